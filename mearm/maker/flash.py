"""``mearm flash``: build the Uno firmware and upload it, with Debian's tools and no IDE.

Two commands, printed before they run::

    make -C <firmware source> BUILD_DIR=<build dir>
    avrdude -p atmega328p -c arduino -P <port> -b 115200 -D -U flash:w:<build dir>/mearm_servo.hex:i

then the port is opened and the firmware's banner awaited, to show that the board runs
it. The upload settings are the Arduino Uno's (the Arduino core's boards.txt:
``upload.protocol=arduino``, ``upload.speed=115200``, ``build.mcu=atmega328p``); an old
Uno or Nano bootloader needs ``--upload-baud 57600``.

``--dry-run`` checks the tools, prints the two commands and runs neither: nothing is built
and nothing is written (a missing tool is reported as a note; the exit status is 0).

Tools: ``sudo apt-get install make gcc-avr avr-libc arduino-core-avr avrdude``. A missing
one stops the command before anything runs, with one line naming its Debian package
(exit 2); so does a ``--port`` that does not exist or is a folder (not checked by
``--dry-run``, which may run with no board plugged in). The build goes to
``--build-dir`` (default ``~/.cache/mearm/firmware``), so the firmware source may be
read-only (an installed package); once built, it is named on stdout before the upload
(``wrote DIR/ (the firmware's build: mearm_servo.hex and its objects)``), as every file or
folder a command writes is.

A config whose board is the virtual Uno (``servo.backend: virtual_uno``) has nothing to
flash: that board runs the firmware built from the source each time a command starts
it, and has no port. Without ``--port`` the command says so in one line and exits 0,
nothing built or run (``--dry-run`` too); with ``--port`` it flashes that board.
"""

from __future__ import annotations

import shlex
import subprocess
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from mearm.cli import (
    EXIT_FAILURE,
    EXIT_OK,
    ArgumentParser,
    add_config_argument,
    check_output_folder,
    config_from_args,
    plain_int,
    run,
)
from mearm.data import firmware_source_dir
from mearm.errors import MearmError
from mearm.hardware import toolchain
from mearm.hardware.toolchain import (
    FIRMWARE_BUILD,
    UPLOAD,
    cache_dir,
    describe_missing,
)

#: The sketch's name: ``<source>/mearm_servo/mearm_servo.ino`` → ``<build>/mearm_servo.hex``.
SKETCH = "mearm_servo"
#: The Uno's upload settings (boards.txt: ``uno.build.mcu``, ``uno.upload.protocol``,
#: ``uno.upload.speed``).
MCU = "atmega328p"
PROGRAMMER = "arduino"
UPLOAD_BAUD = 115200
#: Bootloaders answer at one of these [baud] (57600: Uno and Nano before optiboot).
UPLOAD_BAUDS = (57600, 115200)
#: Longest build and upload [s].
BUILD_TIMEOUT_S = 600.0
UPLOAD_TIMEOUT_S = 120.0


def default_build_dir() -> Path:
    """``$XDG_CACHE_HOME/mearm/firmware``, else ``~/.cache/mearm/firmware``."""
    return cache_dir("firmware")


@dataclass(frozen=True)
class FlashPlan:
    """The two commands of a flash.

    Attributes:
        build: The ``make`` command.
        upload: The ``avrdude`` command.
        hex_file: The firmware image the build writes and the upload reads.
    """

    build: tuple[str, ...]
    upload: tuple[str, ...]
    hex_file: Path


def plan_flash(source: Path, build_dir: Path, port: str, upload_baud: int) -> FlashPlan:
    """The build and upload commands for the firmware in ``source``, onto ``port``."""
    build_dir = build_dir.resolve()
    hex_file = build_dir / f"{SKETCH}.hex"
    build = ("make", "-C", str(source), f"BUILD_DIR={build_dir}")
    upload = (
        "avrdude",
        "-p", MCU,
        "-c", PROGRAMMER,
        "-P", port,
        "-b", str(upload_baud),
        "-D",
        "-U", f"flash:w:{hex_file}:i",
    )  # fmt: skip
    return FlashPlan(build, upload, hex_file)


def _check_port(text: str) -> str:
    if not text or text != text.strip() or text.startswith("-") or "://" in text:
        raise MearmError(
            f"--port must be the board's device path, e.g. /dev/ttyACM0, got {text!r} "
            "(mearm find-port lists them)"
        )
    return text


def _check_port_is_there(port: str) -> None:
    """Refuse, before the build, a port avrdude could only fail on (a minute later)."""
    if Path(port).is_dir():
        raise MearmError(f"--port {port} is a folder, not a serial port (mearm find-port "
                         "lists them)")  # fmt: skip
    if not Path(port).exists():
        raise MearmError(f"--port {port} does not exist: is the board plugged in? (mearm "
                         "find-port lists the ports)")  # fmt: skip
    _check_port_is_free(port)


def _check_port_is_free(port: str) -> None:
    """Refuse a port a running mearm command holds (exit 2, one line).

    :class:`~mearm.hardware.errors.PortInUseError` names it. avrdude would reset the
    board it drives mid-move and overwrite its firmware. Read from ``/proc/locks`` (the
    serial backends' lock); avrdude itself takes no lock, and a program that takes none
    is not seen.
    """
    from mearm.hardware.serial_bus import check_port_free  # noqa: PLC0415  (pyserial)

    check_port_free(port)


def _run_step(what: str, command: Sequence[str], timeout_s: float) -> bool:
    """Run ``command`` with its output on the terminal; ``False`` (said why) if it failed."""
    print(f"$ {shlex.join(command)}", flush=True)
    try:
        result = subprocess.run(command, timeout=timeout_s, check=False)
    except subprocess.TimeoutExpired:
        print(f"flash: the {what} took longer than {timeout_s:g} s; stopped", file=sys.stderr)
        return False
    except OSError as exc:
        print(f"flash: cannot run {command[0]}: {exc}", file=sys.stderr)
        return False
    if result.returncode != 0:
        print(f"flash: the {what} failed (exit {result.returncode}; its output is above)",
              file=sys.stderr)  # fmt: skip
        return False
    return True


def main(argv: Sequence[str] | None = None) -> int:
    """Build and upload the firmware; see the module docstring."""
    parser = ArgumentParser(
        prog="mearm flash",
        description="Build the mearm firmware and upload it to an Arduino Uno with avrdude, "
        "then check that the board prints the firmware's banner.",
        epilog="Needs: sudo apt-get install make gcc-avr avr-libc arduino-core-avr avrdude. "
        "Exit status: 0 flashed and answering (--dry-run: commands printed; a virtual Uno "
        "config without --port: nothing to flash), 1 the build, the upload or the check "
        "failed, 2 bad input or a missing tool.",
    )
    add_config_argument(parser)
    parser.add_argument(
        "--port",
        default=None,
        help="the board's serial port (default: servo.port of the config, /dev/ttyACM0); "
        "mearm find-port lists them",
    )
    parser.add_argument(
        "--upload-baud",
        type=plain_int,
        choices=UPLOAD_BAUDS,
        default=UPLOAD_BAUD,
        help="the bootloader's baud rate (default 115200, the Uno's; 57600 for an old Uno "
        "or Nano bootloader)",
    )
    parser.add_argument(
        "--build-dir",
        type=Path,
        default=None,
        metavar="DIR",
        help="where to build (default ~/.cache/mearm/firmware)",
    )
    parser.add_argument(
        "--dry-run",
        action="store_true",
        help="print the commands and run neither (nothing is built or uploaded)",
    )
    parser.add_argument(
        "--no-check",
        action="store_true",
        help="after the upload, do not wait for the firmware's banner",
    )
    args = parser.parse_args(argv)
    config = config_from_args(args)
    source = firmware_source_dir()
    if config.servo.backend == "virtual_uno" and args.port is None:
        # its board already runs the firmware it would get, and has no port to upload to
        print(
            "flash: nothing to do: the config's board is the virtual Uno (servo.backend: "
            f"virtual_uno), which runs the firmware built from {source} each time a command "
            "starts it; --port flashes a real board"
        )
        return EXIT_OK
    if config.servo.backend == "ssc32":  # its port and baud are the SSC-32's, not an Uno's
        raise MearmError(
            "the config's board is an SSC-32 (servo.backend: ssc32), which runs its own "
            "firmware: flash uploads mearm's to an Uno; give a config whose servo.backend "
            "is serial (e.g. --config lab)"
        )
    port = _check_port(args.port if args.port is not None else config.servo.port)
    build_dir = args.build_dir if args.build_dir is not None else default_build_dir()
    check_output_folder(build_dir, "--build-dir")  # a file there: said before anything runs
    plan = plan_flash(source, build_dir, port, args.upload_baud)
    missing = toolchain.missing((*FIRMWARE_BUILD, *UPLOAD))

    if args.dry_run:
        print(shlex.join(plan.build))
        print(shlex.join(plan.upload))
        if not args.no_check:
            print(f"# then: wait for the firmware's banner on {port} at {config.servo.baud} baud")
        if missing:
            print(f"flash: note: {describe_missing(missing)}", file=sys.stderr)
        return EXIT_OK

    if missing:
        raise MearmError(describe_missing(missing))
    _check_port_is_there(port)
    try:
        build_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MearmError(f"cannot make the build folder {build_dir}: {exc}") from None
    if not _run_step("build", plan.build, BUILD_TIMEOUT_S):
        return EXIT_FAILURE
    if not plan.hex_file.is_file():
        print(f"flash: the build wrote no {plan.hex_file}", file=sys.stderr)
        return EXIT_FAILURE
    print(f"wrote {plan.hex_file.parent}/ (the firmware's build: {plan.hex_file.name} and "
          "its objects)", flush=True)  # fmt: skip
    _check_port_is_free(port)  # again: a sort may have started during the build
    if not _run_step("upload", plan.upload, UPLOAD_TIMEOUT_S):
        print(
            "flash: check the port (mearm find-port), that no other program holds it, and "
            "--upload-baud 57600 for an old bootloader",
            file=sys.stderr,
        )
        return EXIT_FAILURE
    if args.no_check:
        print(f"uploaded {plan.hex_file} to {port}")
        return EXIT_OK
    from mearm.maker.find_port import SerialPort, format_report, probe_port, usable_boards

    report = probe_port(SerialPort(port), config.servo.baud, config.servo.banner_timeout_s)
    print(format_report(report, len(port)))
    if report.status != "mearm":
        print(
            f"flash: avrdude reported success but the board on {port} does not print the "
            "mearm banner",
            file=sys.stderr,
        )
        return EXIT_FAILURE
    _, unusable = usable_boards([report], config)
    if unusable:  # (as find-port: every command's handshake would refuse it)
        named = args.config if args.config is not None else "sim, the default"
        print(
            f"flash: the board runs the mearm firmware, but the config ({named}) cannot use "
            f"it: {unusable[0]}",
            file=sys.stderr,
        )
        return EXIT_FAILURE
    print(f"the board on {port} runs the mearm firmware: set servo.port: {port} in your config")
    return EXIT_OK


if __name__ == "__main__":
    run(main)
