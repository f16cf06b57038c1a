"""Our protocol on a serial port: the board running ``tools/arduino/mearm_servo``.

Connecting opens the port, which resets an Uno (DTR), waits for its ``READY`` banner
(``servo.banner_timeout_s``), then asks ``V`` for the firmware name, version, servo count
and pulse range and checks them against the config. A banner of another protocol version
(above all protocol 1's, checked by an XOR: a board flashed before the CRC-16) is refused
with :class:`~mearm.hardware.errors.FirmwareVersionError` before anything is sent. Each
command then waits ``servo.ack_timeout_s`` of wall time for its ``OK`` (the virtual
Uno's bus counts its simulated clock as well: :meth:`SerialServoBus._deadline
<mearm.hardware.serial_bus.SerialServoBus._deadline>`); a checksum failure in either
direction is resent with the same sequence number up to ``servo.retries`` times, each
failed try logged; no acknowledgement, a numbered board error, a lost link or a board
reset stops the bus with a named error carrying the last acknowledged pose.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from mearm.config import ArmDescription, ServoConfig
from mearm.hardware.bus import ArmCommand
from mearm.hardware.errors import (
    BannerTimeoutError,
    BoardError,
    BoardResetError,
    ChecksumError,
    FirmwareVersionError,
    HandshakeError,
    NoAckError,
)
from mearm.hardware.mapping import ServoMap
from mearm.hardware.mearm_protocol import (
    BANNER_HEAD,
    ERR_CHECKSUM,
    ERROR_CODES,
    FIRMWARE_NAME,
    MAX_LINE,
    PROTOCOL_MAJOR,
    SEQ_MODULO,
    BadChecksum,
    Decoded,
    FirmwareInfo,
    Reply,
    Unparseable,
    decode_line,
    decode_protocol1_banner,
    encode_command,
    parse_firmware_info,
    version_major,
)
from mearm.hardware.serial_bus import SerialServoBus

log = logging.getLogger(__name__)

#: Bytes of an ``OK <seq>*HHHH\n`` acknowledgement, at most.
_ACK_BYTES = 12
#: Garbage kept for an error message [bytes]; a flood is cut here.
_GARBAGE_KEPT = 256


@dataclass(frozen=True)
class BoardStatus:
    """The board's answer to ``Q``.

    Attributes:
        mode: ``IDLE`` (no pulses yet), ``RUN`` or ``HOLD`` (stopped or watchdog).
        pulses_us: Current pulse of each channel [µs], 0 = none.
    """

    mode: str
    pulses_us: tuple[int, ...]


def misfit(info: FirmwareInfo, servo_map: ServoMap) -> str | None:
    """Why a board that reports ``info`` cannot drive the servos of ``servo_map``, or ``None``.

    A channel past the board's, a pulse range wider than the board's, or more channels
    than a move's line can name. The handshake refuses such a board; ``find-port`` says so.
    """
    highest = max(servo_map.channels)
    if highest >= info.servo_count:
        return (
            f"the config uses servo channel {highest}, the board drives channels "
            f"0..{info.servo_count - 1}; fix the servo channels in arm (joints' and tool "
            "actuators' servo.channel)"
        )
    for j in servo_map.actuators:
        if j.min_us < info.min_us or j.max_us > info.max_us:
            return (
                f"{j.name}'s pulse range [{j.min_us}, {j.max_us}] µs is wider than the "
                f"board's [{info.min_us}, {info.max_us}] µs"
            )
    # a move names every channel the board drives: it must fit one line, or every move
    # would fail to encode (a ValueError, not a fault) after a handshake passed
    longest = max(j.max_us for j in servo_map.actuators)
    try:
        encode_command(SEQ_MODULO - 1, "M", [longest] * info.servo_count)
    except ValueError:
        return (
            f"the board reports {info.servo_count} servo channels; a move to that many does "
            f"not fit the protocol's {MAX_LINE}-character line (the firmware drives 5): "
            "flash tools/arduino/mearm_servo"
        )
    return None


class ArduinoBus(SerialServoBus):
    """The serial backend (``servo.backend: serial``) for our firmware and protocol.

    Args:
        arm: The arm whose actuators it drives.
        link: The ``servo`` section (port, baud, rate, timeouts, retries).
        port: Override ``link.port``.

    Attributes:
        banner: The banner line the board printed, once connected.
        firmware: What the board reported to ``V``, once connected.
    """

    def __init__(self, arm: ArmDescription, link: ServoConfig, *, port: str | None = None):
        super().__init__(arm, link, port=port)
        self.banner: bytes | None = None
        self.firmware: FirmwareInfo | None = None
        self._seq = -1

    @property
    def wire_bytes_per_move(self) -> int:
        """An ``M`` frame with every channel at 4 digits, plus its acknowledgement."""
        count = self.firmware.servo_count if self.firmware else len(self.servo_map.channels)
        return len(encode_command(SEQ_MODULO - 1, "M", [2500] * count)) + _ACK_BYTES

    # ----------------------------------------------------------------- public extras

    def query(self) -> BoardStatus:
        """Ask the board for its mode and current pulses (``Q``).

        Raises:
            ServoError: as :meth:`move` does.
        """
        self._require_ready()
        reply = self._guarded(self._transact, "Q")
        mode, *pulses = reply.fields or ("?",)
        return BoardStatus(mode, tuple(int(p) for p in pulses if p.isdigit()))

    # ----------------------------------------------------------------- backend hooks

    def _connect(self) -> None:
        self._open_port()
        try:
            self.banner = self._await_banner()
            self.firmware = self._handshake()
        except BaseException:
            self._close()
            raise
        log.info(
            "%s: %s %s, %d servos", self.port, self.firmware.name, self.firmware.version,
            self.firmware.servo_count,
        )  # fmt: skip

    def _send_move(self, command: ArmCommand, pulses_us: dict[int, int]) -> None:
        assert self.firmware is not None
        args = [pulses_us.get(ch, 0) for ch in range(self.firmware.servo_count)]
        self._transact("M", args)

    def _stop(self) -> None:
        """``S``: the board keeps its current pulses (mode ``HOLD``) and changes none.

        Its current pulses are the last acknowledged ``M`` (a move whose ``OK`` never
        came faults the bus, and nothing is sent after a fault), so the arm holds the
        last confirmed pose.
        """
        self._transact("S")

    # ----------------------------------------------------------------- protocol

    def _await_banner(self) -> bytes:
        """The board's banner line, once it came.

        Raises:
            BannerTimeoutError: none came in ``servo.banner_timeout_s``.
            FirmwareVersionError: the banner is of another protocol version.
        """
        timeout = self.link.banner_timeout_s
        deadline = self._deadline(timeout)
        seen = bytearray()
        while True:
            line = self._read_line(deadline)
            if line is None:
                raise BannerTimeoutError(self.port, timeout, bytes(seen) + self._drain())
            decoded = decode_line(line)
            if isinstance(decoded, Reply) and decoded.kind == "READY":
                log.info("%s: banner %r", self.port, decoded.raw)
                # another firmware's banner is left to the V reply's check
                name, version = (*decoded.fields, "", "")[:2]
                major = version_major(version)
                if name == FIRMWARE_NAME and major != PROTOCOL_MAJOR:
                    raise FirmwareVersionError(
                        self.port, f"{name} {version}", major, PROTOCOL_MAJOR
                    )
                return decoded.raw  # without noise before it on its line
            old = decode_protocol1_banner(line)
            if old is not None:  # its V reply could not even be read: refused by its line
                firmware = " ".join(old.fields[:2]) or "a firmware of protocol 1"
                raise FirmwareVersionError(self.port, firmware, 1, PROTOCOL_MAJOR)
            if len(seen) < _GARBAGE_KEPT:
                seen += line[:_GARBAGE_KEPT] + b"\n"
            log.debug("%s: skipped before the banner: %r", self.port, line[:80])

    def _handshake(self) -> FirmwareInfo:
        reply = self._transact("V")
        info = parse_firmware_info(reply)
        if info is None or info.name != FIRMWARE_NAME:
            raise HandshakeError(
                f"{self.port}: the board is not running {FIRMWARE_NAME} "
                f"(its V reply was {reply.raw!r}); flash tools/arduino/mearm_servo"
            )
        if info.major != PROTOCOL_MAJOR:
            raise FirmwareVersionError(
                self.port, f"{info.name} {info.version}", info.major, PROTOCOL_MAJOR, sent=True
            )
        problem = misfit(info, self.servo_map)
        if problem is not None:
            raise HandshakeError(f"{self.port}: {problem}")
        return info

    def _next_seq(self) -> int:
        self._seq = (self._seq + 1) % SEQ_MODULO
        return self._seq

    def _transact(self, command: str, args: list[int] | None = None) -> Reply:
        """Send a command and return its ``OK``, resending it after checksum failures.

        Raises:
            NoAckError: no reply in time.
            BoardError: a numbered error other than a checksum failure.
            ChecksumError: every try failed its checksum.
            BoardResetError: the board printed its banner instead, or before the
                command went out (:meth:`_settle`).
            LinkDroppedError: the port failed.
        """
        frame = encode_command(self._next_seq(), command, args or [])
        tries = 1 + self.link.retries
        bad = b""
        for attempt in range(1, tries + 1):
            self._settle()
            self._write(frame)
            reply = self._await_reply(self._seq, frame)
            if isinstance(reply, Reply) and reply.kind == "OK":
                return reply
            if isinstance(reply, Reply) and reply.seq is not None and reply.code != ERR_CHECKSUM:
                raise BoardError(
                    reply.code,
                    ERROR_CODES.get(reply.code, "unknown error number"),
                    reply.detail,
                    frame,
                    last_state=self.state,
                )
            bad = reply.raw
            why = (  # an ERR - (no seq read): the line came garbled, checksum or not
                f"the board could not read the line ({reply.detail or 'ERR -'})"
                if isinstance(reply, Reply)
                else "bad reply"
            )
            log.warning(
                "%s: try %d/%d of %r failed: %s (%r)", self.port, attempt, tries, frame, why, bad
            )
        raise ChecksumError(frame, tries, bad, "checksum failure", last_state=self.state)

    def _settle(self) -> None:
        """Take every line that came since the last reply, before a command goes out.

        None of them can answer a command not yet sent: late replies, notices and junk are
        logged and dropped. A banner among them means the board restarted between two
        commands (a brown-out during a hold or a pause): its pulses stopped and the arm's
        pose is unknown, so nothing more may reach it, above all not the next move, which
        the freshly booted firmware would make at once.

        The board sends whole lines only, so a line begun and not ended is on its way (a
        banner's 29 bytes take 2.5 ms at 115200 baud, and may come in two USB packets):
        it is waited for, up to ``servo.ack_timeout_s``, before anything is written.

        Raises:
            BoardResetError: the board printed its banner since the last reply.
            LinkDroppedError: the port failed.
        """
        self._take_waiting()
        in_flight = self._deadline(self.link.ack_timeout_s)
        while (line := self._read_line(in_flight if self._rx else 0.0)) is not None:
            decoded = decode_line(line)
            if _is_banner(decoded):
                raise self._board_reset(line)
            if isinstance(decoded, Reply) and decoded.kind == "NOTE":
                log.info("%s: board notice %r", self.port, line)
            elif decoded.raw:
                log.warning("%s: dropped a line that came unasked %r", self.port, line[:80])

    def _board_reset(self, banner: bytes) -> BoardResetError:
        """The fault of a board that printed its ``banner`` in the middle of a session."""
        return BoardResetError(
            f"{self.port}: the board restarted (banner {banner!r}) and stopped its "
            "pulses: a brown-out? Power the servos separately from the board",
            last_state=self.state,
        )

    def _await_reply(self, seq: int, frame: bytes) -> Reply | BadChecksum:
        """The reply to ``seq``: an OK or ERR for it, an ``ERR -``, or a corrupted line."""
        timeout = self.link.ack_timeout_s
        deadline = self._deadline(timeout)
        garbage = bytearray()
        while True:
            line = self._read_line(deadline)
            if line is None:
                raise NoAckError(
                    self.port, frame, timeout, bytes(garbage) + self._drain(),
                    last_state=self.state,
                )  # fmt: skip
            decoded = decode_line(line)
            if _is_banner(decoded):
                raise self._board_reset(line)
            if isinstance(decoded, Unparseable):
                if decoded.raw:
                    if len(garbage) < _GARBAGE_KEPT:
                        garbage += decoded.raw[:_GARBAGE_KEPT] + b"\n"
                    log.warning("%s: ignored garbage %r", self.port, decoded.raw[:80])
                continue
            if isinstance(decoded, BadChecksum):
                return decoded
            if decoded.kind == "NOTE":
                log.info("%s: board notice %r", self.port, line)
                continue
            if decoded.kind == "ERR" and decoded.seq is None:
                return decoded
            if decoded.seq != seq:
                log.warning("%s: ignored a stale reply %r (waiting for %d)", self.port, line, seq)
                continue
            return decoded


def _is_banner(decoded: Decoded) -> bool:
    """Whether a line read after the handshake is a banner: a reset.

    Its checksum intact or not: no other line the board sends holds ``READY ``, and a
    banner damaged on the wire (a chip restarting puts noise on it) is still a board
    that restarted. Taken for a bad reply, it had the command sent again, to the freshly
    booted board, which made that move at once from a pose nobody knows.
    """
    if isinstance(decoded, Reply):
        return decoded.kind == "READY"
    return BANNER_HEAD in decoded.raw
