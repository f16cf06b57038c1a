"""Measure how closely the virtual Uno's pins follow the commands (the firmware in simavr).

Sends random servo commands (every channel, 500–2500 µs) to the project's firmware on a
simulated ATmega328P and measures, for each acknowledged command, the first servo frame
the emulated pins produce after the acknowledgement: the difference from the command,
per pulse [µs]. Builds the firmware and the harness on first use (needs make, gcc-avr,
avr-libc, arduino-core-avr, gcc, libsimavr-dev, libelf-dev).

    mearm virtual-uno-pulses --commands 2000 [--json FILE [--force]]

``--json`` writes the figures marked ``"simulated": true``. An existing ``--json`` is
refused before the measurement unless ``--force``; once written, ``wrote FILE`` follows
the figures (also when a pulse is beyond the tolerance).
"""

from __future__ import annotations

import json
import random
import statistics
import sys
from collections.abc import Sequence
from pathlib import Path

import serial

from mearm.cli import (
    EXIT_FAILURE,
    EXIT_OK,
    ArgumentParser,
    check_output_file,
    plain_int,
    refuse_to_replace,
    run,
    seed_value,
    write_text_atomic,
)
from mearm.config.sections import VirtualUnoConfig
from mearm.errors import MearmError
from mearm.hardware.mearm_protocol import encode_command
from mearm.sim.virtual_uno import VirtualUno, build_virtual_uno

#: The servo channels the firmware drives.
CHANNELS = 5
#: The pulse range the random commands span [µs].
LOW_US, HIGH_US = 500, 2500


def pulse_errors(commands: int, seed: int = 0, cache_dir: Path | None = None) -> list[float]:
    """|measured − commanded| [µs] of every pulse of the first frame after each command.

    Raises:
        MearmError: the build or the board failed, or a command was not acknowledged.
    """
    build = build_virtual_uno(cache_dir=cache_dir)
    rng = random.Random(seed)
    errors: list[float] = []
    with (
        VirtualUno(build, speed=0) as board,
        serial.Serial(board.port, 115200, timeout=2.0) as link,
    ):
        banner = link.readline()
        while b"READY" not in banner:
            if not banner:
                raise MearmError("the virtual Uno printed no banner within 2 s")
            banner = link.readline()
        for seq in range(commands):
            pulses = [rng.randint(LOW_US, HIGH_US) for _ in range(CHANNELS)]
            link.write(encode_command(seq % 256, "M", pulses))
            reply = link.readline()
            while reply.startswith(b"!"):  # a watchdog notice on a loaded machine
                reply = link.readline()
            if not reply.startswith(b"OK"):
                raise MearmError(f"command {seq} was answered {reply[:40]!r}, not OK")
            sent_at = board.reply_time_us()
            frame = None if sent_at is None else board.frame_after(sent_at, range(CHANNELS))
            if frame is None or sorted(frame.widths_us) != list(range(CHANNELS)):
                raise MearmError(f"no whole servo frame after command {seq}")
            errors += [abs(frame.widths_us[ch] - us) for ch, us in enumerate(pulses)]
    return errors


def summary(errors: Sequence[float]) -> dict[str, float]:
    """Median, mean and max |error| [µs] and the share within 1 µs."""
    return {
        "pulses": len(errors),
        "median_us": statistics.median(errors),
        "mean_us": statistics.mean(errors),
        "max_us": max(errors),
        "within_1us": sum(e <= 1.0 for e in errors) / len(errors),
    }


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: exit 0 when every pulse is within the virtual Uno's tolerance."""
    parser = ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--commands", type=plain_int, default=500,
        help="random commands to send (default 500; 5 pulses each)",
    )  # fmt: skip
    parser.add_argument("--seed", type=seed_value, default=0, help="random seed (default 0)")
    parser.add_argument(
        "--json", type=Path, help='write the figures here (marked "simulated": true)'
    )
    parser.add_argument("--force", action="store_true", help="replace an existing --json")
    args = parser.parse_args(argv)
    if not 1 <= args.commands <= 100_000:
        parser.error(f"--commands must be from 1 to 100000, got {args.commands}")
    if args.json is not None:  # before the measurement, not after it
        check_output_file(args.json, "--json")
        refuse_to_replace(args.json, "--json", args.force)
    errors = pulse_errors(args.commands, args.seed)
    s = summary(errors)
    tolerance = VirtualUnoConfig().pulse_tolerance_us
    print(
        f"{s['pulses']} pulses: |error| median {s['median_us']:.2f} µs, mean "
        f"{s['mean_us']:.2f} µs, max {s['max_us']:.1f} µs; {100 * s['within_1us']:.1f} % "
        f"within 1 µs (simulated: the firmware in simavr)"
    )
    if args.json:
        record = {"simulated": True, **s}  # the firmware in simavr, not a board
        write_text_atomic(args.json, json.dumps(record, indent=2) + "\n")
        print(f"wrote {args.json}")
    if s["max_us"] > tolerance:
        print(
            f"mearm virtual-uno-pulses: a pulse is {s['max_us']:.1f} µs off, beyond the "
            f"{tolerance:g} µs the virtual Uno accepts",
            file=sys.stderr,
        )
        return EXIT_FAILURE
    return EXIT_OK


if __name__ == "__main__":
    run(main)
