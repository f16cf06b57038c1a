r"""Our servo protocol (``tools/arduino/PROTOCOL.md``): frames, checksum and parser.

ASCII lines a person can read in a serial monitor. Every line ends ``*HHHH\n``, where
``HHHH`` is the CRC-16/XMODEM (polynomial 0x1021, initial value 0) of all bytes before
the ``*`` in four upper-case hex digits: :func:`binascii.crc_hqx` here, avr-libc's
``_crc_xmodem_update`` in the firmware. On lines of at most 80 characters it catches
every error of 1, 2 or 3 bits and every burst of up to 16 bits; protocol 1 ended its
lines in the XOR of the bytes (``*HH``), which missed the same bit flipped in two bytes
(``1500 1500`` read as ``1400 1501``). A board still speaking protocol 1 is recognised by
its banner (:func:`decode_protocol1_banner`) and refused before anything is sent.

Host → board, ``<seq> <cmd>[ <arg>…]*HHHH\n`` with ``seq`` in 0–255 (a resend keeps its
number, so the board acknowledges a duplicate without acting on it twice)::

    7 V*HHHH                            version: name, version, servo count, pulse range
    8 M 1800 1530 1080 2100 1000*HHHH   one pulse per channel [µs]; 0 = no pulse
    9 S*HHHH                            stop: hold the current pulses
    10 Q*HHHH                           query: state and current pulses

Board → host::

    READY mearm_servo 2.0 5*HHHH        banner, printed on boot (DTR reset)
    OK <seq>[ <field>…]*HHHH            acknowledgement
    ERR <seq|-> <code> <word>*HHHH      numbered error (:data:`ERROR_CODES`)
    ! <text>*HHHH                       notice, e.g. ``! HOLD`` when the watchdog holds

This module does no I/O; :class:`mearm.hardware.arduino.ArduinoBus` does.
"""

from __future__ import annotations

import binascii
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

FIRMWARE_NAME = "mearm_servo"
#: Protocol major version: a board with another major version is refused. 2: lines end
#: in a CRC-16; 1 (the firmware before it): in an XOR.
PROTOCOL_MAJOR = 2
#: Hex digits of the check value after the ``*``.
CHECK_DIGITS = 4
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
    """CRC-16/XMODEM of ``body`` (the part of a line before ``*``), as the firmware's."""
    return binascii.crc_hqx(body, 0)


def _xor(body: bytes) -> int:
    """Protocol 1's check value: the XOR of all bytes (only to recognise an old board)."""
    value = 0
    for b in body:
        value ^= b
    return value


def encode_line(body: str) -> bytes:
    r"""A full line: ``body*HHHH\n``.

    Raises:
        ValueError: ``body`` is not printable ASCII, contains ``*`` or is too long.
    """
    raw = body.encode("ascii")
    if any(b < 0x20 or b > 0x7E for b in raw) or b"*" in raw:
        raise ValueError(f"frame body must be printable ASCII without '*': {body!r}")
    line = raw + b"*%04X" % checksum(raw)
    if len(line) > MAX_LINE:
        raise ValueError(f"frame of {len(line)} bytes exceeds {MAX_LINE}: {body!r}")
    return line + b"\n"


def encode_command(seq: int, command: str, args: Sequence[int] = ()) -> bytes:
    r"""A host command frame: ``encode_command(8, "M", [1500, 0])`` → ``b"8 M 1500 0*HHHH\n"``.

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


def _split(line: bytes, digits: int) -> tuple[bytes, int] | None:
    """``body*`` and ``digits`` hex digits → (body, the check value sent), else ``None``."""
    line = line.rstrip(b"\r\n")
    star = line.rfind(b"*")
    if star < 0 or len(line) - star != 1 + digits or not set(line[star + 1 :]) <= _HEX:
        return None
    body = line[:star]
    if any(b < 0x20 or b > 0x7E for b in body):
        return None
    return body, int(line[star + 1 :], 16)


def split_frame(line: bytes) -> tuple[bytes, bool] | None:
    """Split ``body*HHHH`` into (body, checksum ok); ``None`` if it is not frame-shaped."""
    split = _split(line, CHECK_DIGITS)
    if split is None:
        return None
    body, sent = split
    return body, checksum(body) == sent


#: What a banner starts with; also found after noise on its line (:func:`decode_line`).
BANNER_HEAD = b"READY "


def _after_noise(raw: bytes) -> bytes | None:
    """The part of ``raw`` from its last :data:`BANNER_HEAD` on, if noise comes before it."""
    start = raw.rfind(BANNER_HEAD)
    return raw[start:] if start > 0 else None


def decode_line(line: bytes) -> Decoded:
    """Parse one board line (without or with its newline).

    A banner is found after noise on its line too: a restarting chip can put a byte or
    two on the wire before its banner (its TX pin floats while it resets), with no
    newline between, and a banner missed is a reset missed (the next move sent to a
    freshly booted board, which makes it at once).
    """
    raw = line.rstrip(b"\r\n")
    decoded = _decode(raw)
    tail = _after_noise(raw) if not isinstance(decoded, Reply) else None
    if tail is not None:
        banner = _decode(tail)
        if isinstance(banner, Reply) and banner.kind == "READY":
            return banner
    return decoded


def _decode(raw: bytes) -> Decoded:
    """:func:`decode_line` of a line without its newline, taken whole."""
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


def decode_protocol1_banner(line: bytes) -> Reply | None:
    """The banner of a board still running protocol 1 (``READY mearm_servo 1.0 5*25``).

    Its lines end in the XOR of their bytes (``*HH``), which :func:`decode_line` takes
    for noise. Recognised by its intact XOR (after noise on its line too, as
    :func:`decode_line` finds a banner), so that such a board is refused by name
    (reflash it) rather than waited on until no banner seems to have come.

    Returns:
        The banner as a ``READY`` :class:`Reply`, or ``None`` if ``line`` is not one.
    """
    raw = line.rstrip(b"\r\n")
    raw = _after_noise(raw) or raw
    split = _split(raw, 2)
    if split is None or _xor(split[0]) != split[1]:
        return None
    head, *rest = split[0].decode("ascii").split(" ")
    return Reply("READY", None, tuple(rest), raw) if head == "READY" else None


def version_major(version: str) -> int:
    """The major number of a ``major.minor`` version (``-1`` if it is not one)."""
    head = version.split(".")[0]
    return int(head) if head.isdigit() else -1


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
        return version_major(self.version)


def parse_firmware_info(reply: Reply) -> FirmwareInfo | None:
    """The :class:`FirmwareInfo` of an ``OK`` reply to ``V``, or ``None`` if malformed."""
    f = reply.fields
    if reply.kind != "OK" or len(f) != 5 or not all(x.isdigit() for x in f[2:]):
        return None
    return FirmwareInfo(f[0], f[1], int(f[2]), int(f[3]), int(f[4]))
