r"""Our servo protocol (``tools/arduino/PROTOCOL.md``): frames, checksum and parser.

ASCII lines a person can read in a serial monitor. Every line ends ``*HH\n``, where
``HH`` is the XOR of all bytes before the ``*`` in two upper-case hex digits (NMEA style).

Host → board, ``<seq> <cmd>[ <arg>…]*HH\n`` with ``seq`` in 0–255 (a resend keeps its
number, so the board acknowledges a duplicate without acting on it twice)::

    7 V*HH                          version: name, version, servo count, pulse range
    8 M 1800 1530 1080 2100 1000*HH one pulse per channel [µs]; 0 = no pulse
    9 S*HH                          stop: hold the current pulses
    10 Q*HH                         query: state and current pulses

Board → host::

    READY mearm_servo 1.0 5*HH      banner, printed on boot (DTR reset)
    OK <seq>[ <field>…]*HH          acknowledgement
    ERR <seq|-> <code> <word>*HH    numbered error (:data:`ERROR_CODES`)
    ! <text>*HH                     notice, e.g. ``! HOLD`` when the watchdog holds

This module does no I/O; :class:`mearm.hardware.arduino.ArduinoBus` does.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

FIRMWARE_NAME = "mearm_servo"
#: Protocol major version: a board with another major version is refused.
PROTOCOL_MAJOR = 1
#: Longest line either side sends, without the newline [bytes] (the firmware's buffer).
MAX_LINE = 80
SEQ_MODULO = 256

ERR_CHECKSUM = 1
ERR_MALFORMED = 2
ERR_UNKNOWN_COMMAND = 3
ERR_ARGUMENT_COUNT = 4
ERR_PULSE_RANGE = 5
ERR_LINE_TOO_LONG = 6

#: What each error number means (tools/arduino/PROTOCOL.md, the firmware's ``E_*``).
ERROR_CODES: dict[int, str] = {
    ERR_CHECKSUM: "checksum mismatch",
    ERR_MALFORMED: "malformed frame",
    ERR_UNKNOWN_COMMAND: "unknown command",
    ERR_ARGUMENT_COUNT: "wrong number of arguments",
    ERR_PULSE_RANGE: "pulse out of range",
    ERR_LINE_TOO_LONG: "line too long",
}

_HEX = frozenset(b"0123456789ABCDEFabcdef")


def checksum(body: bytes) -> int:
    """XOR of all bytes of ``body`` (the part of a line before ``*``)."""
    value = 0
    for b in body:
        value ^= b
    return value


def encode_line(body: str) -> bytes:
    r"""A full line: ``body*HH\n``.

    Raises:
        ValueError: ``body`` is not printable ASCII, contains ``*`` or is too long.
    """
    raw = body.encode("ascii")
    if any(b < 0x20 or b > 0x7E for b in raw) or b"*" in raw:
        raise ValueError(f"frame body must be printable ASCII without '*': {body!r}")
    line = raw + b"*%02X" % checksum(raw)
    if len(line) > MAX_LINE:
        raise ValueError(f"frame of {len(line)} bytes exceeds {MAX_LINE}: {body!r}")
    return line + b"\n"


def encode_command(seq: int, command: str, args: Sequence[int] = ()) -> bytes:
    r"""A host command frame: ``encode_command(8, "M", [1500, 0])`` → ``b"8 M 1500 0*HH\n"``.

    Raises:
        ValueError: ``seq`` outside 0–255, a bad command letter or a negative argument.
    """
    if not 0 <= seq < SEQ_MODULO:
        raise ValueError(f"seq must be in 0..{SEQ_MODULO - 1}, got {seq}")
    if len(command) != 1 or not command.isalpha() or not command.isupper():
        raise ValueError(f"command must be one upper-case letter, got {command!r}")
    if any(int(a) != a or a < 0 for a in args):
        raise ValueError(f"arguments must be non-negative integers, got {list(args)!r}")
    return encode_line(" ".join([str(seq), command, *(str(int(a)) for a in args)]))


@dataclass(frozen=True)
class Reply:
    """A well-formed board line.

    Attributes:
        kind: ``OK``, ``ERR``, ``READY`` (banner) or ``NOTE`` (``! …``).
        seq: The sequence number it answers (``None`` for banner, notice, or ``ERR -``).
        fields: The remaining space-separated fields.
        raw: The line as received, without the newline.
    """

    kind: Literal["OK", "ERR", "READY", "NOTE"]
    seq: int | None
    fields: tuple[str, ...]
    raw: bytes

    @property
    def code(self) -> int:
        """The error number of an ``ERR`` reply (0 otherwise)."""
        if self.kind != "ERR" or not self.fields or not self.fields[0].isdigit():
            return 0
        return int(self.fields[0])

    @property
    def detail(self) -> str:
        """The text after the error number of an ``ERR`` reply."""
        return " ".join(self.fields[1:]) if self.kind == "ERR" else ""


@dataclass(frozen=True)
class BadChecksum:
    """A line shaped like a frame whose checksum does not match: corrupted on the wire."""

    raw: bytes


@dataclass(frozen=True)
class Unparseable:
    """Bytes that are not a frame at all (noise, a bootloader, the wrong baud rate)."""

    raw: bytes


Decoded = Reply | BadChecksum | Unparseable


def _seq(token: str) -> int | None:
    if token.isdigit() and len(token) <= 3 and int(token) < SEQ_MODULO:
        return int(token)
    return None


def split_frame(line: bytes) -> tuple[bytes, bool] | None:
    """Split ``body*HH`` into (body, checksum ok); ``None`` if it is not frame-shaped."""
    line = line.rstrip(b"\r\n")
    star = line.rfind(b"*")
    if star < 0 or len(line) - star != 3 or not set(line[star + 1 :]) <= _HEX:
        return None
    body = line[:star]
    if any(b < 0x20 or b > 0x7E for b in body):
        return None
    return body, checksum(body) == int(line[star + 1 :], 16)


def decode_line(line: bytes) -> Decoded:
    """Parse one board line (without or with its newline)."""
    raw = line.rstrip(b"\r\n")
    split = split_frame(raw)
    if split is None:
        return Unparseable(raw)
    body, ok = split
    if not ok:
        return BadChecksum(raw)
    tokens = body.decode("ascii").split(" ")
    head, rest = tokens[0], tokens[1:]
    if head == "OK" and rest and _seq(rest[0]) is not None:
        return Reply("OK", _seq(rest[0]), tuple(rest[1:]), raw)
    if head == "ERR" and len(rest) >= 2 and rest[1].isdigit():
        if rest[0] == "-" or _seq(rest[0]) is not None:
            return Reply("ERR", _seq(rest[0]), tuple(rest[1:]), raw)
    if head == "READY":
        return Reply("READY", None, tuple(rest), raw)
    if head == "!":
        return Reply("NOTE", None, tuple(rest), raw)
    return Unparseable(raw)


@dataclass(frozen=True)
class FirmwareInfo:
    """What the board reports in its ``V`` reply.

    Attributes:
        name: Firmware name (``mearm_servo``).
        version: ``major.minor``.
        servo_count: Number of servo channels it drives.
        min_us: Lowest pulse it accepts [µs].
        max_us: Highest pulse it accepts [µs].
    """

    name: str
    version: str
    servo_count: int
    min_us: int
    max_us: int

    @property
    def major(self) -> int:
        """The protocol major version (``-1`` if the version is not ``major.minor``)."""
        head = self.version.split(".")[0]
        return int(head) if head.isdigit() else -1


def parse_firmware_info(reply: Reply) -> FirmwareInfo | None:
    """The :class:`FirmwareInfo` of an ``OK`` reply to ``V``, or ``None`` if malformed."""
    f = reply.fields
    if reply.kind != "OK" or len(f) != 5 or not all(x.isdigit() for x in f[2:]):
        return None
    return FirmwareInfo(f[0], f[1], int(f[2]), int(f[3]), int(f[4]))
