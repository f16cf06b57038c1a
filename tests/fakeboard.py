"""Pty-backed fake servo boards: the real serial backends talk to them through pyserial.

Each board owns a pseudo-terminal pair (``os.openpty``). The backend opens the slave end
by its path (``board.port``) with real pyserial; a thread serves the master end, parsing
what the backend writes and answering byte for byte as the firmware would.

"Opening the port resets the board" is emulated faithfully enough: pyserial flushes the
input buffer when it opens a port (``Serial.open`` → ``reset_input_buffer``), and with the
master in packet mode (``TIOCPKT``) the kernel reports that flush to the master as a
``TIOCPKT_FLUSHREAD`` status byte. The fake Uno treats it as its DTR reset and prints its
banner; the fake SSC-32, like the real one, does not reset.

``SimavrBoard`` is the real firmware in simavr: the package's
:class:`~mearm.sim.virtual_uno.VirtualUno` (the virtual Uno), run from given executables.

Faults are injected by the ``faults`` record of each board: no banner, silence, garbage,
corrupted frames in either direction, numbered errors, a reset and a dropped link; the
fake SSC-32 also delays (in order, as a serial line does), loses and garbles answers,
and talks unasked.
"""

from __future__ import annotations

import fcntl
import os
import re
import select
import struct
import termios
import threading
import time
import tty
from dataclasses import dataclass
from pathlib import Path

from mearm.hardware.mearm_protocol import (
    ERR_ARGUMENT_COUNT,
    ERR_CHECKSUM,
    ERR_LINE_TOO_LONG,
    ERR_MALFORMED,
    ERR_PULSE_RANGE,
    ERR_UNKNOWN_COMMAND,
    MAX_LINE,
    encode_line,
    split_frame,
)
from mearm.sim.virtual_uno import VirtualUno, VirtualUnoBuild

TIOCPKT = getattr(termios, "TIOCPKT", 0x5420)
TIOCPKT_FLUSHREAD = 0x01


class FakeBoard:
    """A pty whose master end a thread serves; subclasses answer the lines.

    Attributes:
        port: Path of the slave end, to give to pyserial.
        received: Every line received, terminator stripped, in order.
        opens: How many times the host opened the port.
    """

    terminator = b"\n"
    #: Longest wait of the serving loop [s].
    tick_s = 0.01

    def __init__(self) -> None:
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        fcntl.ioctl(self._master, TIOCPKT, struct.pack("i", 1))
        self.port = os.ttyname(self._slave)
        self.received: list[bytes] = []
        self.opens = 0
        self.dropped = False
        self._buf = bytearray()
        #: Passes of the serving loop that found nothing to read (:meth:`drained`).
        self._idle_passes = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="fakeboard", daemon=True)
        self._thread.start()

    # ----------------------------------------------------------------- for subclasses

    def on_open(self) -> None:
        """The host opened the port."""

    def on_line(self, line: bytes) -> None:
        """A line arrived (terminator stripped)."""

    def on_idle(self) -> None:
        """Called about every 10 ms while nothing arrives."""

    def on_tick(self) -> None:
        """Called on every pass of the serving loop (at least every 10 ms)."""

    def send(self, data: bytes) -> None:
        """Write to the host (nothing once the link is dropped)."""
        if not self.dropped:
            os.write(self._master, data)

    def drop(self) -> None:
        """Pull the cable: close the master end; the host's next read or write fails."""
        if not self.dropped:
            self.dropped = True
            os.close(self._master)

    def drained(self, timeout_s: float = 30.0) -> None:
        """Wait until every byte the host wrote before this call is read and its lines handled.

        Two passes of the serving loop that find nothing to read, both begun after this
        call: a loaded machine may starve the thread, and a line still in the pty is not in
        :attr:`received` yet. A hang is the failure: ``timeout_s`` is generous.
        """
        start, deadline = self._idle_passes, time.monotonic() + timeout_s
        while self._idle_passes < start + 2 and not self.dropped and self._thread.is_alive():
            assert time.monotonic() < deadline, f"the fake board read on for {timeout_s} s"
            time.sleep(self.tick_s)

    # ----------------------------------------------------------------- plumbing

    def _serve(self) -> None:
        while not self._stop.is_set() and not self.dropped:
            self.on_tick()
            try:
                ready, _, _ = select.select([self._master], [], [], self.tick_s)
                if not ready:
                    self._idle_passes += 1
                    self.on_idle()
                    continue
                packet = os.read(self._master, 4096)
            except (OSError, ValueError):
                return
            if not packet:
                continue
            status, data = packet[0], packet[1:]
            if status:
                if status & TIOCPKT_FLUSHREAD:
                    self._buf.clear()
                    self.opens += 1
                    self.on_open()
                continue
            self._buf += data
            while not self.dropped:
                end = self._buf.find(self.terminator)
                if end < 0:
                    break
                line = bytes(self._buf[:end])
                del self._buf[: end + 1]
                self.received.append(line)
                self.on_line(line)

    def close(self) -> None:
        """Stop the thread and close both ends."""
        self._stop.set()
        self._thread.join(timeout=2)
        if not self.dropped:
            self.dropped = True
            os.close(self._master)
        os.close(self._slave)

    def __enter__(self) -> FakeBoard:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# --------------------------------------------------------------------------- our protocol


@dataclass
class MearmFaults:
    """Faults of the fake Uno. Move numbers count ``M`` frames from 1, resends included.

    Attributes:
        banner: Print the banner on reset.
        boot_noise: Bytes printed before the banner (as a bootloader might).
        silent_from_move: Answer nothing from this move on.
        garbage_line: A junk line sent before every reply.
        garbage_from_move: From this move on, answer only junk.
        corrupt_incoming: The next n frames arrive with one byte flipped (line noise).
        corrupt_replies: The next n replies leave with a wrong checksum.
        garble_incoming: (old, new): the next frame holding ``old`` arrives with ``new``
            in its place, its check value as sent (line noise a weak check may miss, such
            as ``1500 1500`` read as ``1400 1501``: the same bit flipped in two bytes).
        garble_reply: (old, new): the same for the next reply holding ``old``.
        error_at_move: (move, error number): answer that move with the numbered error.
        drop_at_move: Pull the cable when this move arrives, before answering it.
        reset_at_move: Reboot (print the banner again) instead of answering this move.
        raw_reply_from_move: (move, bytes): from this move on, send these bytes instead
            of the reply (a truncated line, a NUL flood, a stale acknowledgement...).
        v_reply: Bytes sent instead of the reply to ``V``.
    """

    banner: bool = True
    boot_noise: bytes = b"\x00\xfe\r\n"
    silent_from_move: int | None = None
    garbage_line: bytes | None = None
    garbage_from_move: int | None = None
    corrupt_incoming: int = 0
    corrupt_replies: int = 0
    garble_incoming: tuple[bytes, bytes] | None = None
    garble_reply: tuple[bytes, bytes] | None = None
    error_at_move: tuple[int, int] | None = None
    drop_at_move: int | None = None
    reset_at_move: int | None = None
    raw_reply_from_move: tuple[int, bytes] | None = None
    v_reply: bytes | None = None


class FakeMearmBoard(FakeBoard):
    """The Uno running ``tools/arduino/mearm_servo``: the protocol of ``PROTOCOL.md``.

    Args:
        faults: What to break.
        servo_count: Channels it drives.
        version: Firmware version it reports.
        name: Firmware name it reports.
        hold_timeout_s: Watchdog: no valid command for this long → ``HOLD``.

    Attributes:
        pulses_us: Current pulse per channel [µs].
        mode: ``IDLE``, ``RUN`` or ``HOLD``.
        moves: Pulses of every executed move, in order.
    """

    def __init__(
        self,
        faults: MearmFaults | None = None,
        *,
        servo_count: int = 5,
        version: str = "2.0",
        name: str = "mearm_servo",
        hold_timeout_s: float = 1.0,
    ):
        self.faults = faults or MearmFaults()
        self.servo_count = servo_count
        self.version = version
        self.name = name
        self.hold_timeout_s = hold_timeout_s
        self._reboot()
        self.move_count = 0
        super().__init__()

    def _reboot(self) -> None:
        self.pulses_us = [0] * self.servo_count
        self.mode = "IDLE"
        self.moves: list[list[int]] = []
        self._last_frame: bytes | None = None
        self._last_reply: bytes | None = None
        self._last_valid = time.monotonic()

    def on_open(self) -> None:
        self._reboot()
        self._boot()

    def _boot(self) -> None:
        if self.faults.boot_noise:
            self.send(self.faults.boot_noise)
        if self.faults.banner:
            self.send(encode_line(f"READY {self.name} {self.version} {self.servo_count}"))

    def on_idle(self) -> None:
        if self.mode == "RUN" and time.monotonic() - self._last_valid > self.hold_timeout_s:
            self.mode = "HOLD"
            self.send(encode_line("! HOLD"))

    def _reply(self, body: str, *, remember: bool = True) -> None:
        """Send a reply; ``remember``: the one a resend of the command gets again.

        As the firmware's ``out_send(seq >= 0)``: an ``ERR -`` (no ``seq`` read) answers
        no command, so a resend after it gets the reply before it.
        """
        line = encode_line(body)
        if remember:
            self._last_reply = line
        self._transmit(line)

    def _transmit(self, line: bytes) -> None:
        if self.faults.garbage_line is not None:
            self.send(self.faults.garbage_line + b"\n")
        if self.faults.corrupt_replies > 0:
            self.faults.corrupt_replies -= 1
            star = line.rfind(b"*")
            wrong = int(line[star + 1 : star + 5], 16) ^ 0x5A5A
            line = line[: star + 1] + b"%04X\n" % wrong
        if self.faults.garble_reply is not None and self.faults.garble_reply[0] in line:
            old, new = self.faults.garble_reply
            self.faults.garble_reply = None
            line = line.replace(old, new, 1)
        self.send(line)

    def on_line(self, line: bytes) -> None:
        line = line.rstrip(b"\r")
        if not line:
            return
        f = self.faults
        if f.corrupt_incoming > 0:
            f.corrupt_incoming -= 1
            line = bytes([line[0] ^ 0x01]) + line[1:]
        if f.garble_incoming is not None and f.garble_incoming[0] in line:
            old, new = f.garble_incoming
            f.garble_incoming = None
            line = line.replace(old, new, 1)
        is_move = b" M " in line or line.endswith(b" M")
        if is_move:
            self.move_count += 1
            n = self.move_count
            if f.drop_at_move == n:
                self.drop()
                return
            if f.reset_at_move == n:
                self._reboot()
                self._boot()
                return
            if f.silent_from_move is not None and n >= f.silent_from_move:
                return
            if f.garbage_from_move is not None and n >= f.garbage_from_move:
                self.send(b"\x8f\x13garbage \xff\n")
                return
            if f.raw_reply_from_move is not None and n >= f.raw_reply_from_move[0]:
                self.send(f.raw_reply_from_move[1])
                return
            if f.error_at_move is not None and f.error_at_move[0] == n:
                seq = line.split(b" ")[0].decode()
                self._reply(f"ERR {seq} {f.error_at_move[1]} injected")
                return
        self._execute(line)

    def _execute(self, line: bytes) -> None:
        """What the firmware's ``handle_line`` does, in the same order."""
        if len(line) > MAX_LINE:
            self._reply(f"ERR - {ERR_LINE_TOO_LONG} long", remember=False)
            return
        split = split_frame(line)
        if split is None:
            self._reply(f"ERR - {ERR_MALFORMED} syntax", remember=False)
            return
        body, ok = split
        if not ok:
            self._reply(f"ERR - {ERR_CHECKSUM} checksum", remember=False)
            return
        tokens = body.decode("ascii").split(" ")
        seq = tokens[0]
        if not (seq.isdigit() and len(seq) <= 3 and int(seq) <= 255):
            self._reply(f"ERR - {ERR_MALFORMED} syntax", remember=False)
            return
        seq = str(int(seq))  # as the firmware prints the number it read: 007 answers 7
        if line == self._last_frame and self._last_reply is not None:
            self._transmit(self._last_reply)  # a resend: answer again, do not act twice
            return
        self._last_valid = time.monotonic()
        self._last_frame = line
        if len(tokens) < 2 or len(tokens[1]) != 1:
            self._reply(f"ERR {seq} {ERR_MALFORMED} syntax")
            return
        command, args = tokens[1], tokens[2:]
        if not all(a.isdigit() and len(a) <= 5 for a in args):
            self._reply(f"ERR {seq} {ERR_MALFORMED} syntax")
            return
        values = [int(a) for a in args]
        expected = {"V": 0, "M": self.servo_count, "S": 0, "Q": 0}
        if command not in expected:
            self._reply(f"ERR {seq} {ERR_UNKNOWN_COMMAND} command")
            return
        if len(values) != expected[command]:
            self._reply(f"ERR {seq} {ERR_ARGUMENT_COUNT} args")
            return
        if command == "V" and self.faults.v_reply is not None:
            self.send(self.faults.v_reply)
        elif command == "V":
            self._reply(f"OK {seq} {self.name} {self.version} {self.servo_count} 500 2500")
        elif command == "M":
            for ch, us in enumerate(values):
                if us != 0 and not 500 <= us <= 2500:
                    self._reply(f"ERR {seq} {ERR_PULSE_RANGE} ch{ch}")
                    return
            self.pulses_us = values
            self.moves.append(values)
            self.mode = "RUN"
            self._reply(f"OK {seq}")
        elif command == "S":
            if self.mode == "RUN":
                self.mode = "HOLD"
            self._reply(f"OK {seq}")
        else:
            self._reply(f"OK {seq} {self.mode} " + " ".join(str(p) for p in self.pulses_us))


# --------------------------------------------------------------------------- SSC-32


@dataclass
class SSC32Faults:
    """Faults of the fake SSC-32.

    Answers are the one-byte replies to ``Q`` and ``QP``; the ``*_answers`` faults start
    with the first answer after group move ``fault_at_move`` (counting from 1; ``None``:
    at once) and each applies to that many answers, in this order: lost, late, garbage,
    extra.

    Attributes:
        silent: Answer nothing at all.
        version: What ``VER`` answers (and the restart banner).
        ver_reply: Raw bytes sent instead of the answer to ``VER``.
        ver_delay_s: The first ``VER`` is answered this late [s] (a board slow to start).
        garbage_q: The next n ``Q`` get a junk byte instead of ``.``/``+``.
        drop_at_move: Pull the cable when this group move arrives.
        fault_at_move: The group move after which the answer faults start.
        lost_answers: This many answers are never sent.
        late_answers: This many answers are sent ``late_s`` late (and, the line being
            in order, so is everything after them).
        late_s: The delay of a late answer [s].
        stale_late: A late answer is the one an earlier query would have had: ``+`` for
            ``Q``, the pulse before the last move for ``QP``.
        garbage_answers: This many answers are ``garbage`` instead.
        garbage: The junk sent for a garbled answer.
        extra_answers: This many answers given once the move is done are followed by
            ``extra`` (a byte too many).
        extra: What follows them.
        wrong_qp_us: Added to every ``QP`` answer after ``fault_at_move`` [µs].
        mute_qp: After ``fault_at_move``, ``QP`` gets no answer (``Q`` still does): every
            answer is cut short.
        moving_forever: After ``fault_at_move``, ``Q`` always answers ``+``.
        slow_s: Every timed move takes this much longer than its ``T`` [s].
        reset_at_move: Restart when this group move arrives, instead of making it: every
            channel goes limp (``QP`` answers 0) and the banner is printed.
        banner_on_reset: Print the banner when restarting.
        stray_after_move: (move, bytes): send these bytes unasked right after the answer
            to the first ``QP`` of that group move's last channel once the move is done
            (the answer that confirms it, however late a loaded host asks).
    """

    silent: bool = False
    version: bytes = b"SSC32-V2.50USB"
    ver_reply: bytes | None = None
    ver_delay_s: float = 0.0
    garbage_q: int = 0
    drop_at_move: int | None = None
    fault_at_move: int | None = None
    lost_answers: int = 0
    late_answers: int = 0
    late_s: float = 0.0
    stale_late: bool = False
    garbage_answers: int = 0
    garbage: bytes = b"\x87"
    extra_answers: int = 0
    extra: bytes = b"."
    wrong_qp_us: int = 0
    mute_qp: bool = False
    moving_forever: bool = False
    slow_s: float = 0.0
    reset_at_move: int | None = None
    banner_on_reset: bool = True
    stray_after_move: tuple[int, bytes] | None = None


_SERVO = re.compile(rb"#(\d+)P(\d+)(?:S(\d+))?")
_TIME = re.compile(rb"T(\d+)\s*$")
_QP = re.compile(rb"QP\s*(\d+)$")


class FakeSSC32Board(FakeBoard):
    """An SSC-32U: ``#<ch>P<µs>…T<ms>``, ``Q``, ``QP<ch>`` and ``VER``, lines ending ``\\r``.

    A timed move glides: until it ends ``Q`` answers ``+`` and ``QP`` the pulse on the
    way, then ``.`` and the target. ``QP`` answers pulse // 10, 0 for a channel never
    set (limp). Replies leave in order through an outbox, so a late one delays the rest.

    Attributes:
        pulses_us: Target pulse per channel [µs].
        moves: (pulses, time_ms) of every group move made, in order.
        move_lines: Index in :attr:`received` of every group move line, made or not.
        fault_line: Index in :attr:`received` of the line at which the first fault
            struck (``None`` before).
        resets: How many times it restarted.
    """

    terminator = b"\r"
    tick_s = 0.002

    def __init__(self, faults: SSC32Faults | None = None):
        self.faults = faults or SSC32Faults()
        self.pulses_us: dict[int, int] = {}
        self.moves: list[tuple[dict[int, int], int | None]] = []
        self.move_lines: list[int] = []
        self.fault_line: int | None = None
        self.resets = 0
        self._from_us: dict[int, int] = {}
        self._before_us: dict[int, int] = {}
        self._move_start = 0.0
        self._move_end = 0.0
        self._outbox: list[tuple[float, bytes]] = []
        self._stray: tuple[int, bytes] | None = None  # (after QP of this channel, bytes)
        self._lock = threading.Lock()
        super().__init__()

    # ----------------------------------------------------------------- replies, in order

    def emit(self, data: bytes, delay_s: float = 0.0) -> None:
        """Send ``data`` after ``delay_s``, never before anything sent earlier."""
        with self._lock:
            due = time.monotonic() + delay_s
            if self._outbox:
                due = max(due, self._outbox[-1][0])
            self._outbox.append((due, data))
        self.on_tick()

    def on_tick(self) -> None:
        now = time.monotonic()
        with self._lock:
            while self._outbox and self._outbox[0][0] <= now:
                _, data = self._outbox.pop(0)
                self.send(data)

    # ----------------------------------------------------------------- the board

    def _armed(self) -> bool:
        f = self.faults
        return f.fault_at_move is None or len(self.move_lines) >= f.fault_at_move

    def current_us(self, channel: int) -> int:
        """The pulse channel ``channel`` outputs now, part-way through a timed move [µs]."""
        target = self.pulses_us.get(channel, 0)
        start = self._from_us.get(channel, target)
        now = time.monotonic()
        if now >= self._move_end or start == 0:
            return target
        progress = (now - self._move_start) / (self._move_end - self._move_start)
        return round(start + (target - start) * progress)

    def _mark_fault(self) -> None:
        if self.fault_line is None:
            self.fault_line = len(self.received) - 1

    def _answer(self, byte: bytes, stale: bytes, tail: bytes = b"") -> None:
        """Send one answer byte through the armed faults (``stale``: an earlier answer),
        then ``tail`` in the same write."""
        f = self.faults
        if not self._armed():
            self.emit(byte + tail)
        elif f.lost_answers > 0:
            f.lost_answers -= 1
            self._mark_fault()
        elif f.late_answers > 0:
            f.late_answers -= 1
            self._mark_fault()
            self.emit((stale if f.stale_late else byte) + tail, f.late_s)
        elif f.garbage_answers > 0:
            f.garbage_answers -= 1
            self._mark_fault()
            self.emit(f.garbage + tail)
        elif f.extra_answers > 0 and time.monotonic() >= self._move_end:
            # only once the move is done: while it runs the host polls again, and the
            # shifted byte would be read as one nobody asked for (a race, not the fault)
            f.extra_answers -= 1
            self._mark_fault()
            self.emit(byte + f.extra + tail)
        else:
            self.emit(byte + tail)

    def _restart(self) -> None:
        self.resets += 1
        self.pulses_us = {}
        self._from_us = {}
        self._move_end = 0.0
        if self.faults.banner_on_reset:
            self.emit(self.faults.version + b"\r")

    def on_line(self, line: bytes) -> None:
        f = self.faults
        text = line.strip()
        if f.silent or not text:
            return
        if text == b"VER":
            if f.ver_delay_s > 0:
                time.sleep(f.ver_delay_s)
                f.ver_delay_s = 0.0
            self.emit(f.version + b"\r" if f.ver_reply is None else f.ver_reply)
        elif text == b"Q":
            if f.garbage_q > 0:
                f.garbage_q -= 1
                self.emit(b"\x87")
                return
            moving = time.monotonic() < self._move_end
            if f.moving_forever and self._armed():
                self._mark_fault()
                moving = True
            self._answer(b"+" if moving else b".", b"+")
        elif _QP.match(text):
            ch = int(_QP.match(text).group(1))  # type: ignore[union-attr]
            if f.mute_qp and self._armed():
                self._mark_fault()
                return
            us = self.current_us(ch)
            if us and f.wrong_qp_us and self._armed():
                self._mark_fault()
                us += f.wrong_qp_us
            stale = self._before_us.get(ch, 0)
            tail = b""
            done = time.monotonic() >= self._move_end  # the answer that confirms the move
            if self._stray is not None and self._stray[0] == ch and done:
                self._mark_fault()
                tail, self._stray = self._stray[1], None
            self._answer(bytes([max(0, min(255, us // 10))]), bytes([stale // 10]), tail)
        elif text.startswith(b"#"):
            self.move_lines.append(len(self.received) - 1)
            n = len(self.move_lines)
            if f.drop_at_move == n:
                self._mark_fault()
                self.drop()
                return
            if f.reset_at_move == n:
                self._mark_fault()
                self._restart()
                return
            move = {int(c): int(p) for c, p, _s in _SERVO.findall(text)}
            t = _TIME.search(text)
            time_ms = int(t.group(1)) if t else None
            self._before_us = {ch: self.pulses_us.get(ch, 0) for ch in move}
            self._from_us = {ch: self.current_us(ch) for ch in move}
            self.pulses_us.update(move)
            self.moves.append((move, time_ms))
            self._move_start = time.monotonic()
            self._move_end = self._move_start + (time_ms or 0) / 1000.0
            if time_ms:
                self._move_end += f.slow_s
            if f.stray_after_move is not None and f.stray_after_move[0] == n:
                self._stray = (max(move), f.stray_after_move[1])

    def moves_after_fault(self) -> list[bytes]:
        """Group move lines received after the line the faults started at (or any, if the
        faults never started)."""
        after = -1 if self.fault_line is None else self.fault_line
        return [self.received[i] for i in self.move_lines if i > after]


# --------------------------------------------------------------------------- the real firmware


class SimavrBoard(VirtualUno):
    """The real ``mearm_servo`` firmware on a simulated ATmega328P behind the pty.

    :class:`mearm.sim.virtual_uno.VirtualUno` run from the given executables, in real
    time: opening the port restarts the simulator, as DTR resets an Uno, and every pulse
    the firmware generates is measured in CPU cycles (:attr:`pulses`, :meth:`widths_us`,
    :attr:`now_ms`).

    Args:
        sim: The ``mearm_sim`` executable.
        elf: The firmware.
    """

    def __init__(self, sim: str, elf: str):
        super().__init__(VirtualUnoBuild(firmware=Path(elf), simulator=Path(sim)), speed=1.0)


def empty_table_rig(tmp_path: Path, servo: str = "") -> Path:
    """A real rig's config, written to ``tmp_path/rig.yaml``: a folder camera of an empty
    table (the arm goes home, each trial ends at once) and servos on a Uno at
    ``tmp_path/tty``; ``servo``: more of the ``servo:`` section, each line indented."""
    import cv2  # noqa: PLC0415  (the tests that make a rig)

    from mearm.config import Config  # noqa: PLC0415
    from mearm.sim import SimCamera, World  # noqa: PLC0415

    config = Config()
    frames = tmp_path / "frames"
    frames.mkdir()
    empty = SimCamera(config, World(bins={c.name: c for c in config.task.classes})).read()
    cv2.imwrite(str(frames / "table.png"), empty)
    path = tmp_path / "rig.yaml"
    path.write_text(
        f"camera:\n  kind: folder\n  path: {frames}\n  loop: true\ntask:\n  scene: []\n"
        f"servo:\n  backend: serial\n  port: {tmp_path / 'tty'}\n{servo}"
    )
    return path
