"""The virtual Uno's board: the firmware on a simulated ATmega328P, behind a pty.

:class:`VirtualUno` runs the firmware in the harness and serves it on a pseudo-terminal:
a serial port for pyserial, ``find-port``, ``jog``… Opening the port restarts the
simulated chip, as DTR resets a real Uno. Every servo pulse the emulated pins produce is
measured in CPU cycles and collected, and grouped into servo frames.
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import os
import select
import signal
import struct
import subprocess
import termios
import threading
import time
import tty
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

from mearm.sim.virtual_uno.build import VirtualUnoBuild, build_virtual_uno
from mearm.sim.virtual_uno.errors import VirtualUnoError

log = logging.getLogger(__name__)

#: The firmware's servo frame (``FRAME_US`` in ``mearm_servo.ino``) [µs].
FRAME_US = 20_000
#: A pause between two pulses longer than this ends a frame [µs] (within a frame the
#: next pulse starts within 100 µs; the frame's idle tail is over 7 ms).
FRAME_GAP_US = 2_000
#: A move's pulses must show within this many frames after its ``OK``.
FRAMES_TO_CONFIRM = 3
#: Fastest simulation the harness accepts (``-x``) [simulated s per wall-clock s].
MAX_SPEED = 1000.0
#: Pulses kept for :attr:`VirtualUno.pulses` (about 3 minutes of 5 channels).
MAX_PULSES = 50_000
#: Line times kept for :meth:`VirtualUno.reply_time_us` (only the last is ever asked for).
MAX_LINES = 1000
#: Longest wall-clock wait for something the simulator must report [s] (a stalled or
#: dead simulator is not waited for longer).
WALL_TIMEOUT_S = 10.0

_TIOCPKT = getattr(termios, "TIOCPKT", 0x5420)
_TIOCPKT_FLUSHREAD = 0x01


def _at_normal_priority(pid: int) -> None:
    """Run the simulator ``pid`` at the normal scheduling policy, whatever the host's is.

    A child takes its policy from the thread that started it, and a host thread may run at
    a realtime one it never asked for (SVT-AV1 leaves the thread that opened an encoder as
    root at ``SCHED_FIFO`` 99). The simulator at speed 0 never sleeps: at ``SCHED_FIFO``
    99 a process sharing its core had 5 % of it (50 % beside it at the normal policy),
    and the full suite's virtual-Uno sort, starved beside such boards, ran past its 300 s.
    Where the system has no such policies, or refuses the change, the simulator runs as
    it was started.
    """
    if not hasattr(os, "sched_setscheduler"):  # pragma: no cover - not Linux
        return
    with contextlib.suppress(OSError):
        if os.sched_getscheduler(pid) in (os.SCHED_FIFO, os.SCHED_RR):
            os.sched_setscheduler(pid, os.SCHED_OTHER, os.sched_param(0))


def _signal_name(number: int) -> str:
    """``SIGKILL`` for 9, else ``signal 99``."""
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


class SimDeadline:
    """The end of a wait of ``seconds`` for a :class:`VirtualUno`: :meth:`VirtualUno.deadline`.

    Over once the board has had ``seconds`` by its own simulated clock *and* the host has
    waited as long by the wall clock. By the wall clock alone, a slow simulation passed
    for a silent board: with three busy processes on 2 cores simavr ran at 0.2–0.45 of
    real time (at speed 0 and 1 alike), and a sort stopped once on a reply 2 s late. By
    the simulated clock alone, a reply on its way passed for a missing one: above real
    time (speed 0 on an idle machine, or a high speed) the chip runs on while the host's
    threads that carry its line wait for a core. A simulator that stopped (or could not
    start) has no clock to wait for: the wall time alone. One whose clock stands still
    (stuck, or paused by a signal) ends the wait after :data:`WALL_TIMEOUT_S` more of wall
    time: a reply takes the chip some 10 ms, which only a simulation below 1/1000 of real
    time would take that long to run. (A chip restarted during the wait begins its clock
    again at 0: that wait ends by the wall bound. The virtual Uno's bus starts a fresh
    board at each connect, its clock at 0 before and after the port's opening restarts it.)

    Args:
        board: The board waited for.
        seconds: How long it has to answer [simulated and wall-clock s].
    """

    def __init__(self, board: VirtualUno, seconds: float):
        now = time.monotonic()
        self.seconds = float(seconds)
        self._board = board
        self._wall_from = now
        self._wall_at = now + seconds
        self._hung_at = self._wall_at + WALL_TIMEOUT_S
        self._sim_from = board.clock_s()
        self._sim_at = self._sim_from + seconds
        #: How it ended, once :meth:`passed`: ``(simulated s, wall-clock s, the simulator
        #: had stopped)`` waited.
        self.waited: tuple[float, float, bool] | None = None

    def passed(self) -> bool:
        """Whether the wait is over (see the class)."""
        now = time.monotonic()
        if now < self._wall_at:
            return False
        stopped = self._board.stopped
        clock = self._board.clock_s()
        if now >= self._hung_at or stopped or clock >= self._sim_at:
            self.waited = (clock - self._sim_from, now - self._wall_from, stopped)
            return True
        return False

    def why_over(self) -> str | None:
        """Why the board's answer did not come, once the wait is over, by both clocks.

        ``None`` before, and when the simulator was not running at the end (it had
        stopped: only its own words say why, :attr:`VirtualUno.stopped_because`).
        """
        if self.waited is None or self.waited[2]:
            return None
        sim_s, wall_s, _ = self.waited
        if sim_s >= self.seconds:
            return (
                f"the chip did not answer within {self.seconds:g} s of its own clock "
                f"({wall_s:.2f} s of wall time waited)"
            )
        return (
            f"the chip did not answer, and its clock stood still: it ran {sim_s:.3f} s of the "
            f"{self.seconds:g} s waited for in {wall_s:.1f} s of wall time (the simulator is "
            "stalled or paused)"
        )


class Pulse(NamedTuple):
    """One servo pulse an emulated pin produced.

    Attributes:
        channel: The firmware's channel (its pin in ``SERVO_PINS``).
        width_us: Rising to falling edge [µs], to 0.1 µs.
        time_ms: Simulated time of the falling edge [ms].
        rise_us: Simulated time of the rising edge [µs].
    """

    channel: int
    width_us: float
    time_ms: int
    rise_us: int


@dataclass(frozen=True)
class Frame:
    """One servo frame: the pulses of the channels in order, from one 20 ms period.

    Attributes:
        start_us: The rising edge of its first pulse [simulated µs].
        widths_us: Channel → pulse width [µs]; a channel without a pulse is absent.
    """

    start_us: int
    widths_us: Mapping[int, float] = field(default_factory=dict)


class VirtualUno:
    """The firmware on a simulated ATmega328P, served on a pseudo-terminal.

    Give :attr:`port` to anything that opens a serial port — pyserial,
    :class:`~mearm.hardware.arduino.ArduinoBus`, a ``mearm`` command run as a subprocess
    with that port (``find-port``, ``calibrate-servos``, ``jog``): it is the board's USB
    serial port. Opening it restarts the simulated chip, which prints its banner, as DTR
    resets an Uno. The board runs until :meth:`close`; read what its pins did with
    :meth:`widths_us`, or the frame after the last reply with :meth:`reply_time_us` and
    :meth:`frame_after`::

        from mearm.hardware import ArduinoBus, ArmCommand
        from mearm.sim.virtual_uno import VirtualUno

        with VirtualUno.start() as board:        # builds on first use (a few seconds)
            print(board.port)                    # e.g. /dev/pts/7
            with ArduinoBus(config.arm, config.servo, port=board.port) as bus:
                bus.move(ArmCommand.home(config.arm))
                frame = board.frame_after(board.reply_time_us(), range(5))
            print(frame.widths_us)               # {0: 1800.1, 1: 1530.0, ...} [µs]
            print(board.widths_us(channel=0))    # every pulse channel 0 produced [µs]

    Commands run as a subprocess see the same board for as long as it runs (``speed``
    1: real time, as a person at the keyboard expects).

    Args:
        build: The firmware and harness (:func:`build_virtual_uno`).
        speed: Simulated seconds per wall-clock second; 0: as fast as it runs.

    Attributes:
        port: The pty's device path.
        pulses: Every pulse since the last restart (the latest :data:`MAX_PULSES`).
        stderr: Lines the simulator printed that are not events.
        opens: How many times the port was opened (restarts).
    """

    def __init__(self, build: VirtualUnoBuild, *, speed: float = 1.0):
        if not 0 <= speed <= MAX_SPEED:
            raise VirtualUnoError(f"speed must be from 0 to {MAX_SPEED:g}, got {speed}")
        for path in (build.firmware, build.simulator):
            if not path.is_file():
                raise VirtualUnoError(f"{path} is not there: build it (build_virtual_uno)")
        self.build = build
        self.speed = speed
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        fcntl.ioctl(self._master, _TIOCPKT, struct.pack("i", 1))
        self.port = os.ttyname(self._slave)
        self.pulses: list[Pulse] = []
        self.stderr: list[str] = []
        self.opens = 0
        self._cond = threading.Condition()
        self._proc: subprocess.Popen[bytes] | None = None
        self._events: threading.Thread | None = None  # the running simulator's reports
        self._reset_state()
        self._closed = False
        self._thread = threading.Thread(target=self._serve, name="virtual-uno", daemon=True)
        self._thread.start()

    @classmethod
    def start(cls, defines: Sequence[str] = (), *, speed: float = 1.0) -> VirtualUno:
        """Build (once, cached) the firmware with ``defines`` and start a board running it.

        Raises:
            VirtualUnoError: as :func:`build_virtual_uno`.
        """
        return cls(build_virtual_uno(defines), speed=speed)

    # ----------------------------------------------------------------- measurements

    @property
    def now_ms(self) -> int:
        """Simulated time of the last pulse's falling edge [ms] (0 before any)."""
        with self._cond:
            return self.pulses[-1].time_ms if self.pulses else 0

    def widths_us(self, channel: int, after_ms: int = 0) -> list[float]:
        """Widths of the channel's pulses that ended after simulated time ``after_ms``."""
        with self._cond:
            return [
                p.width_us for p in self.pulses if p.channel == channel and p.time_ms > after_ms
            ]

    def clock_s(self) -> float:
        """The simulated time [s] (0 until the simulator reports it)."""
        with self._cond:
            return self._now_us / 1e6

    def sleep_s(self, seconds: float) -> None:
        """Wait until ``seconds`` of simulated time have passed (or the simulator stopped)."""
        with self._cond:
            target = self._now_us + seconds * 1e6
            self._wait(lambda: self._now_us >= target, WALL_TIMEOUT_S + 100 * seconds)

    def deadline(self, seconds: float) -> SimDeadline:
        """The end of a wait of ``seconds`` for the board, by both clocks (:class:`SimDeadline`).

        A :class:`~mearm.hardware.serial_bus.Deadline` for the serial backend's waits
        (:class:`~mearm.sim.virtual_uno.VirtualUnoBus`).
        """
        return SimDeadline(self, seconds)

    def reply_time_us(self) -> int | None:
        """Simulated time the last line the host has received left the UART [µs].

        Waits for the simulator's report of it; ``None`` if none came (no line sent yet,
        or the simulator stopped).
        """
        with self._cond:
            n = self._lines_out
            if n == 0:
                return None
            ok = self._wait(lambda: self._line_base + len(self._line_us) >= n, WALL_TIMEOUT_S)
            return self._line_us[n - 1 - self._line_base] if ok else None

    def frame_after(self, t_us: int, channels: Sequence[int]) -> Frame | None:
        """The first servo frame that started after simulated time ``t_us``.

        Waits until it holds every channel of ``channels`` or the next frame began, at
        most :data:`FRAMES_TO_CONFIRM` frames of simulated time.

        Returns:
            The frame, or ``None`` when no frame started in that time.
        """
        wanted = set(channels)
        deadline_us = t_us + FRAMES_TO_CONFIRM * FRAME_US
        found: list[Frame] = []

        def ready() -> bool:
            frames = [f for f in self._frames if f.start_us > t_us]
            current = self._frame
            if current is not None and current.start_us > t_us:
                if not frames and wanted <= set(current.widths_us):
                    found.append(current)
                    return True
            if frames:
                found.append(frames[0])
                return True
            return self._now_us > deadline_us

        with self._cond:
            self._wait(ready, WALL_TIMEOUT_S)
        return found[0] if found else None

    @property
    def stopped(self) -> bool:
        """Whether the simulator is not running after an open (it stopped, or was closed)."""
        with self._cond:
            return self.opens > 0 and not self._running

    @property
    def stopped_because(self) -> str | None:
        """Why the simulator stopped on its own since the last open, else ``None``.

        How it exited and its last words (a signal's name alone). ``None`` while it runs,
        before it started, and once :meth:`close` stopped it: what it printed last then,
        simavr's ``Loaded 132 .data``, says nothing of why.
        """
        with self._cond:
            return self._exit

    # ----------------------------------------------------------------- lifetime

    def close(self) -> None:
        """Stop the simulator and close the pty (the host's next read or write fails)."""
        if self._closed:
            return
        self._closed = True
        self._thread.join(timeout=2)
        self._stop_sim()
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)

    def __enter__(self) -> VirtualUno:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ----------------------------------------------------------------- plumbing

    def _reset_state(self) -> None:
        self.pulses = []
        self._frames: list[Frame] = []  # complete frames, the latest few
        self._frame: Frame | None = None  # the frame being generated
        self._last_fall_us = 0
        self._line_us: list[int] = []  # when each line left the UART, from line _line_base
        self._line_base = 0
        self._lines_out = 0
        self._now_us = 0
        self._running = False
        self._exit: str | None = None  # why the simulator stopped on its own

    def _wait(self, predicate: Callable[[], bool], wall_s: float) -> bool:
        """Wait (holding the condition) until ``predicate`` or the simulator stopped."""
        deadline = time.monotonic() + wall_s
        while not predicate():
            left = deadline - time.monotonic()
            if not self._running or left <= 0:
                return predicate()
            self._cond.wait(min(left, 0.1))
        return True

    def _restart(self) -> None:
        """The host opened the port: a DTR reset, a fresh chip."""
        self._stop_sim()
        argv = [str(self.build.simulator), "-t", "-x", f"{self.speed:g}", str(self.build.firmware)]
        with self._cond:
            self._reset_state()
            self.opens += 1
            try:
                # A process group of its own: a Ctrl-C at the terminal goes to the
                # terminal's foreground group, mearm, not to the board (a real Uno does
                # not die on it, and the park or hold that follows needs it). It still
                # ends with mearm: close() kills it, and if mearm dies unannounced
                # (SIGKILL) its stdin closes and it exits within 100 ms of quiet.
                proc = subprocess.Popen(
                    argv,
                    stdin=subprocess.PIPE,
                    stdout=subprocess.PIPE,
                    stderr=subprocess.PIPE,
                    process_group=0,
                )
            except OSError as exc:  # the host sees no banner; the reason is kept here
                self.stderr.append(f"cannot run {argv[0]}: {exc}")
                self._exit = self.stderr[-1]
                log.error("virtual Uno: cannot run %s: %s", argv[0], exc)
                return
            _at_normal_priority(proc.pid)
            self._proc = proc
            self._running = True
            self._events = threading.Thread(target=self._pump_events, args=(proc,), daemon=True)
        threading.Thread(target=self._pump_out, args=(proc,), daemon=True).start()
        self._events.start()

    def _stop_sim(self) -> None:
        proc = self._proc
        if proc is not None and proc.poll() is not None and self._events is not None:
            # It exited on its own: its last words are read (and why recorded) first.
            self._events.join(timeout=2)
        with self._cond:
            proc, self._proc = self._proc, None
            self._running = False
            self._cond.notify_all()
        if proc is not None:
            proc.kill()
            proc.wait(timeout=5)
            for stream in (proc.stdin, proc.stdout, proc.stderr):
                if stream is not None:
                    with contextlib.suppress(OSError):
                        stream.close()

    def _serve(self) -> None:
        """Forward the host's bytes to the UART; restart the chip when the port opens."""
        while not self._closed:
            try:
                ready, _, _ = select.select([self._master], [], [], 0.05)
                if not ready:
                    continue
                packet = os.read(self._master, 4096)
            except (OSError, ValueError):
                return
            if not packet:
                continue
            status, data = packet[0], packet[1:]
            if status:
                if status & _TIOCPKT_FLUSHREAD:
                    self._restart()
                continue
            proc = self._proc
            if proc is not None and proc.stdin is not None:
                try:
                    proc.stdin.write(data)
                    proc.stdin.flush()
                except (OSError, ValueError):  # the simulator was stopped
                    pass

    def _pump_out(self, proc: subprocess.Popen[bytes]) -> None:
        """The UART's transmitter → the host, counting the lines sent."""
        assert proc.stdout is not None
        try:
            while True:
                chunk = os.read(proc.stdout.fileno(), 4096)
                if not chunk:
                    break
                with self._cond:
                    if proc is not self._proc:
                        return
                    self._lines_out += chunk.count(b"\n")
                os.write(self._master, chunk)
        except (OSError, ValueError):  # the simulator was stopped, or the pty closed
            pass
        self._ended(proc)

    def _pump_events(self, proc: subprocess.Popen[bytes]) -> None:
        """The harness's reports: pulses, lines sent, the simulated clock.

        Read in chunks and recorded under one lock per chunk, so the host's threads are
        not woken for each of the thousand reports a second.
        """
        assert proc.stderr is not None
        fd = proc.stderr.fileno()
        pending = b""
        try:
            while True:
                chunk = os.read(fd, 65536)
                if not chunk:
                    break
                *lines, pending = (pending + chunk).split(b"\n")
                with self._cond:
                    if proc is not self._proc:
                        return
                    for raw in lines:
                        self._event(raw.decode("ascii", "replace").split())
                    self._cond.notify_all()
        except (OSError, ValueError):  # the simulator was stopped
            pass
        self._ended(proc, last_words=True)

    def _ended(self, proc: subprocess.Popen[bytes], *, last_words: bool = False) -> None:
        """One of the simulator's outputs closed: it exited (unless it was stopped).

        With ``last_words`` (its reports' stream, which carries them, was read to its end)
        how and with what words it exited is recorded (:attr:`stopped_because`).
        """
        status = None
        if last_words:
            with contextlib.suppress(subprocess.TimeoutExpired):
                status = proc.wait(timeout=2)
        with self._cond:
            if proc is not self._proc:
                return
            self._running = False
            if last_words:
                if status is not None and status < 0:  # what it printed last is no reason
                    self._exit = f"killed by {_signal_name(-status)}"
                else:
                    how = "it closed its output" if status is None else f"exit status {status}"
                    self._exit = f"{how}: {self.stderr[-1]}" if self.stderr else how
            self._cond.notify_all()

    def _event(self, words: list[str]) -> None:
        """Record one report (holding the condition)."""
        kind = words[0] if words else ""
        if kind == "pulse" and len(words) == 5 and all(w.isdigit() for w in words[1:]):
            pulse = Pulse(int(words[1]), int(words[2]) / 10.0, int(words[3]), int(words[4]))
            self._add_pulse(pulse)
        elif kind == "line" and len(words) == 2 and words[1].isdigit():
            self._line_us.append(int(words[1]))
            if len(self._line_us) > 2 * MAX_LINES:
                del self._line_us[:MAX_LINES]
                self._line_base += MAX_LINES
            self._now_us = max(self._now_us, int(words[1]))
        elif kind == "time" and len(words) == 2 and words[1].isdigit():
            self._now_us = max(self._now_us, int(words[1]))
        elif words:
            self.stderr.append(" ".join(words))
            log.debug("virtual Uno: %s", " ".join(words))

    def _add_pulse(self, pulse: Pulse) -> None:
        self.pulses.append(pulse)
        if len(self.pulses) > 2 * MAX_PULSES:
            del self.pulses[:MAX_PULSES]
        self._now_us = max(self._now_us, pulse.rise_us + int(pulse.width_us))
        # A frame's pulses follow one another within microseconds; frames are separated
        # by the frame's idle tail (≥ 7 ms). Channel order is not assumed: a miswired
        # firmware drives the pins in another order.
        fall_us = pulse.rise_us + round(pulse.width_us)
        frame = self._frame
        if (
            frame is None
            or pulse.rise_us - self._last_fall_us > FRAME_GAP_US
            or pulse.channel in frame.widths_us
        ):
            if frame is not None:
                self._frames = [*self._frames[-(FRAMES_TO_CONFIRM + 1) :], frame]
            frame = Frame(pulse.rise_us, {})
        self._frame = Frame(frame.start_us, {**frame.widths_us, pulse.channel: pulse.width_us})
        self._last_fall_us = fall_us
