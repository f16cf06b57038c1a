r"""The Lynxmotion SSC-32 / SSC-32U text protocol (``servo.backend: ssc32``).

Commands end in a carriage return. A group move sets every servo in one command, and
all of them start and arrive together::

    #0P1800#1P1530#2P1080#3P2100#4P1000T20\r     pulse [µs] per channel, T: move time [ms]

``Q\r`` answers one byte, ``.`` when the last move is done and ``+`` while it runs;
``QP<ch>\r`` answers one byte, the channel's current pulse / 10; ``VER\r`` answers the
firmware version, e.g. ``SSC32-V2.50USB\r``.

The board has no acknowledgement and no checksum, so each move is followed by a ``Q``:
its answer confirms the board is there and has read the move (the link is in order).
A byte other than ``.``/``+`` is logged and the ``Q`` resent, up to ``servo.retries``
times. Each move's ``T`` is the command period, so the servos glide from one command to
the next instead of jumping. The SSC-32 does not reset when the port opens and prints no
banner: the handshake is ``VER``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping

from mearm.config import Config
from mearm.exceptions import GarbledReplyError, HandshakeError, NoAckError
from mearm.hardware.bus import ArmCommand
from mearm.hardware.serial_bus import SerialServoBus

log = logging.getLogger(__name__)

QUERY_MOVEMENT = b"Q\r"
QUERY_VERSION = b"VER\r"
#: The SSC-32's pulse range [µs].
SSC32_MIN_US = 500
SSC32_MAX_US = 2500
MOVE_DONE = b"."
MOVE_RUNNING = b"+"


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


class SSC32Bus(SerialServoBus):
    """The SSC-32 / SSC-32U backend.

    Args:
        config: The whole configuration.
        port: Override ``servo.port``.

    Attributes:
        version: The board's answer to ``VER``, once connected.
    """

    def __init__(self, config: Config, *, port: str | None = None):
        super().__init__(config, port=port)
        self.version: str | None = None

    @property
    def move_time_ms(self) -> int:
        """The ``T`` of each move: the command period [ms]."""
        return max(1, round(1000.0 * self.period_s))

    @property
    def wire_bytes_per_move(self) -> int:
        """A group move of every channel at 4 digits with ``T``, a ``Q`` and its byte."""
        move = encode_group_move(dict.fromkeys(self.servo_map.channels, 2500), 65535)
        return len(move) + len(QUERY_MOVEMENT) + 1

    # ----------------------------------------------------------------- public extras

    def is_moving(self) -> bool:
        """Whether the last move is still running (``Q`` answers ``+``)."""
        self._require_ready()
        return self._guarded(self._query_movement, b"") == MOVE_RUNNING

    def wait_until_done(self, timeout_s: float = 5.0) -> bool:
        """Poll ``Q`` until the last move is done; ``False`` if it still runs at the timeout."""
        deadline = time.monotonic() + timeout_s
        while self.is_moving():
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.005)
        return True

    # ----------------------------------------------------------------- backend hooks

    def _connect(self) -> None:
        # The config already keeps every pulse within the SSC-32's 500..2500 µs.
        self._open_port()
        try:
            self.version = self._handshake()
        except BaseException:
            self._close()
            raise
        log.info("%s: %s", self.port, self.version)

    def _handshake(self) -> str:
        self._write(QUERY_VERSION)
        timeout = self.config.servo.ack_timeout_s
        deadline = time.monotonic() + timeout
        seen = bytearray()
        while True:
            line = self._read_line(deadline, terminators=b"\r\n")
            if line is None:
                raise NoAckError(self.port, QUERY_VERSION, timeout, bytes(seen) + self._drain())
            text = line.decode("ascii", "replace").strip()
            if text.upper().startswith("SSC32") or text.upper().startswith("SSC-32"):
                return text
            if text and text != "VER":
                raise HandshakeError(
                    f"{self.port}: not an SSC-32: VER answered {line!r} (servo.backend "
                    "'serial' is for the Uno running tools/arduino/mearm_servo)"
                )
            seen += line

    def _send_move(self, command: ArmCommand, pulses_us: dict[int, int]) -> None:
        move = encode_group_move(pulses_us, self.move_time_ms)
        self._write(move)
        self._query_movement(move)

    def _query_movement(self, after: bytes) -> bytes:
        """Send ``Q`` and return its ``.``/``+``; resend after a garbled answer.

        Raises:
            NoAckError: no answer in time.
            GarbledReplyError: every answer was something else.
        """
        timeout = self.config.servo.ack_timeout_s
        tries = 1 + self.config.servo.retries
        bad = b""
        for attempt in range(1, tries + 1):
            self._write(QUERY_MOVEMENT)
            byte = self._read_byte(time.monotonic() + timeout)
            if byte is None:
                raise NoAckError(
                    self.port, after + QUERY_MOVEMENT, timeout, bad, last_state=self.state
                )
            if byte in (MOVE_DONE, MOVE_RUNNING):
                return byte
            bad = byte + self._drain()
            log.warning(
                "%s: try %d/%d: Q after %r answered %r, not '.' or '+'",
                self.port, attempt, tries, after, bad,
            )  # fmt: skip
        raise GarbledReplyError(
            after + QUERY_MOVEMENT, tries, bad, "no '.'/'+' answer to Q", last_state=self.state
        )

    def _stop(self) -> None:
        """Hold every servo at its current pulse: ``QP`` each, a move without ``T``, a ``Q``.

        ``QP`` reports in 10 µs steps, so a servo may shift by up to 10 µs.
        """
        timeout = self.config.servo.ack_timeout_s
        here: dict[int, int] = {}
        for ch in self.servo_map.channels:
            query = encode_query_pulse(ch)
            self._write(query)
            byte = self._read_byte(time.monotonic() + timeout)
            if byte is None:
                raise NoAckError(self.port, query, timeout, last_state=self.state)
            here[ch] = min(SSC32_MAX_US, max(SSC32_MIN_US, 10 * byte[0]))
        hold = encode_group_move(here)
        self._write(hold)
        self._query_movement(hold)
