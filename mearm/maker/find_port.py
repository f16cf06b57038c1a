"""``mearm find-port``: which serial port is the arm's board?

Lists the serial ports the system knows, opens each one briefly at the config's baud rate
and listens for the banner the mearm firmware prints when it starts
(``READY mearm_servo 2.0 5``; ``tools/arduino/PROTOCOL.md``). Opening a port resets an
Arduino Uno, so a board running the firmware always prints it. A board that prints it is
asked for its version (``V``) and named; a port that cannot be opened is reported with
the reason. A port another process holds (a mearm command driving its arm: the serial
backends lock their port) is reported in use, with the process, and left alone: the
board it drives is not reset. ::

    mearm find-port                          # every port the system lists
    mearm find-port --port /dev/ttyUSB3      # add a port the list misses (a pty, a link)
    mearm find-port --only --port /dev/ttyACM0   # just this one
    mearm find-port --replug                 # find a board that does not print the banner

``--replug`` finds any board, with or without the firmware: it lists the ports, asks you
to unplug the board and press Enter, lists them again, asks you to plug it back in, and
names the port that came back. Ports given with ``--port`` count as present while their
path exists. It needs a terminal.

A ``--port`` path that is a folder, or (without ``--replug``) does not exist, is bad
input, as is ``--wait`` without ``--replug``: exit 2 before any port is opened.

A config whose board is the virtual Uno (``servo.backend: virtual_uno``) has no port to
find: each command that uses it starts the board on a pseudo-terminal of its own. Without
``--port`` the command says so in one line and exits 0, no port opened (``--replug``
too); with ``--port`` it tries those ports as usual.

Exit status: 0 when a mearm board was found (``--replug``: when the replugged board's port
was found) or the config's board is the virtual Uno, 1 when none was (one line, ``mearm
find-port: error: no mearm board found …``, as every command's failure), 2 on bad input,
130 on Ctrl-C.
"""

from __future__ import annotations

import os
import select
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Literal

import serial
from serial.tools import list_ports

from mearm.cli import (
    EXIT_FAILURE,
    EXIT_OK,
    ArgumentParser,
    add_config_argument,
    config_from_args,
    positive_number,
    run,
)
from mearm.config import Config
from mearm.config.errors import SerialPortError
from mearm.config.port import check_port
from mearm.errors import MearmError
from mearm.hardware.errors import PortInUseError
from mearm.hardware.mearm_protocol import (
    FIRMWARE_NAME,
    PROTOCOL_MAJOR,
    FirmwareInfo,
    Reply,
    decode_line,
    decode_protocol1_banner,
    encode_command,
    parse_firmware_info,
    version_major,
)
from mearm.hardware.serial_bus import open_exclusive

#: USB ids of the boards that run the firmware (the Uno's ``upload_port`` ids in the
#: Arduino core's boards.txt, and the CH340 of most Uno clones) → what to call them.
KNOWN_USB_IDS: dict[tuple[int, int], str] = {
    (0x2341, 0x0043): "Arduino Uno",
    (0x2341, 0x0001): "Arduino Uno",
    (0x2A03, 0x0043): "Arduino Uno",
    (0x2341, 0x0243): "Arduino Uno",
    (0x2341, 0x006A): "Arduino Uno",
    (0x1A86, 0x7523): "CH340 USB serial (most Uno clones)",
}

#: How long to wait for the answer to ``V`` once the banner came [s].
VERSION_TIMEOUT_S = 1.0
#: Bytes heard on a port without a banner that are kept for the report.
_HEARD_KEPT = 40
#: After the user says the board is plugged back in, how long to wait for its port [s]
#: (USB enumeration and udev take about a second).
REPLUG_WAIT_S = 10.0
#: How often the port list is read while waiting [s].
REPLUG_POLL_S = 0.2


class NoBoardFound(MearmError):
    """No board was found: the run could not do its job (exit 1), though its input was fine.

    Raised, not printed, so the line is the one every command ends a failure with
    (``mearm find-port: error: …``, :func:`mearm.cli.run`).
    """

    exit_status = EXIT_FAILURE


NEEDS_TERMINAL = (
    "--replug asks you to unplug and replug the board: it needs a terminal (standard input "
    "is not one)"
)


@dataclass(frozen=True)
class SerialPort:
    """A port the system lists (or one given with ``--port`` whose path exists).

    Attributes:
        device: Its path (or pyserial URL).
        description: What the system says it is ("" when it says nothing).
        usb_id: (vendor id, product id) of a USB port, else ``None``.
    """

    device: str
    description: str = ""
    usb_id: tuple[int, int] | None = None

    @property
    def label(self) -> str:
        """The description, with the board it likely is when its USB id is known."""
        parts = []
        if self.usb_id is not None:
            vid, pid = self.usb_id
            known = KNOWN_USB_IDS.get(self.usb_id)
            parts.append(f"{known + ', ' if known else ''}USB {vid:04x}:{pid:04x}")
        elif self.description and self.description != "n/a":
            parts.append(self.description)
        return "; ".join(parts)


@dataclass(frozen=True)
class PortReport:
    """What was found on one port.

    Attributes:
        port: The port.
        status: ``mearm`` (the firmware's banner), ``outdated`` (the firmware's banner,
            of another protocol version: reflash it), ``unknown`` (opened, no banner),
            ``error`` (could not be opened) or ``busy`` (another process holds it: left
            alone).
        detail: The firmware, what was heard instead of a banner, or why it did not open.
        firmware: The firmware's answer to ``V`` (``mearm`` only, when it answered).
    """

    port: SerialPort
    status: Literal["mearm", "outdated", "unknown", "error", "busy"]
    detail: str
    firmware: FirmwareInfo | None = None


def usable_boards(
    reports: Sequence[PortReport], config: Config | None
) -> tuple[list[str], list[str]]:
    """The ports of the mearm boards the commands can drive, and why each other one not.

    A board that printed its banner but did not answer ``V`` fails every command's
    handshake; so does one whose channels or pulse range do not fit the config's servos
    (:func:`~mearm.hardware.arduino.misfit`).
    """
    from mearm.hardware.arduino import misfit  # noqa: PLC0415
    from mearm.hardware.mapping import ServoMap  # noqa: PLC0415

    smap = None if config is None else ServoMap.from_arm(config.arm)
    usable, unusable = [], []
    for r in reports:
        if r.status != "mearm":
            continue
        device = r.port.device
        if r.firmware is None:
            unusable.append(f"{device} printed the banner but did not answer V")
            continue
        problem = None if smap is None else misfit(r.firmware, smap)
        if problem is not None:
            unusable.append(f"{device}: {problem}")
        else:
            usable.append(device)
    return usable, unusable


def list_serial_ports(extra: Iterable[str] = (), *, system: bool = True) -> list[SerialPort]:
    """The ports the system lists, then each of ``extra`` whose path exists, no repeats.

    pyserial lists USB and on-board serial ports, not pseudo-terminals or links such as
    ``/dev/serial/by-id/…``: give those in ``extra``. A URL in ``extra`` is always present.
    ``system=False``: only ``extra``.
    """
    found: dict[str, SerialPort] = {}
    listed = list_ports.comports() if system else []
    for info in sorted(listed, key=lambda p: p.device):
        usb = (info.vid, info.pid) if info.vid is not None and info.pid is not None else None
        found[info.device] = SerialPort(info.device, info.description or "", usb)
    for port in extra:
        if port not in found and ("://" in port or os.path.exists(port)):
            found[port] = SerialPort(port)
    return list(found.values())


def _open_error(port: str, exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    if isinstance(exc, OSError | serial.SerialException) and "ermission denied" in text:
        text += (
            " (Linux: add yourself to the dialout group, sudo usermod -aG dialout $USER, "
            "then log in again)"
        )
    return text


def _in_use(exc: PortInUseError) -> str:
    """A busy port's report: who holds it, and that it was left alone."""
    if exc.pid is None:
        who = "another process"
    else:
        who = f"process {exc.pid}" + (f" ({exc.command})" if exc.command else "")
    return f"held by {who}: left alone, not reset (stop that program to probe it)"


def probe_port(port: SerialPort, baud: int, timeout_s: float) -> PortReport:
    """Open ``port`` at ``baud``, wait up to ``timeout_s`` for the mearm banner, close it.

    Opening resets an Uno (DTR); its bootloader runs for about 1.5 s before the firmware
    prints the banner. A board that prints it is asked ``V`` for its firmware. A port
    another process holds (a running ``mearm sort`` or ``jog``: the serial backends'
    exclusive lock, :func:`~mearm.hardware.serial_bus.open_exclusive`) is reported
    ``busy`` and left alone: not opened where ``/proc/locks`` names its holder, else
    closed again before pyserial sets the line or DTR, so the board it drives is not
    reset.
    """
    try:
        check_port(port.device)
        ser = open_exclusive(port.device, baud, timeout=0.05, write_timeout=VERSION_TIMEOUT_S)
    except PortInUseError as exc:
        return PortReport(port, "busy", _in_use(exc))
    except (serial.SerialException, OSError, ValueError, SerialPortError) as exc:
        return PortReport(port, "error", _open_error(port.device, exc))
    try:
        return _listen(ser, port, timeout_s)
    except (serial.SerialException, OSError) as exc:
        return PortReport(port, "error", f"failed while listening: {_open_error('', exc)}")
    finally:
        try:
            ser.close()
        except (serial.SerialException, OSError):
            pass


def _lines(ser: serial.SerialBase, deadline: float) -> Iterable[bytes]:
    """Lines read from ``ser`` (newline stripped) until the monotonic ``deadline``."""
    buf = bytearray()
    while time.monotonic() < deadline:
        buf += ser.read(max(1, ser.in_waiting))
        while b"\n" in buf:
            end = buf.index(b"\n")
            yield bytes(buf[:end]).rstrip(b"\r")
            del buf[: end + 1]
        if len(buf) > 256:  # no newline in a flood: look at it as a line
            yield bytes(buf)
            buf.clear()
    if buf:
        yield bytes(buf)


def _listen(ser: serial.SerialBase, port: SerialPort, timeout_s: float) -> PortReport:
    heard = bytearray()
    for line in _lines(ser, time.monotonic() + timeout_s):
        decoded = decode_line(line)
        if isinstance(decoded, Reply) and decoded.kind == "READY":
            name = decoded.fields[0] if decoded.fields else ""
            if name != FIRMWARE_NAME:
                return PortReport(port, "unknown", f"its banner names firmware {name!r}")
            version = decoded.fields[1] if len(decoded.fields) > 1 else ""
            if version_major(version) not in (PROTOCOL_MAJOR, -1):  # (-1: none given)
                return _outdated(port, f"{name} {version}", version_major(version))
            return _ask_version(ser, port, decoded)
        old = decode_protocol1_banner(line)  # lines checked by an XOR: flashed before
        if old is not None:
            return _outdated(port, " ".join(old.fields[:2]), 1)
        if len(heard) < _HEARD_KEPT:
            heard += line[: _HEARD_KEPT - len(heard)] + b"\n"
    if heard.strip(b"\x00\r\n \xfe"):
        return PortReport(
            port,
            "unknown",
            f"no mearm banner in {timeout_s:g} s; heard {bytes(heard).rstrip()!r} "
            "(another program, or the wrong baud rate?)",
        )
    return PortReport(port, "unknown", f"silent for {timeout_s:g} s: no mearm banner")


def _outdated(port: SerialPort, firmware: str, major: int) -> PortReport:
    """A board running the mearm firmware of another protocol: reflash it.

    No command of this host's would be read; ``mearm flash`` puts the one this mearm ships
    on it.
    """
    return PortReport(
        port,
        "outdated",
        f"{firmware} speaks protocol {major}, this host {PROTOCOL_MAJOR}: reflash it "
        f"(mearm flash --port {port.device})",
    )


def _ask_version(ser: serial.SerialBase, port: SerialPort, banner: Reply) -> PortReport:
    version = " ".join(banner.fields[:2])
    ser.write(encode_command(0, "V"))
    ser.flush()
    for line in _lines(ser, time.monotonic() + VERSION_TIMEOUT_S):
        decoded = decode_line(line)
        if isinstance(decoded, Reply) and decoded.kind == "OK" and decoded.seq == 0:
            info = parse_firmware_info(decoded)
            if info is not None:
                detail = (
                    f"{info.name} {info.version}, {info.servo_count} servos, "
                    f"pulses {info.min_us}..{info.max_us} µs"
                )
                return PortReport(port, "mearm", detail, info)
    return PortReport(port, "mearm", f"{version} (printed its banner but did not answer V)")


def probe_ports(ports: Sequence[SerialPort], baud: int, timeout_s: float) -> list[PortReport]:
    """:func:`probe_port` on every port at once (the waits overlap), in the given order."""
    if not ports:
        return []
    with ThreadPoolExecutor(max_workers=min(8, len(ports))) as pool:
        return list(pool.map(lambda p: probe_port(p, baud, timeout_s), ports))


def format_report(report: PortReport, width: int) -> str:
    """One line: the port, what is on it, and what the system calls it."""
    what = {
        "mearm": "mearm board:",
        "outdated": "mearm board of another protocol:",
        "unknown": "not a mearm board:",
        "error": "cannot open:",
        "busy": "in use:",
    }[report.status]
    label = f"  [{report.port.label}]" if report.port.label else ""
    return f"  {report.port.device:<{width}}  {what} {report.detail}{label}"


# --------------------------------------------------------------------------- replug


@dataclass(frozen=True)
class ReplugResult:
    """What unplugging and replugging changed in the port list.

    Attributes:
        gone: Ports present before unplugging and missing after.
        new: Ports missing after unplugging and present after replugging.
    """

    gone: tuple[str, ...]
    new: tuple[str, ...]


def replug(
    present: Callable[[], set[str]],
    prompt: Callable[[str], None],
    wait_s: float = REPLUG_WAIT_S,
    poll_s: float = REPLUG_POLL_S,
) -> ReplugResult:
    """Diff the port list around an unplug and a replug.

    Args:
        present: The ports present now.
        prompt: Shows a message and returns when the user pressed Enter.
        wait_s: After the replug prompt, how long to wait for a new port [s].
        poll_s: How often the list is read while waiting [s].
    """
    before = present()
    prompt("Unplug the board's USB cable, then press Enter: ")
    unplugged = present()
    prompt("Plug it back in, then press Enter: ")
    deadline = time.monotonic() + wait_s
    new = present() - unplugged
    while not new and time.monotonic() < deadline:
        time.sleep(poll_s)
        new = present() - unplugged
    return ReplugResult(tuple(sorted(before - unplugged)), tuple(sorted(new)))


def _terminal_prompt() -> Callable[[str], None]:
    try:
        interactive = sys.stdin is not None and sys.stdin.isatty()
    except (ValueError, OSError):  # a closed stream
        interactive = False
    if not interactive:
        raise MearmError(NEEDS_TERMINAL)

    def ask(text: str) -> None:
        # Not input(): a Ctrl-C the kernel delivers to another thread (numpy's) would
        # leave it blocked in read(); waking every 0.1 s lets the interrupt through.
        print(text, end="", flush=True)
        while not select.select([sys.stdin], [], [], 0.1)[0]:
            pass
        if not sys.stdin.readline():
            raise MearmError(f"input ended at the prompt: {NEEDS_TERMINAL}")

    return ask


def _run_replug(
    extra: Sequence[str],
    baud: int,
    timeout_s: float,
    wait_s: float,
    prompt: Callable[[str], None],
    *,
    system: bool,
) -> int:
    result = replug(
        lambda: {p.device for p in list_serial_ports(extra, system=system)}, prompt, wait_s
    )
    if not result.new:
        if result.gone:
            why = f"{', '.join(result.gone)} went away but no port came back in {wait_s:g} s"
        else:
            why = (
                "no port went away or came back: a charge-only USB cable, or a board whose "
                "USB driver is missing (see the kernel log: sudo dmesg | tail)"
            )
        raise NoBoardFound(f"no board found: {why}")
    if len(result.new) > 1:
        raise NoBoardFound(
            f"several ports came back ({', '.join(result.new)}): unplug the other devices "
            "and try again"
        )
    device = result.new[0]
    ports = {p.device: p for p in list_serial_ports(extra, system=system)}
    port = ports.get(device, SerialPort(device))
    print(f"the board is on {device}" + (f"  [{port.label}]" if port.label else ""))
    if result.gone and result.gone != (device,):
        print(f"  (before unplugging it was {', '.join(result.gone)})")
    report = probe_port(port, baud, timeout_s)
    print(format_report(report, len(device)))
    if report.status == "mearm":
        print(f"set servo.port: {device} in your config (or --set servo.port={device})")
    elif report.status == "busy":
        print("stop the program that holds it, then run find-port again to probe it")
    else:
        print(f"to put the mearm firmware on it: mearm flash --port {device}")
    return EXIT_OK


# --------------------------------------------------------------------------- main


def check_given_port(port: str, *, replug: bool) -> None:
    """Refuse a ``--port`` that cannot be a serial port, before any port is opened.

    A folder never is; a path that does not exist is a typo or an unplugged board, except
    with ``--replug``, where the board's port (a ``/dev/serial/by-id`` link) is gone while
    it is unplugged.

    Raises:
        MearmError: as :func:`~mearm.config.port.check_port`, or the path is a folder, or
            it does not exist (without ``replug``).
    """
    check_port(port)
    if "://" in port:
        return
    if os.path.isdir(port):
        raise MearmError(f"--port {port} is a folder, not a serial port (mearm find-port "
                         "lists the ports)")  # fmt: skip
    if not replug and not os.path.exists(port):
        raise MearmError(
            f"--port {port} does not exist: is the board plugged in? (mearm find-port "
            "without --port lists the ports; --replug finds one)"
        )


def main(argv: Sequence[str] | None = None) -> int:
    """List the serial ports and name the mearm boards; see the module docstring."""
    parser = ArgumentParser(
        prog="mearm find-port",
        description="List the serial ports and name the one with a mearm board "
        "(the firmware's banner), or find an unknown board by unplugging and replugging it.",
        epilog="Exit status: 0 a mearm board was found (--replug: the board's port was "
        "found) or the config's board is the virtual Uno (nothing to find), 1 none was, "
        "2 bad input.",
    )
    add_config_argument(parser)
    parser.add_argument(
        "--port",
        action="append",
        default=[],
        metavar="PORT",
        help="also try this port (a pseudo-terminal, a /dev/serial/by-id link, a "
        "socket:// URL); repeatable",
    )
    parser.add_argument(
        "--only",
        action="store_true",
        help="try only the ports given with --port, not the ones the system lists",
    )
    parser.add_argument(
        "--timeout",
        type=positive_number(0.1, 60.0, "s"),
        default=None,
        metavar="SECONDS",
        help="how long to listen for the banner on each port, in seconds "
        "(default: servo.banner_timeout_s of the config, 3 s)",
    )
    parser.add_argument(
        "--replug",
        action="store_true",
        help="find the board by unplugging and replugging it (asks you on the terminal)",
    )
    parser.add_argument(
        "--wait",
        type=positive_number(0.1, 600.0, "s"),
        default=None,
        metavar="SECONDS",
        help=f"--replug: after you plug the board back in, wait this long for its port, "
        f"in seconds (default {REPLUG_WAIT_S:g})",
    )
    args = parser.parse_args(argv)
    if args.wait is not None and not args.replug:
        raise MearmError("--wait is how long --replug waits for the replugged board: give "
                         "--replug too, or leave --wait out")  # fmt: skip
    if args.only and not args.port:  # no port left to try: not "no board found"
        raise MearmError("--only tries only the ports given with --port: give --port PORT "
                         "too, or leave --only out")  # fmt: skip
    for port in args.port:
        check_given_port(port, replug=args.replug)
    config = config_from_args(args)
    if config.servo.backend == "virtual_uno" and not args.port:
        # its port exists only inside each command that starts it: none to find or set
        print(
            "find-port: nothing to do: the config's board is the virtual Uno (servo.backend: "
            "virtual_uno), which each command that uses the config starts on a port of its "
            "own; there is no port to find or set"
        )
        return EXIT_OK
    baud = config.servo.baud
    timeout_s = args.timeout if args.timeout is not None else config.servo.banner_timeout_s
    if args.replug:
        prompt = _terminal_prompt()
        wait_s = args.wait if args.wait is not None else REPLUG_WAIT_S
        return _run_replug(args.port, baud, timeout_s, wait_s, prompt, system=not args.only)

    ports = list_serial_ports(args.port, system=not args.only)
    if not ports:
        raise NoBoardFound(
            "no serial ports found: is the board plugged in? (--replug finds it by "
            "unplugging and replugging)"
        )
    print(
        f"{len(ports)} serial port{'s' if len(ports) != 1 else ''}; listening on each for "
        f"{timeout_s:g} s at {baud} baud (opening a port resets an Arduino):"
    )
    reports = probe_ports(ports, baud, timeout_s)
    width = max(len(r.port.device) for r in reports)
    for report in reports:
        print(format_report(report, width))
    boards, unusable = usable_boards(reports, config)
    outdated = [r.port.device for r in reports if r.status == "outdated"]
    if not boards and outdated:
        # a board is there, with the mearm firmware of another protocol: the remedy is to
        # reflash it, as its line above says, not to flash some other board
        where = outdated[0] if len(outdated) == 1 else "PORT"
        raise NoBoardFound(
            f"no mearm board found that speaks protocol {PROTOCOL_MAJOR}: reflash the one "
            f"of another protocol on {', '.join(outdated)} (mearm flash --port {where})"
        )
    if not boards and unusable:  # a board the other commands would refuse at the handshake
        named = args.config if args.config is not None else "sim, the default"
        raise NoBoardFound(f"no mearm board the config ({named}) can use: {unusable[0]}")
    busy = [r.port.device for r in reports if r.status == "busy"]
    if not boards and busy:  # likely the board, driven by a mearm command running now
        raise NoBoardFound(
            f"no free mearm board found: {', '.join(busy)} "
            f"{'is' if len(busy) == 1 else 'are'} in use by another process (a mearm "
            "command running now?), left alone: stop it, then run find-port again"
        )
    if not boards:
        raise NoBoardFound(
            "no mearm board found: flash one (mearm flash --port PORT), or find an unknown "
            "board with mearm find-port --replug"
        )
    if len(boards) == 1:
        print(f"set servo.port: {boards[0]} in your config (or --set servo.port={boards[0]})")
    return EXIT_OK


if __name__ == "__main__":
    run(main)
