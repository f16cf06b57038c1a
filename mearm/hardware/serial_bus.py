"""Shared pyserial plumbing of the serial backends (lerobot's ``SerialMotorsBus`` idea).

Opening, line and byte reads with a deadline, writes, and turning every pyserial or OS
failure into a named :class:`~mearm.hardware.errors.LinkError` that carries the last
acknowledged pose. The port is checked by :func:`~mearm.config.port.check_port` before
anything is opened: a device path, or a ``socket://``, ``rfc2217://`` or ``loop://`` URL
(never ``spy://``, which writes a file). The subclasses
(:class:`~mearm.hardware.arduino.ArduinoBus`, :class:`~mearm.hardware.ssc32.SSC32Bus`)
speak their protocol on top of it.

Pacing: commands go at most ``servo.rate_hz`` per second, and never faster than the baud
rate carries one command and its reply (8N1: 10 bits a byte).

One process a port: a device path is opened with an exclusive, non-blocking ``flock``
(pyserial's ``exclusive=True``), held while it is open. A port another process holds is
refused with a :class:`~mearm.hardware.errors.PortInUseError` naming it, before a byte is
sent: where ``/proc/locks`` names the holder (Linux) the port is not even opened; else
pyserial opens it and takes the lock before it sets the line, DTR and RTS or flushes
anything, and closes it again. The lock is advisory: it keeps a second mearm process off
the port, not a program that does not take it (a serial monitor, avrdude);
``docs/safety.md``.
"""

from __future__ import annotations

import errno
import logging
import time
from abc import abstractmethod
from typing import Protocol

import serial

from mearm.config import ArmDescription, ServoConfig
from mearm.config.port import check_port
from mearm.hardware.bus import ServoBus
from mearm.hardware.errors import LinkDroppedError, LinkError, PortInUseError

log = logging.getLogger(__name__)

try:  # pyserial's POSIX flush() lets termios.error (not an OSError) through
    import termios

    _IO_ERRORS: tuple[type[BaseException], ...] = (
        serial.SerialException,
        OSError,
        termios.error,
    )
except ImportError:  # pragma: no cover - Windows
    _IO_ERRORS = (serial.SerialException, OSError)

#: Longest single blocking read [s]; deadlines are checked between reads.
POLL_S = 0.005
#: Bits on the wire per byte: start + 8 data + stop (8N1).
BITS_PER_BYTE = 10
#: Longest line kept whole [bytes]; a longer run without a terminator is cut into lines
#: of this length, so a flood of bytes cannot grow the buffer without bound.
MAX_LINE_BYTES = 256
#: Longest a write may block [s]. A line takes milliseconds on the wire; this bounds a
#: link that stopped draining. It is not ``ack_timeout_s``: pyserial raises "Write
#: timeout" after a complete write when the process was descheduled that long, and a
#: loaded machine takes a short acknowledgement timeout for a lost cable.
WRITE_TIMEOUT_S = 2.0


class Deadline(Protocol):
    """The end of a wait for the board, by a clock other than the wall clock's."""

    def passed(self) -> bool:
        """Whether the wait is over."""
        ...


def _passed(deadline: float | Deadline) -> bool:
    """Whether ``deadline`` (a monotonic time [s], or a :class:`Deadline`) has passed."""
    if isinstance(deadline, (int, float)):
        return time.monotonic() >= deadline
    return deadline.passed()


def port_holder(port: str) -> tuple[int | None, str] | None:
    """The process holding the exclusive lock on ``port``, read without opening it.

    Returns ``(pid, command line)`` from ``/proc/locks`` (Linux) when a process holds a
    ``flock`` on the device, else ``None``: the port is free, or it is a URL (no lock),
    or the system does not say (no ``/proc/locks``, another pid namespace). Only the
    lock itself (:func:`open_exclusive`) is sure.
    """
    if "://" in port:
        return None
    try:
        from mearm.runlog.lock import lock_holder  # noqa: PLC0415  (fcntl: POSIX only)
    except ImportError:  # pragma: no cover - Windows, where ports are exclusive anyway
        return None
    pid, command = lock_holder(port)
    return None if pid is None else (pid, command)


def check_port_free(port: str) -> None:
    """Refuse ``port`` if ``/proc/locks`` says another process holds it (nothing opened).

    Raises:
        PortInUseError: a process holds the port's lock.
    """
    held = port_holder(port)
    if held is not None:
        raise PortInUseError(port, *held)


def _lock_refused(exc: BaseException) -> bool:
    """Whether pyserial's ``open()`` failed on the exclusive lock (another holder)."""
    return (
        isinstance(exc, serial.SerialException)
        and getattr(exc, "errno", None) in (errno.EAGAIN, errno.EWOULDBLOCK)
        and "lock" in str(exc)
    )


def open_exclusive(
    port: str, baud: int, *, timeout: float, write_timeout: float
) -> serial.SerialBase:
    """Open ``port`` for this process alone: an exclusive ``flock`` held while it is open.

    A port another process holds is refused before anything is sent: without opening it
    where ``/proc/locks`` names the holder; else pyserial's ``open()`` takes the lock right
    after the ``open(2)`` call, before it sets the line, DTR or RTS or flushes, and closes
    it on failure. The lock is advisory (``flock``): a program that does not take it is
    not kept off. URLs take no lock.

    Raises:
        PortInUseError: another process holds the port.
        serial.SerialException, OSError, ValueError: it cannot be opened.
    """
    check_port_free(port)
    ser = serial.serial_for_url(port, do_not_open=True)
    ser.baudrate = baud
    ser.timeout = timeout
    ser.write_timeout = write_timeout
    ser.exclusive = True
    try:
        ser.open()
    except serial.SerialException as exc:
        if not _lock_refused(exc):
            raise
        raise PortInUseError(port, *(port_holder(port) or (None, ""))) from None
    return ser


class SerialServoBus(ServoBus):
    """A servo bus on a serial port (device path or pyserial URL).

    Args:
        arm: The arm whose actuators it drives.
        link: The ``servo`` section; ``port`` and ``baud`` open the port.
        port: Override ``link.port``.

    Raises:
        SerialPortError: the port is neither a device path nor an allowed URL.
    """

    def __init__(self, arm: ArmDescription, link: ServoConfig, *, port: str | None = None):
        super().__init__(arm, link, paced=True)
        self.port = check_port(port if port is not None else link.port)
        self.baud = link.baud
        self._serial: serial.SerialBase | None = None
        self._rx = bytearray()

    # ----------------------------------------------------------------- pacing

    @property
    @abstractmethod
    def wire_bytes_per_move(self) -> int:
        """Bytes one move puts on the wire, command and reply together."""

    @property
    def wire_time_s(self) -> float:
        """Time the baud rate needs to carry one move and its reply [s]."""
        return BITS_PER_BYTE * self.wire_bytes_per_move / self.baud

    @property
    def period_s(self) -> float:
        """Time between moves [s]: 1 / ``rate_hz``, or the wire time if that is longer."""
        return max(1.0 / self.link.rate_hz, self.wire_time_s)

    # ----------------------------------------------------------------- port

    def _open_port(self) -> None:
        """Open the port for this process alone, asserting DTR (an Uno resets); empty buffers.

        The port is locked while it is open (:func:`open_exclusive`).

        Raises:
            SerialPortError: the port is neither a device path nor an allowed URL.
            PortInUseError: another process holds it (nothing sent, nothing reset).
            LinkError: it cannot be opened.
        """
        check_port(self.port)  # again: the attribute may have been changed since
        try:
            ser = open_exclusive(
                self.port,
                self.baud,
                timeout=POLL_S,
                write_timeout=max(WRITE_TIMEOUT_S, self.link.ack_timeout_s),
            )
        except (serial.SerialException, OSError, ValueError) as exc:
            raise LinkError(
                self.port,
                f"cannot open at {self.baud} baud: {exc}. Is the board plugged in and "
                "servo.port right? (mearm find-port lists the ports; Linux: the user must be "
                "in the dialout group)",
            ) from None
        self._serial = ser
        self._rx.clear()
        if self.wire_time_s > 1.0 / self.link.rate_hz:
            log.warning(
                "%s: %d baud carries one move in %.1f ms: %.1f Hz at most, not the %.1f Hz "
                "of servo.rate_hz",
                self.port,
                self.baud,
                1e3 * self.wire_time_s,
                1.0 / self.wire_time_s,
                self.link.rate_hz,
            )

    def _close(self) -> None:
        if self._serial is not None:
            try:
                self._serial.close()
            except _IO_ERRORS as exc:
                log.warning("%s: error while closing: %s", self.port, exc)
            self._serial = None

    def _dropped(self, what: str, exc: BaseException) -> LinkDroppedError:
        return LinkDroppedError(
            self.port,
            f"link lost while {what} ({exc}): cable, USB hub or board power?",
            last_state=self.state,
        )

    def _write(self, data: bytes) -> None:
        """Write all of ``data``.

        Raises:
            LinkDroppedError: the port failed.
        """
        assert self._serial is not None
        try:
            self._serial.write(data)
            self._serial.flush()
        except _IO_ERRORS as exc:
            raise self._dropped(f"sending {data!r}", exc) from None
        log.debug("%s > %r", self.port, data)

    def _fill(self) -> None:
        """Read what has arrived (waiting at most :data:`POLL_S`) into the buffer."""
        assert self._serial is not None
        try:
            chunk = self._serial.read(1)
            if chunk:
                waiting = self._serial.in_waiting
                if waiting:
                    chunk += self._serial.read(waiting)
        except _IO_ERRORS as exc:
            raise self._dropped("reading", exc) from None
        if chunk:
            log.debug("%s < %r", self.port, chunk)
            self._rx += chunk

    def _take_waiting(self) -> bytes:
        """Read, without waiting, what has arrived; return everything not yet consumed."""
        assert self._serial is not None
        try:
            waiting = self._serial.in_waiting
            chunk = self._serial.read(waiting) if waiting else b""
        except _IO_ERRORS as exc:
            raise self._dropped("reading", exc) from None
        if chunk:
            log.debug("%s < %r", self.port, chunk)
            self._rx += chunk
        return bytes(self._rx)

    def _deadline(self, timeout_s: float) -> float | Deadline:
        """When a wait of ``timeout_s`` for the board ends: that much wall time from now.

        A real board's silence is measured by the wall clock; a simulated board's bus
        may count its own clock (:class:`~mearm.sim.virtual_uno.VirtualUnoBus`).
        """
        return time.monotonic() + timeout_s

    def _read_line(self, deadline: float | Deadline, terminators: bytes = b"\n") -> bytes | None:
        """The next line (terminator stripped), or ``None`` at ``deadline``.

        ``deadline``: a monotonic time [s], or a :class:`Deadline` (:meth:`_deadline`).
        A run of :data:`MAX_LINE_BYTES` without a terminator is returned as a line.

        Raises:
            LinkDroppedError: the port failed.
        """
        while True:
            ends = [i for i in (self._rx.find(t) for t in terminators) if i >= 0]
            if ends:
                end = min(ends)
                line = bytes(self._rx[:end])
                del self._rx[: end + 1]
                return line
            if len(self._rx) >= MAX_LINE_BYTES:
                line = bytes(self._rx[:MAX_LINE_BYTES])
                del self._rx[:MAX_LINE_BYTES]
                return line
            if _passed(deadline):
                return None
            self._fill()

    def _read_byte(self, deadline: float | Deadline) -> bytes | None:
        """The next byte, or ``None`` at ``deadline`` (as :meth:`_read_line`'s)."""
        while not self._rx:
            if _passed(deadline):
                return None
            self._fill()
        byte = bytes(self._rx[:1])
        del self._rx[:1]
        return byte

    def _drain(self) -> bytes:
        """Take everything received and not yet consumed."""
        data = bytes(self._rx)
        self._rx.clear()
        return data
