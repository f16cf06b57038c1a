"""Pty-backed fake servo boards: the real serial backends talk to them through pyserial.

Each board owns a pseudo-terminal pair (``os.openpty``). The backend opens the slave end
by its path (``board.port``) with real pyserial; a thread serves the master end, parsing
what the backend writes and answering byte for byte as the firmware would.

"Opening the port resets the board" is emulated faithfully enough: pyserial flushes the
input buffer when it opens a port (``Serial.open`` → ``reset_input_buffer``), and with the
master in packet mode (``TIOCPKT``) the kernel reports that flush to the master as a
``TIOCPKT_FLUSHREAD`` status byte. The fake Uno treats it as its DTR reset and prints its
banner; the fake SSC-32, like the real one, does not reset.

Faults are injected by the ``faults`` record of each board: no banner, silence, garbage,
corrupted frames in either direction, numbered errors, a reset and a dropped link.
"""

from __future__ import annotations

import fcntl
import os
import re
import select
import struct
import subprocess
import termios
import threading
import time
import tty
from dataclasses import dataclass

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

    def __init__(self) -> None:
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        fcntl.ioctl(self._master, TIOCPKT, struct.pack("i", 1))
        self.port = os.ttyname(self._slave)
        self.received: list[bytes] = []
        self.opens = 0
        self.dropped = False
        self._buf = bytearray()
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

    def send(self, data: bytes) -> None:
        """Write to the host (nothing once the link is dropped)."""
        if not self.dropped:
            os.write(self._master, data)

    def drop(self) -> None:
        """Pull the cable: close the master end; the host's next read or write fails."""
        if not self.dropped:
            self.dropped = True
            os.close(self._master)

    # ----------------------------------------------------------------- plumbing

    def _serve(self) -> None:
        while not self._stop.is_set() and not self.dropped:
            try:
                ready, _, _ = select.select([self._master], [], [], 0.01)
                if not ready:
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
        error_at_move: (move, error number): answer that move with the numbered error.
        drop_at_move: Pull the cable when this move arrives, before answering it.
        reset_at_move: Reboot (print the banner again) instead of answering this move.
    """

    banner: bool = True
    boot_noise: bytes = b"\x00\xfe\r\n"
    silent_from_move: int | None = None
    garbage_line: bytes | None = None
    garbage_from_move: int | None = None
    corrupt_incoming: int = 0
    corrupt_replies: int = 0
    error_at_move: tuple[int, int] | None = None
    drop_at_move: int | None = None
    reset_at_move: int | None = None


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
        version: str = "1.0",
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

    def _reply(self, body: str) -> None:
        line = encode_line(body)
        self._last_reply = line
        self._transmit(line)

    def _transmit(self, line: bytes) -> None:
        if self.faults.garbage_line is not None:
            self.send(self.faults.garbage_line + b"\n")
        if self.faults.corrupt_replies > 0:
            self.faults.corrupt_replies -= 1
            star = line.rfind(b"*")
            wrong = (int(line[star + 1 : star + 3], 16) ^ 0x5A) & 0xFF
            line = line[: star + 1] + b"%02X\n" % wrong
        self.send(line)

    def on_line(self, line: bytes) -> None:
        line = line.rstrip(b"\r")
        if not line:
            return
        f = self.faults
        if f.corrupt_incoming > 0:
            f.corrupt_incoming -= 1
            line = bytes([line[0] ^ 0x01]) + line[1:]
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
            if f.error_at_move is not None and f.error_at_move[0] == n:
                seq = line.split(b" ")[0].decode()
                self._reply(f"ERR {seq} {f.error_at_move[1]} injected")
                return
        self._execute(line)

    def _execute(self, line: bytes) -> None:
        """What the firmware's ``handle_line`` does, in the same order."""
        if len(line) > MAX_LINE:
            self._reply(f"ERR - {ERR_LINE_TOO_LONG} long")
            return
        split = split_frame(line)
        if split is None:
            self._reply(f"ERR - {ERR_MALFORMED} syntax")
            return
        body, ok = split
        if not ok:
            self._reply(f"ERR - {ERR_CHECKSUM} checksum")
            return
        tokens = body.decode("ascii").split(" ")
        seq = tokens[0]
        if not (seq.isdigit() and len(seq) <= 3 and int(seq) <= 255):
            self._reply(f"ERR - {ERR_MALFORMED} syntax")
            return
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
        if command == "V":
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

    Attributes:
        silent: Answer nothing at all.
        version: What ``VER`` answers.
        garbage_q: The next n ``Q`` get a junk byte instead of ``.``/``+``.
        drop_at_move: Pull the cable when this group move arrives.
    """

    silent: bool = False
    version: bytes = b"SSC32-V2.50USB"
    garbage_q: int = 0
    drop_at_move: int | None = None


_SERVO = re.compile(rb"#(\d+)P(\d+)(?:S(\d+))?")
_TIME = re.compile(rb"T(\d+)\s*$")


class FakeSSC32Board(FakeBoard):
    """An SSC-32U: ``#<ch>P<µs>…T<ms>``, ``Q``, ``QP<ch>`` and ``VER``, lines ending ``\\r``.

    Attributes:
        pulses_us: Current target pulse per channel [µs].
        moves: (pulses, time_ms) of every group move, in order.
    """

    terminator = b"\r"

    def __init__(self, faults: SSC32Faults | None = None):
        self.faults = faults or SSC32Faults()
        self.pulses_us: dict[int, int] = {}
        self.moves: list[tuple[dict[int, int], int | None]] = []
        self._move_end = 0.0
        super().__init__()

    def on_line(self, line: bytes) -> None:
        f = self.faults
        text = line.strip()
        if f.silent or not text:
            return
        if text == b"VER":
            self.send(f.version + b"\r")
        elif text == b"Q":
            if f.garbage_q > 0:
                f.garbage_q -= 1
                self.send(b"\x87")
            else:
                self.send(b"+" if time.monotonic() < self._move_end else b".")
        elif text.startswith(b"QP"):
            ch = int(text[2:].strip())
            self.send(bytes([self.pulses_us.get(ch, 0) // 10]))
        elif text.startswith(b"#"):
            if f.drop_at_move == len(self.moves) + 1:
                self.drop()
                return
            move = {int(c): int(p) for c, p, _s in _SERVO.findall(text)}
            t = _TIME.search(text)
            time_ms = int(t.group(1)) if t else None
            self.pulses_us.update(move)
            self.moves.append((move, time_ms))
            self._move_end = time.monotonic() + (time_ms or 0) / 1000.0


# --------------------------------------------------------------------------- the real firmware


class SimavrBoard(FakeBoard):
    """The real ``mearm_servo`` firmware on a simulated ATmega328P behind the pty.

    ``tools/arduino/sim/mearm_sim`` runs the ELF in simavr with UART0 on its stdin/stdout;
    this board forwards the host's lines to it and its output to the host. Opening the
    port restarts the simulator, as DTR resets an Uno. Every pulse the firmware generates
    is measured in CPU cycles and collected in :attr:`pulses`.

    Args:
        sim: The ``mearm_sim`` executable.
        elf: The firmware.

    Attributes:
        pulses: (channel, width [µs], simulated time [ms]) of every pulse, in order.
    """

    def __init__(self, sim: str, elf: str):
        self._cmd = [str(sim), str(elf)]
        self._proc: subprocess.Popen[bytes] | None = None
        self.pulses: list[tuple[int, float, int]] = []
        self.stderr: list[str] = []
        super().__init__()

    def on_open(self) -> None:
        self._stop_sim()
        self.pulses = []
        proc = subprocess.Popen(
            self._cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE
        )
        self._proc = proc
        threading.Thread(target=self._pump_out, args=(proc,), daemon=True).start()
        threading.Thread(target=self._pump_err, args=(proc,), daemon=True).start()

    def on_line(self, line: bytes) -> None:
        if self._proc is not None and self._proc.stdin is not None:
            self._proc.stdin.write(line + b"\n")
            self._proc.stdin.flush()

    def _pump_out(self, proc: subprocess.Popen[bytes]) -> None:
        assert proc.stdout is not None
        try:
            while True:
                chunk = os.read(proc.stdout.fileno(), 4096)
                if not chunk:
                    return
                if proc is self._proc:
                    self.send(chunk)
        except (OSError, ValueError):  # the simulator was stopped, or the link dropped
            return

    def _pump_err(self, proc: subprocess.Popen[bytes]) -> None:
        assert proc.stderr is not None
        try:
            for raw in proc.stderr:
                text = raw.decode("ascii", "replace").split()
                if len(text) == 4 and text[0] == "pulse":
                    self.pulses.append((int(text[1]), int(text[2]) / 10.0, int(text[3])))
                else:
                    self.stderr.append(" ".join(text))
        except (OSError, ValueError):  # the simulator was stopped
            return

    def widths_us(self, channel: int, after_ms: int = 0) -> list[float]:
        """Widths of the channel's pulses generated after simulated time ``after_ms``."""
        return [w for ch, w, t in list(self.pulses) if ch == channel and t > after_ms]

    @property
    def now_ms(self) -> int:
        """Simulated time of the last pulse [ms] (0 before any)."""
        return self.pulses[-1][2] if self.pulses else 0

    def _stop_sim(self) -> None:
        proc, self._proc = self._proc, None
        if proc is not None:
            proc.kill()
            proc.wait(timeout=5)
            for stream in (proc.stdin, proc.stdout, proc.stderr):
                if stream is not None:
                    stream.close()

    def close(self) -> None:
        self._stop_sim()
        super().close()
