r"""The Lynxmotion SSC-32 / SSC-32U text protocol (``servo.backend: ssc32``).

Commands end in a carriage return. A group move sets every servo in one command, and
all of them start and arrive together::

    #0P1800#1P1530#2P1080#3P2100#4P1000T20\r     pulse [µs] per channel, T: move time [ms]

``Q\r`` answers one byte, ``.`` when the last move is done and ``+`` while it runs;
``QP<ch>\r`` answers one byte, the channel's current pulse / 10 (0: no pulse); ``VER\r``
answers the firmware version, e.g. ``SSC32-V2.50USB\r``, which the board also prints
when it restarts.

The board has no acknowledgement, no checksum and no sequence numbers, so the host
confirms each move with the board's own queries and keeps count of every byte:

- **Confirmation.** After a group move the host asks ``Q`` and ``QP`` for every channel
  in one write (:func:`encode_status_query`) and reads exactly ``1 + channels`` bytes. The
  move is confirmed when ``Q`` says done and every ``QP`` reads the pulse sent, within
  the 10 µs step of ``QP``. Only then does :attr:`~ServoBus.state` change.
- **Accounting.** The board answers its queries once each, in order. An exchange that
  got all its bytes leaves nothing owed; a byte that arrives when nothing is owed came
  unasked (:class:`~mearm.hardware.errors.UnsolicitedBytesError`, or
  :class:`~mearm.hardware.errors.BoardResetError` if it is the restart banner). An exchange
  that timed out (a lost or late reply) or read junk may still owe bytes, so before the
  next query the host **resynchronises**: it sends ``VER`` and discards everything up
  to the version line. Answers come in order, so a late reply to the earlier query
  arrives before that line and is discarded with it: it can never be read as the answer
  to a later query. Each try is logged; after ``1 + servo.retries`` tries the bus faults
  (:class:`~mearm.hardware.errors.NoAckError` or :class:`~mearm.hardware.errors.GarbledReplyError`).
- **Verification.** ``QP`` reading other pulses than those sent (the board restarted and
  went limp, junk in the reply, a move it did not make) is
  :class:`~mearm.hardware.errors.MoveNotConfirmedError` at once, or
  :class:`~mearm.hardware.errors.BoardResetError` when every channel reads 0 (limp) or the
  restart banner is in the reply. A move still running ``servo.ack_timeout_s`` after its
  ``T`` is :class:`~mearm.hardware.errors.MoveNotConfirmedError` too. An answer whose
  pulses do not match and that runs longer than asked (a byte inside it, noise on the
  line, shifted the rest) says nothing of the pulses: it is a try that read junk, asked
  again after a resynchronisation, and
  :class:`~mearm.hardware.errors.GarbledReplyError` when every try does.

After any fault the bus sends nothing more (:class:`~mearm.hardware.bus.ServoBus`), and
:attr:`~ServoBus.state` stays the last confirmed pose. ``stop()`` sends nothing: every
move returns only once the board has finished it and holds its pulses, which is the
last confirmed pose.

Each move's ``T`` is the servo frame period, 1 / ``servo.rate_hz``: the time the stream
plans each step over, so the servos glide from one command to the next at the speed
planned instead of jumping. The confirmation cannot overlap the glide (its answer must
say done), so one move takes the move's bytes on the wire, its ``T``, then the status
query and its answer on the wire: :attr:`SSC32Bus.period_s` counts them all (at 9600
baud about 73 ms of wire for five channels, on top of the 20 ms of ``T``), and the bus
paces its moves at that period.
The SSC-32 does not reset when the port opens and prints no banner then: the handshake
is ``VER``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable, Mapping
from typing import NoReturn

from mearm.config import ArmDescription, ServoConfig
from mearm.hardware.bus import ArmCommand
from mearm.hardware.errors import (
    BoardResetError,
    GarbledReplyError,
    HandshakeError,
    MoveNotConfirmedError,
    NoAckError,
    UnsolicitedBytesError,
)
from mearm.hardware.serial_bus import BITS_PER_BYTE, SerialServoBus

log = logging.getLogger(__name__)

QUERY_MOVEMENT = b"Q\r"
QUERY_VERSION = b"VER\r"
#: The SSC-32's pulse range [µs].
SSC32_MIN_US = 500
SSC32_MAX_US = 2500
MOVE_DONE = b"."
MOVE_RUNNING = b"+"
#: ``QP`` answers pulse // 10: a pulse read back within this of the one sent matches [µs].
QP_STEP_US = 10
#: Pause between two ``Q`` while a move still runs [s].
POLL_MOVING_S = 0.002
#: How long to wait for the rest of a restart banner after its first bytes [s].
BANNER_WAIT_S = 0.05
#: How long, after an answer whose pulses do not match, a byte more is waited for (an
#: answer longer than asked: a byte inside it, noise on the line): a USB adapter's
#: latency timer holds the last bytes up to 16 ms [s].
OVERRUN_WAIT_S = 0.02
#: Text the restart banner (and the answer to ``VER``) starts with.
BANNER_MARKS = (b"SSC32", b"SSC-32")
#: Longest answer to ``VER`` taken for a version.
MAX_VERSION_CHARS = 40


def encode_group_move(pulses_us: Mapping[int, int], time_ms: int | None = None) -> bytes:
    r"""``#<ch>P<µs>…[T<ms>]\r`` for the given channels, in ascending channel order.

    Raises:
        ValueError: a channel outside 0–31, a pulse outside 500–2500 µs, or a bad time.
    """
    parts = []
    for ch, us in sorted(pulses_us.items()):
        if not 0 <= ch <= 31:
            raise ValueError(f"SSC-32 channels are 0..31, got {ch}")
        if not SSC32_MIN_US <= us <= SSC32_MAX_US or int(us) != us:
            raise ValueError(f"SSC-32 pulses are integers in 500..2500 µs, got {us}")
        parts.append(f"#{ch}P{int(us)}")
    if time_ms is not None:
        if not 1 <= time_ms <= 65535:
            raise ValueError(f"SSC-32 move time is 1..65535 ms, got {time_ms}")
        parts.append(f"T{time_ms}")
    return ("".join(parts) + "\r").encode("ascii")


def encode_query_pulse(channel: int) -> bytes:
    r"""``QP<ch>\r``: ask one channel's current pulse."""
    if not 0 <= channel <= 31:
        raise ValueError(f"SSC-32 channels are 0..31, got {channel}")
    return f"QP{channel}\r".encode("ascii")


def encode_status_query(channels: Iterable[int]) -> bytes:
    r"""``Q\rQP<ch>\r…``: is the move done, and each channel's pulse, in one write.

    The board answers ``1 + len(channels)`` bytes, in this order.
    """
    return QUERY_MOVEMENT + b"".join(encode_query_pulse(ch) for ch in channels)


def looks_like_banner(data: bytes) -> bool:
    """Whether ``data`` holds the SSC-32's version text (its restart banner)."""
    upper = data.upper()
    return any(mark in upper for mark in BANNER_MARKS)


class SSC32Bus(SerialServoBus):
    """The SSC-32 / SSC-32U backend.

    Args:
        arm: The arm whose actuators it drives.
        link: The ``servo`` section (port, baud, rate, timeouts, retries).
        port: Override ``link.port``.

    Attributes:
        version: The board's answer to ``VER``, once connected.
    """

    def __init__(self, arm: ArmDescription, link: ServoConfig, *, port: str | None = None):
        super().__init__(arm, link, port=port)
        self.version: str | None = None
        # True while a query may still owe bytes (a timeout, junk, an interruption):
        # the next query resynchronises first.
        self._owed = False

    @property
    def move_time_ms(self) -> int:
        """The ``T`` of each move: the servo frame period, 1 / ``servo.rate_hz`` [ms]."""
        return max(1, round(1000.0 / self.link.rate_hz))

    @property
    def period_s(self) -> float:
        """Time between moves [s]: a move's ``T`` and everything on the wire.

        The move's bytes, its status query's and the answer's: the confirmation follows
        the glide and never overlaps it.
        """
        return self.move_time_ms / 1000.0 + self.wire_time_s

    @property
    def step_s(self) -> float:
        """Time one move's glide takes [s]: its ``T``, not the period.

        The wire's time is spent holding, before and after the glide.
        """
        return self.move_time_ms / 1000.0

    def _wire_s(self, data: bytes) -> float:
        """Time ``data`` takes on the wire at the baud rate [s]."""
        return BITS_PER_BYTE * len(data) / self.baud

    @property
    def wire_bytes_per_move(self) -> int:
        """A group move of every channel at 4 digits with ``T``, its status query and answer."""
        channels = self.servo_map.channels
        move = encode_group_move(dict.fromkeys(channels, 2500), 65535)
        return len(move) + len(encode_status_query(channels)) + 1 + len(channels)

    # ----------------------------------------------------------------- public extras

    def is_moving(self) -> bool:
        """Whether the last move is still running (``Q`` answers ``+``).

        Every :meth:`move` returns once its move is done, so this is ``False`` between
        moves unless the board was moved by someone else.
        """
        self._require_ready()
        return self._guarded(self._query_movement) == MOVE_RUNNING

    def wait_until_done(self, timeout_s: float = 5.0) -> bool:
        """Poll ``Q`` until the last move is done; ``False`` if it still runs at the timeout."""
        deadline = time.monotonic() + timeout_s
        while self.is_moving():
            if time.monotonic() >= deadline:
                return False
            time.sleep(POLL_MOVING_S)
        return True

    # ----------------------------------------------------------------- backend hooks

    def _connect(self) -> None:
        # The config already keeps every pulse within the SSC-32's 500..2500 µs.
        self._open_port()
        self._owed = False
        try:
            self.version = self._handshake()
        except BaseException:
            self._close()
            raise
        log.info("%s: %s", self.port, self.version)

    def _handshake(self) -> str:
        self._write(QUERY_VERSION)
        # the first answer since the port opened: the time a board has to say what it is
        # (as the Uno's banner), however short the ack timeout of the route's queries
        timeout = max(self.link.ack_timeout_s, self.link.banner_timeout_s)
        deadline = time.monotonic() + timeout
        seen = bytearray()
        while True:
            line = self._read_line(deadline, terminators=b"\r\n")
            if line is None:
                raise NoAckError(self.port, QUERY_VERSION, timeout, bytes(seen) + self._drain())
            text = line.decode("ascii", "replace").strip()
            printable = all(0x20 <= b < 0x7F for b in line.strip())
            is_ssc32 = text.upper().startswith("SSC32") or text.upper().startswith("SSC-32")
            if is_ssc32 and printable and len(text) <= MAX_VERSION_CHARS:
                self._skip_line_feed()
                return text
            if text and text != "VER":
                raise HandshakeError(
                    f"{self.port}: not an SSC-32: VER answered {line[:60]!r} (servo.backend "
                    "'serial' is for the Uno running tools/arduino/mearm_servo)"
                )
            seen += line

    def _send_move(self, command: ArmCommand, pulses_us: dict[int, int]) -> None:
        move = encode_group_move(pulses_us, self.move_time_ms)
        self._settle(move)
        self._write(move)
        # the board starts the glide once the whole line has arrived
        due = time.monotonic() + self._wire_s(move) + self.move_time_ms / 1000.0
        self._confirm(move, pulses_us, due)

    def _stop(self) -> None:
        """Send nothing: the last move was confirmed done, and the board holds its pulses.

        The SSC-32 keeps sending each channel's last pulse, so the arm stays at the last
        confirmed pose; any command here could only move it.
        """

    # ----------------------------------------------------------------- protocol

    def _settle(self, before: bytes) -> None:
        """Make sure nothing is owed or unasked before ``before`` is sent.

        Raises:
            BoardResetError: the restart banner arrived unasked.
            UnsolicitedBytesError: other bytes arrived unasked.
            NoAckError: a resynchronisation got no answer.
        """
        if self._owed:
            self._resync(before)
        elif self._take_waiting():
            self._raise_if_reset(b"", before)
            raise UnsolicitedBytesError(self.port, self._drain(), last_state=self.state)

    def _resync(self, before: bytes) -> None:
        """Send ``VER`` and discard everything up to its answer (late replies included).

        Raises:
            NoAckError: no version line within ``servo.ack_timeout_s``.
        """
        timeout = self.link.ack_timeout_s
        assert self.version is not None
        version = self.version.encode("ascii", "replace")
        self._write(QUERY_VERSION)
        deadline = time.monotonic() + timeout
        discarded = bytearray()
        while True:
            line = self._read_line(deadline, terminators=b"\r")
            if line is None:
                late = bytes(discarded) + self._drain()
                log.warning("%s: no answer to VER; received meanwhile %r", self.port, late[:60])
                raise NoAckError(self.port, QUERY_VERSION, timeout, last_state=self.state)
            if line.endswith(version):
                discarded += line[: -len(version)]
                self._skip_line_feed()
                break
            discarded += line + b"\r"
        self._owed = False
        if discarded:
            log.warning(
                "%s: resynchronised before %r: discarded %d late or stray bytes %r",
                self.port, before, len(discarded), bytes(discarded[:60]),
            )  # fmt: skip

    def _skip_line_feed(self) -> None:
        """Drop a line feed right after a version line's carriage return (CR LF)."""
        if self._take_waiting()[:1] == b"\n":
            del self._rx[:1]

    def _ask(self, query: bytes, n: int, before: bytes) -> bytes | None:
        """Send ``query`` and read its ``n`` answer bytes; ``None`` if they do not all come.

        After ``None`` the bytes may still come: the next query resynchronises first.
        """
        self._settle(before)
        self._owed = True
        self._write(query)
        deadline = time.monotonic() + self.link.ack_timeout_s
        reply = bytearray()
        while len(reply) < n:
            byte = self._read_byte(deadline)
            if byte is None:
                self._rx[:0] = reply  # discarded by the resync
                return None
            reply += byte
        self._owed = False
        return bytes(reply)

    def _reject(self, reply: bytes, after: bytes) -> None:
        """A reply that cannot be used: raise if it is the restart banner, else resync next."""
        self._owed = True  # junk may hide a shifted answer
        self._raise_if_reset(reply, after)

    def _raise_if_reset(self, reply: bytes, after: bytes) -> None:
        """Raise :class:`BoardResetError` if ``reply`` and what follows it is the banner."""
        rest = self._read_line(time.monotonic() + BANNER_WAIT_S, terminators=b"\r")
        if rest is not None:
            self._rx[:0] = rest + b"\r"
        seen = reply + bytes(self._rx)
        if looks_like_banner(seen):
            self._owed = True
            raise BoardResetError(
                f"{self.port}: the SSC-32 restarted (it printed {seen[:40]!r} after "
                f"{after[:60]!r}) and its servos went limp: a brown-out? Power the servos "
                "separately from the board (VS and VL)",
                last_state=self.state,
            )

    def _query_movement(self) -> bytes:
        """Ask ``Q`` alone: ``.`` or ``+``, with the same tries as a confirmation."""
        tries = 1 + self.link.retries
        reply: bytes | None = None
        for attempt in range(1, tries + 1):
            reply = self._ask(QUERY_MOVEMENT, 1, QUERY_MOVEMENT)
            if reply is not None and reply in (MOVE_DONE, MOVE_RUNNING):
                return reply
            if reply is not None:
                self._reject(reply, QUERY_MOVEMENT)
            self._failed_try(attempt, tries, QUERY_MOVEMENT, reply)
        self._give_up(QUERY_MOVEMENT, tries, reply)

    def _confirm(self, move: bytes, pulses_us: dict[int, int], due: float) -> None:
        """Wait for the move to finish and read back its pulses.

        Args:
            move: The group move as sent.
            pulses_us: Channel → the pulse sent [µs].
            due: When the move should be done (monotonic) [s].

        Raises:
            NoAckError: no complete answer on every try.
            GarbledReplyError: ``Q`` answered something else than ``.``/``+``, or an
                answer longer than asked, on every try.
            MoveNotConfirmedError: a pulse read back is not the one sent, or the move
                still runs ``servo.ack_timeout_s`` after ``due``.
            BoardResetError: the board restarted.
        """
        channels = sorted(pulses_us)
        query = encode_status_query(channels)
        timeout = self.link.ack_timeout_s
        give_up_at = due + timeout
        tries = 1 + self.link.retries
        failures = 0
        while True:
            wait = due - time.monotonic()
            if wait > 0:
                time.sleep(wait)
            asked_at = time.monotonic()
            reply = self._ask(query, 1 + len(channels), move)
            if reply is None or reply[:1] not in (MOVE_DONE, MOVE_RUNNING):
                if reply is not None:
                    self._reject(reply, move)
                failures += 1
                self._failed_try(failures, tries, query, reply)
                if failures >= tries:
                    self._give_up(move + query, tries, reply)
                continue
            if reply[:1] == MOVE_RUNNING:
                # '+' says the move ran when the query reached the board, not now: only
                # a query sent after the deadline proves it still runs (a slow answer
                # to an earlier one is asked again)
                if asked_at > give_up_at:
                    raise MoveNotConfirmedError(
                        self.port,
                        f"still moving {timeout:g} s after its {self.move_time_ms} ms "
                        f"({move!r})",
                        pulses_us, {}, last_state=self.state,
                    )  # fmt: skip
                due = time.monotonic() + POLL_MOVING_S
                continue
            reported = {ch: QP_STEP_US * b for ch, b in zip(channels, reply[1:], strict=True)}
            if _wrong(pulses_us, reported) and self._overran():
                # a byte more than asked: one inside the answer shifted the rest, which
                # says nothing of the pulses; asked again, after a resync
                self._reject(reply, move)
                failures += 1
                self._failed_try(failures, tries, query, reply)
                if failures >= tries:
                    raise GarbledReplyError(
                        move + query, tries, reply,
                        f"an answer longer than the {len(reply)} bytes asked (a byte inside "
                        "it shifted the pulses read back)",
                        last_state=self.state,
                    )  # fmt: skip
                continue
            self._verify(move, reply, pulses_us, reported)
            return

    def _overran(self) -> bool:
        """Whether a byte follows an answer of the length asked, within :data:`OVERRUN_WAIT_S`.

        The byte is kept for the resynchronisation that discards it.
        """
        byte = self._read_byte(time.monotonic() + OVERRUN_WAIT_S)
        if byte is None:
            return False
        self._rx[:0] = byte
        return True

    def _verify(
        self, move: bytes, reply: bytes, pulses_us: dict[int, int], reported: dict[int, int]
    ) -> None:
        """Raise unless every channel reads back the pulse sent (within :data:`QP_STEP_US`)."""
        wrong = _wrong(pulses_us, reported)
        if not wrong:
            return
        self._reject(reply, move)
        if all(us == 0 for us in reported.values()):
            raise BoardResetError(
                f"{self.port}: every channel reads no pulse after {move!r}: the SSC-32 "
                "restarted and its servos went limp (a brown-out? Power the servos "
                "separately from the board)",
                last_state=self.state,
            )
        listing = ", ".join(
            f"channel {ch} reads {us} µs, sent {pulses_us[ch]} µs" for ch, us in wrong.items()
        )
        raise MoveNotConfirmedError(
            self.port, f"{listing} (after {move!r})", pulses_us, reported, last_state=self.state
        )

    def _failed_try(self, attempt: int, tries: int, frame: bytes, reply: bytes | None) -> None:
        what = "no complete answer" if reply is None else f"answered {reply!r}"
        log.warning("%s: try %d/%d of %r: %s", self.port, attempt, tries, frame, what)

    def _give_up(self, frame: bytes, tries: int, reply: bytes | None) -> NoReturn:
        if reply is None:  # a partial answer is not garbage: no hint about the baud rate
            raise NoAckError(self.port, frame, self.link.ack_timeout_s, last_state=self.state)
        raise GarbledReplyError(
            frame, tries, reply, "no '.'/'+' answer to Q", last_state=self.state
        )


def _wrong(pulses_us: Mapping[int, int], reported: Mapping[int, int]) -> dict[int, int]:
    """The channels whose pulse read back is not the one sent (within :data:`QP_STEP_US`)."""
    return {ch: us for ch, us in reported.items() if abs(us - pulses_us[ch]) > QP_STEP_US}
