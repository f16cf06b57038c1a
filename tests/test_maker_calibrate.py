"""``mearm calibrate-servos`` driven with real keystrokes through a pseudo-terminal.

The command runs as a user runs it (``python -m mearm calibrate-servos …``) with a pty
as its controlling terminal; the test is the person at the keyboard: it reads the
reference angle and the pulse from the screen, works out from the servo it simulates
which pulse puts the joint at the reference, presses + / - with the step keys until the
screen shows that pulse, and presses Enter. The fitted file must then match that servo.

Two boards: the ``sim`` backend (the simulated servo is the config's calibration plus
``servo.error_model.offset_deg``), and the pty fake Uno of ``tests/fakeboard.py`` behind
the serial backend, to which this file gives servos of its own (:class:`TrueServo`,
read from the pulses the board holds). The board is the ``board`` fixture: another
board with ``port`` and a ``pulse_us(channel)`` reading can take its place.
"""

from __future__ import annotations

import os
import re
import select
import signal
import statistics
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml
from badinput import run_in_process
from conftest import simulator_build
from fakeboard import FakeMearmBoard, SimavrBoard
from test_servo_file_own_limits import HEADER

from mearm.config import load_config
from mearm.config.servo_file import (
    apply_servo_calibration_file,
    load_servo_calibration,
    servo_overrides,
)
from mearm.hardware import ServoMap
from mearm.maker.calibrate_servos import STEPS_US, reference_values

ROOT = Path(__file__).resolve().parent.parent

#: The launcher makes the pty the child's controlling terminal (so Ctrl-C typed into it
#: is SIGINT, as in a terminal window), then runs the subcommand as ``mearm NAME`` does:
#: its module's ``main`` under :func:`mearm.cli.run`.
_LAUNCHER = (
    "import fcntl, importlib, sys, termios; fcntl.ioctl(0, termios.TIOCSCTTY, 0); "
    "from mearm.cli import run; name, module, *rest = sys.argv[1:]; "
    "sys.argv = [f'mearm {name}', *rest]; run(importlib.import_module(module).main, rest)"
)
#: Subcommand → module (until ``mearm.__main__`` registers them).
MODULES = {"calibrate-servos": "mearm.maker.calibrate_servos", "jog": "mearm.maker.jog"}
_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]|\r")


class PtyCommand:
    """A ``mearm`` subcommand running on a pseudo-terminal; the test types into it.

    Args:
        args: The arguments after ``mearm``.
        cwd: Working folder.
    """

    def __init__(self, *args: str, cwd: Path = ROOT):
        self._master, slave = os.openpty()
        env = dict(os.environ, PYTHONIOENCODING="utf-8", MEARM_DEBUG="1")
        self.proc = subprocess.Popen(
            [sys.executable, "-c", _LAUNCHER, args[0], MODULES[args[0]], *args[1:]],
            stdin=slave, stdout=slave, stderr=slave, cwd=cwd, env=env, start_new_session=True,
        )  # fmt: skip
        os.close(slave)
        self._buf = bytearray()
        self._lock = threading.Lock()
        self.pos = 0
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        while True:
            try:
                ready, _, _ = select.select([self._master], [], [], 0.1)
                if ready:
                    data = os.read(self._master, 4096)
                    if not data:
                        return
                    with self._lock:
                        self._buf += data
                elif self.proc.poll() is not None:
                    return
            except OSError:  # the child closed its end
                return

    @property
    def text(self) -> str:
        """Everything on the screen so far, escape sequences and carriage returns removed."""
        with self._lock:
            raw = bytes(self._buf)
        return _ANSI.sub("", raw.decode("utf-8", "replace"))

    def expect(self, pattern: str, timeout: float = 30.0) -> re.Match[str]:
        """Wait for ``pattern`` after the last match; return the match."""
        regex = re.compile(pattern)
        deadline = time.monotonic() + timeout
        while True:
            m = regex.search(self.text, self.pos)
            if m:
                self.pos = m.end()
                return m
            if time.monotonic() > deadline or (
                self.proc.poll() is not None and not self._reader.is_alive()
            ):
                raise AssertionError(f"no {pattern!r} in:\n{self.text[-3000:]}")
            time.sleep(0.01)

    def send(self, keys: str | bytes) -> None:
        """Type ``keys``."""
        os.write(self._master, keys.encode() if isinstance(keys, str) else keys)

    def wait(self, timeout: float = 60.0) -> int:
        """The exit status, once the command ends; the output is complete then."""
        code = self.proc.wait(timeout=timeout)
        self._reader.join(timeout=5)
        return code

    def close(self) -> None:
        """Stop the command if it still runs; close the terminal."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
            self.proc.wait(timeout=10)
        self._reader.join(timeout=5)
        os.close(self._master)


@dataclass(frozen=True)
class TrueServo:
    """A servo as it really is: angle ↔ pulse, p = zero + direction·k·angle [µs, deg]."""

    zero_us: float
    direction: int
    us_per_unit: float

    def pulse_us(self, value: float) -> float:
        return self.zero_us + self.direction * self.us_per_unit * value

    def value_of(self, pulse_us: float) -> float:
        return (pulse_us - self.zero_us) / (self.direction * self.us_per_unit)


ARROW = {1: "\x1b[C", -1: "\x1b[D"}
STEP_KEY = {1: "1", 5: "2", 20: "3"}


def jog_to(cmd: PtyCommand, start_us: int, goal_us: int) -> None:
    """Press keys as a person would: big steps, then smaller, until the pulse is ``goal_us``."""
    p = start_us
    for step in sorted(STEPS_US, reverse=True):
        n = abs(goal_us - p) // step
        if n:
            sign = 1 if goal_us > p else -1
            keys = STEP_KEY[step] + (ARROW[sign] if step == 20 else "+-"[sign < 0]) * n
            cmd.send(keys)
            p += sign * step * n
    assert p == goal_us
    cmd.expect(rf"pulse {goal_us} µs")


def operate(cmd: PtyCommand, truth: dict[str, TrueServo], count: int) -> dict[str, list[int]]:
    """Calibrate ``count`` actuators: reach each reference on ``truth``'s servo, record it."""
    recorded: dict[str, list[int]] = {}
    for _ in range(count):
        head = cmd.expect(r"\] (\w+) \(\w+, channel \d+\)")
        recorded.update(operate_from_here(cmd, head.group(1), truth))
    return recorded


def check_fit(path: Path, truth: dict[str, TrueServo], references: dict[str, tuple]) -> None:
    """The file's fit is the true servo within what whole-µs pulses allow.

    Each recorded pulse is the true one rounded: off by at most 0.5 µs. So the slope is
    off by at most 1 µs over the references' span, and the zero by 0.5 µs plus that
    slope error times the first reference's distance from 0.
    """
    cal = load_servo_calibration(path)
    fits = {a.name: a for a in cal.actuators}
    assert set(fits) == set(truth)
    for name, true in truth.items():
        s = fits[name].servo
        v1, v2 = references[name]
        slope_tol = 1.0 / abs(v2 - v1)
        assert s.direction == true.direction, name
        assert abs(s.us_per_unit - true.us_per_unit) <= slope_tol + 1e-9, name
        assert abs(s.zero_us - true.zero_us) <= 0.5 + slope_tol * abs(v1) + 1e-9, name
        assert fits[name].residual_us < 1e-6  # two points: the line passes through both


def _args(output: Path, *extra: str) -> list[str]:
    return ["calibrate-servos", "--output", str(output), *extra]


# --------------------------------------------------------------------------- sim backend

SIM_OFFSETS = {"base": 2.5, "shoulder": -3.0, "elbow": 4.0}


def sim_truth() -> dict[str, TrueServo]:
    """The sim realises value_of_config(pulse) + offset: a servo with zero shifted by it."""
    smap = ServoMap.from_arm(load_config(ROOT / "configs" / "sim.yaml").arm)
    out = {}
    for a in smap.joints:
        off = SIM_OFFSETS[a.name]
        out[a.name] = TrueServo(
            a.zero_us - a.direction * a.us_per_unit * off, a.direction, a.us_per_unit
        )
    return out


def sim_args() -> list[str]:
    args = ["--config", str(ROOT / "configs" / "sim.yaml"), "--actuators", "base,shoulder,elbow"]
    for name, off in SIM_OFFSETS.items():
        args += ["--set", f"servo.error_model.offset_deg.{name}={off}"]
    return args


@pytest.mark.slow
def test_calibrate_on_the_sim_fits_the_simulated_servos(tmp_path):
    """Three joints jogged by keys on the sim: the file's fit is the sim's servo."""
    out = tmp_path / "servos.yaml"
    cmd = PtyCommand(*_args(out, *sim_args()))
    try:
        cmd.expect(r"connected: simulated")
        recorded = operate(cmd, sim_truth(), 3)
        assert cmd.wait() == 0, cmd.text[-2000:]
    finally:
        cmd.close()
    config = load_config(ROOT / "configs" / "sim.yaml")
    smap = ServoMap.from_arm(config.arm)
    refs = {a.name: reference_values(a.lower, a.upper, a.unit) for a in smap.joints}
    check_fit(out, sim_truth(), refs)
    # the screen showed the simulated joint at the reference when it was recorded
    assert "simulated arm: " in cmd.text
    cal = load_servo_calibration(out)
    assert cal.board_id.startswith("simulated") and cal.arm == config.arm.name
    assert [p.pulse_us for p in cal.actuators[0].points] == recorded["base"]
    # the printed overrides give a config with the calibration; so does the file
    lines = re.findall(r"--set '([^']+)'", cmd.text)
    assert lines == servo_overrides(config.arm, cal.actuators)
    via_set = load_config(ROOT / "configs" / "sim.yaml", lines)
    via_file = apply_servo_calibration_file(config, out)
    # a config that names the file (relative to its folder) loads with the calibration
    including = out.parent / "mine.yaml"
    text = (ROOT / "configs" / "sim.yaml").read_text()
    including.write_text(
        re.sub(r"(?m)^servo:\n", f"servo:\n  calibration_file: {out.name}\n", text, count=1)
    )
    via_config = load_config(including)
    names = [j.name for j in config.arm.joints]
    for a in cal.actuators:
        i = names.index(a.name)
        assert via_set.arm.joints[i].servo == via_file.arm.joints[i].servo
        assert via_config.arm.joints[i].servo == via_file.arm.joints[i].servo
        assert via_config.arm.joints[i].servo != config.arm.joints[i].servo


# --------------------------------------------------------------------------- fake Uno

#: The fake Uno's servos: not what the config says (paper arm: zero 600/600/2400 µs,
#: 10 µs/deg, all direction +1): another zero, another slope, the shoulder reversed.
BOARD_TRUTH = {
    "base": TrueServo(640.0, 1, 10.4),
    "shoulder": TrueServo(2350.0, -1, 9.6),
    "elbow": TrueServo(2330.0, 1, 10.2),
    "gripper_arm": TrueServo(1480.0, 1, 9.0),
    "gripper": TrueServo(2250.0, -1, 280.0),
}


class BoardUnderTest:
    """What the tests read from a board: its port, the pulse each channel outputs now, the
    moves it got. Wraps the fake Uno (pulses as commanded) or the real firmware in simavr
    (pulses as measured on its pins, to within ``accuracy_us``).
    """

    def __init__(self, board: FakeMearmBoard | SimavrBoard, accuracy_us: float):
        self.board = board
        self.port = board.port
        self.accuracy_us = accuracy_us

    def pulse_us(self, channel: int) -> float:
        """The channel's pulse now [µs] (simavr: the median of its last three)."""
        b = self.board
        if isinstance(b, FakeMearmBoard):
            return float(b.pulses_us[channel])
        widths = b.widths_us(channel)[-3:]
        return statistics.median(widths) if widths else 0.0

    def wait_pulse(self, channel: int, expected: float, timeout: float = 30.0) -> float:
        """Wait until the channel outputs ``expected`` (within the accuracy); return it."""
        deadline = time.monotonic() + timeout
        while True:
            now = self.pulse_us(channel)
            if abs(now - expected) <= self.accuracy_us + 1e-9 or time.monotonic() > deadline:
                return now
            time.sleep(0.01)

    def steady_pulses_us(self, channels: list[int], timeout_s: float = 30.0) -> list[float]:
        """Each channel's pulse [µs] once a move in progress has ended: the same in two
        readings 0.3 s apart (the firmware in simavr lags real time on a loaded machine)."""
        deadline = time.monotonic() + timeout_s
        before = [self.pulse_us(ch) for ch in channels]
        while True:
            time.sleep(0.3)
            now = [self.pulse_us(ch) for ch in channels]
            if now == pytest.approx(before, abs=self.accuracy_us) or time.monotonic() > deadline:
                return now
            before = now

    def move_count(self) -> int | None:
        """``M`` frames received (resends included); ``None`` if the board cannot tell
        (the firmware in simavr: then a test checks that no pulse changed)."""
        received = getattr(self.board, "received", None)
        if received is None:
            return None
        return sum(1 for line in list(received) if b" M " in line)

    def history_us(self, channel: int) -> list[float]:
        """Every pulse the channel was given (fake Uno) or output (simavr), in order [µs]."""
        b = self.board
        if isinstance(b, FakeMearmBoard):
            return [float(move[channel]) for move in b.moves]
        return b.widths_us(channel)


@pytest.fixture(scope="session")
def virtual_uno_build(tmp_path_factory) -> tuple[Path, Path]:
    """The firmware and its simavr runner, built from the checkout (skipped without tools)."""
    build = simulator_build(tmp_path_factory)
    return build / "mearm_sim", build / "mearm_servo.elf"


BOARDS = ["fake_uno", "simavr_uno"]


def make_board(request: pytest.FixtureRequest) -> Iterator[BoardUnderTest]:
    """The board of ``request.param`` (one of :data:`BOARDS`), for a ``board`` fixture."""
    if request.param == "fake_uno":
        with FakeMearmBoard() as b:
            yield BoardUnderTest(b, accuracy_us=0.0)
    else:
        sim, elf = request.getfixturevalue("virtual_uno_build")
        with SimavrBoard(str(sim), str(elf)) as b:
            yield BoardUnderTest(b, accuracy_us=1.0)


@pytest.fixture(params=BOARDS)
def board(request: pytest.FixtureRequest) -> Iterator[BoardUnderTest]:
    """A board behind a pty, as the serial backend sees an Uno: the fake Uno, or the real
    firmware in simavr (pulses measured on its pins; firmware accuracy 1 µs)."""
    yield from make_board(request)


def serial_args(port: str) -> list[str]:
    """The serial backend on ``port``; 400 moves a second, not the paper's 50: the link is
    paced, and a session of keys held down (80 steps past a range's end, the jogs to
    each reference) spent most of its ~10 s waiting out the 20 ms frames."""
    return [
        "--config", str(ROOT / "configs" / "sim.yaml"),
        "--set", "servo.backend=serial", "--port", port,
        "--set", "servo.banner_timeout_s=5", "--set", "servo.ack_timeout_s=2",
        "--set", "servo.rate_hz=400",
    ]  # fmt: skip


@pytest.mark.slow
def test_calibrate_on_a_board_fits_its_servos_and_sends_only_allowed_pulses(board, tmp_path):
    """Every actuator of the paper arm on the fake Uno: the fit is the board's servo; every
    pulse the board got was inside its channel's range, even with keys pressed past it."""
    out = tmp_path / "servos.yaml"
    cmd = PtyCommand(*_args(out, *serial_args(board.port)))
    config = load_config(ROOT / "configs" / "sim.yaml")
    smap = ServoMap.from_arm(config.arm)
    try:
        cmd.expect(r"connected: mearm_servo 2\.0 5 on ")
        # first actuator: hammer 20 µs steps far past the end of its range, then operate
        cmd.expect(r"base: pulse (\d+) µs")
        cmd.send("3" + "\x1b[D" * 80)
        cmd.expect(r"base: pulse 600 µs .*\(end of the pulse range\)")
        assert board.wait_pulse(smap["base"].channel, 600) == pytest.approx(
            600, abs=board.accuracy_us
        )
        cmd.send("\x7f")  # Backspace: start this reference again
        recorded = operate_from_here(cmd, "base", BOARD_TRUTH)
        for name, expected in recorded.items():
            # the board really outputs the pulse recorded last for it
            got = board.wait_pulse(smap[name].channel, expected[-1])
            assert got == pytest.approx(expected[-1], abs=board.accuracy_us)
        rest = operate(cmd, BOARD_TRUTH, 4)
        assert cmd.wait() == 0, cmd.text[-2000:]
    finally:
        cmd.close()
    # (a joint a later actuator's pose moved, to keep the jaws off the table, holds that)
    moved = {
        a.name
        for a in smap.joints
        if re.search(rf"(moved |, ){re.escape(a.combination_text)} to ", cmd.text)
    }
    for name, pulses in rest.items():
        if name in moved:
            continue
        got = board.wait_pulse(smap[name].channel, pulses[-1])
        assert got == pytest.approx(pulses[-1], abs=board.accuracy_us)
    for a in smap.actuators:
        history = board.history_us(a.channel)
        assert history and min(history) >= a.min_us - board.accuracy_us, a.name
        assert max(history) <= a.max_us + board.accuracy_us, a.name
    refs = {a.name: reference_values(a.lower, a.upper, a.unit) for a in smap.actuators}
    check_fit(out, BOARD_TRUTH, refs)
    cal = load_servo_calibration(out)
    assert cal.board_id == "mearm_servo 2.0 5" and cal.port == board.port
    calibrated = apply_servo_calibration_file(config, out)
    assert calibrated.arm.tool.gripper.servo.direction == -1


def operate_from_here(cmd: PtyCommand, name: str, truth: dict[str, TrueServo]) -> dict:
    """:func:`operate` for an actuator whose header was already read."""
    recorded: dict[str, list[int]] = {}
    for _ in range(2):
        ref = float(cmd.expect(rf"move {name} to (-?[\d.]+) (deg|cm)").group(1))
        start = int(cmd.expect(rf"{name}: pulse (\d+) µs").group(1))
        goal = round(truth[name].pulse_us(ref))
        jog_to(cmd, start, goal)
        cmd.send("\r")
        cmd.expect(rf"recorded {name} at [-\d.]+ \w+: {goal} µs")
        recorded.setdefault(name, []).append(goal)
    cmd.expect(rf"{name}: zero ")
    return recorded


# --------------------------------------------------------------------------- refusals


#: A calibration of the paper arm's base, as a file written before the session.
OLD_CALIBRATION = (
    HEADER
    + """\
  base:
    {channel: 0, unit: deg, zero_us: 600.0, direction: 1, us_per_unit: 10.0, min_us: 600,
     max_us: 2400, residual_us: 0.0}
"""
)


@pytest.mark.slow
@pytest.mark.parametrize(("stop", "status"), [("ctrl-c", 130), ("sigterm", 143)])
def test_ctrl_c_writes_nothing_and_leaves_the_arm(board, tmp_path, stop, status):
    """Ctrl-C mid-session: exit 130, the old file untouched, the board's pulses unchanged.

    SIGTERM the same, exit 143 (it ended the process at once, the bus left as it was)."""
    out = tmp_path / "servos.yaml"
    out.write_text(OLD_CALIBRATION)  # (--force replaces only a calibration)
    cmd = PtyCommand(*_args(out, *serial_args(board.port), "--force"))
    try:
        cmd.expect(r"base: pulse (\d+) µs")
        cmd.send("3++")
        cmd.expect(r"base: pulse \d+ µs  step 20")
        channels = ServoMap.from_arm(load_config(ROOT / "configs" / "sim.yaml").arm).channels
        held = board.steady_pulses_us(channels)
        moves = board.move_count()
        if stop == "ctrl-c":
            cmd.send("\x03")
        else:
            cmd.proc.send_signal(signal.SIGTERM)
        assert cmd.wait() == status, cmd.text[-2000:]
    finally:
        cmd.close()
    assert out.read_text() == OLD_CALIBRATION and not (tmp_path / "servos.yaml.bak").exists()
    time.sleep(0.2)
    now = [board.pulse_us(ch) for ch in channels]
    assert now == pytest.approx(held, abs=board.accuracy_us)
    assert board.move_count() == moves  # both None on the simavr board
    assert "interrupted" in cmd.text


@pytest.mark.slow
def test_an_existing_calibration_is_replaced_only_after_yes(tmp_path):
    """N keeps the file (exit 1, nothing moved); y replaces it and keeps the old as .bak.

    The old file is written by the library (a session making it showed nothing more)."""
    from mearm.config.servo_file import CalibrationPoint as P
    from mearm.config.servo_file import (
        ServoCalibrationFile,
        fit_actuator,
        save_servo_calibration,
        servo_of,
    )

    out = tmp_path / "servos.yaml"
    arm = load_config(ROOT / "configs" / "sim.yaml").arm
    fits = tuple(
        fit_actuator(name, "deg", servo_of(arm, name), [P(50.0, 1100), P(115.0, 1750)])
        for name in ("shoulder", "elbow")
    )
    save_servo_calibration(out, ServoCalibrationFile(arm.name, "b", "", "d", fits))
    first = out.read_text()
    cmd = PtyCommand(*_args(out, *sim_args()))
    try:
        cmd.expect(r"exists: replace it .*\[y/N\]")
        cmd.send("n")
        assert cmd.wait() == 1
    finally:
        cmd.close()
    assert out.read_text() == first and "connected" not in cmd.text
    cmd = PtyCommand(*_args(out, *sim_args(), "--actuators", "base"))
    try:
        cmd.expect(r"\[y/N\]")
        cmd.send("y")
        operate(cmd, sim_truth(), 1)
        assert cmd.wait() == 0
    finally:
        cmd.close()
    assert (tmp_path / "servos.yaml.bak").read_text() == first
    # the file's fits of the actuators this session left alone are kept where they still
    # fit the arm (the elbow's made-up one does not), each named (1ba24ad)
    assert [a.name for a in load_servo_calibration(out).actuators] == ["base", "shoulder"]
    text = " ".join(cmd.text.split())
    assert "(1 actuator; shoulder kept from the file it replaced; elbow not kept" in text


@pytest.mark.heavy
@pytest.mark.parametrize("force", [[], ["--force"]], ids=["asked", "force"])
def test_a_file_that_is_not_a_servo_calibration_is_not_replaced(tmp_path, force):
    """Pointing --output at a config is refused before anything opens (exit 2), with
    --force too (it ran the session and replaced the config, and a second run its .bak)."""
    out = tmp_path / "my.yaml"
    out.write_text("arm: {}\n")
    cmd = PtyCommand(*_args(out, *sim_args(), *force))
    try:
        assert cmd.wait() == 2
    finally:
        cmd.close()
    assert "not a mearm servo calibration" in cmd.text and out.read_text() == "arm: {}\n"
    assert not (tmp_path / "my.yaml.bak").exists()


@pytest.mark.heavy
def test_without_a_terminal_exit_2_one_line(tmp_path):
    """No terminal: exit 2 with one line, before any port opens."""
    result = subprocess.run(
        [sys.executable, "-m", MODULES["calibrate-servos"], *_args(tmp_path / "s.yaml")[1:]],
        stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60, cwd=ROOT,
    )  # fmt: skip
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "needs a terminal" in lines[0], result.stderr
    assert not (tmp_path / "s.yaml").exists()


@pytest.mark.heavy
def test_q_writes_nothing(tmp_path):
    """q stops the session: exit 1, no file."""
    out = tmp_path / "servos.yaml"
    cmd = PtyCommand(*_args(out, *sim_args()))
    try:
        cmd.expect(r"base: pulse \d+ µs")
        cmd.send("q")
        assert cmd.wait() == 1
    finally:
        cmd.close()
    assert not out.exists() and "nothing written" in cmd.text


@pytest.mark.heavy
def test_unknown_actuator_is_bad_input(tmp_path):
    """--actuators with a name the arm lacks: exit 2 naming the arm's actuators."""
    r = run_in_process(_args(tmp_path / "s.yaml", "--actuators", "knee"))
    assert r.code == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "no actuator 'knee'" in r.stderr and "shoulder" in r.stderr
    assert not (tmp_path / "s.yaml").exists()


def test_reference_values_lie_inside_the_limits():
    """References are a fifth in from each end, on the 5° grid when that stays inside."""
    assert reference_values(30.0, 135.0, "deg") == (50.0, 115.0)
    assert reference_values(1.0, 4.0, "cm") == (1.5, 3.5)
    a, b = reference_values(10.0, 12.0, "deg")  # too narrow for the grid: exact
    assert 10.0 < a < b < 12.0


@pytest.mark.heavy
def test_calibration_file_round_trips_and_is_versioned(tmp_path):
    """The file carries format, version, kind, arm, board, date; a newer version is refused."""
    out = tmp_path / "servos.yaml"
    cmd = PtyCommand(*_args(out, *sim_args(), "--actuators", "shoulder"))
    try:
        operate(cmd, sim_truth(), 1)
        assert cmd.wait() == 0
    finally:
        cmd.close()
    data = yaml.safe_load(out.read_text())
    assert (data["format"], data["version"], data["kind"]) == (
        "mearm-servo-calibration",
        1,
        "servos",
    )
    assert data["date"] and data["board_id"]
    data["version"] = 2
    out.write_text(yaml.safe_dump(data))
    with pytest.raises(Exception, match="version 2; this mearm reads version 1"):
        load_servo_calibration(out)


# --------------------------------------------------------------------------- the file's library


def _servo(channel: int = 1):
    from mearm.config import ServoCalibration

    return ServoCalibration(channel=channel)


def test_fit_recovers_a_line_and_refuses_what_is_no_line():
    """Two points give zero, slope and direction exactly; one value twice, or one pulse
    at two values, is refused with the reason."""
    from mearm.config.servo_file import CalibrationPoint as P
    from mearm.config.servo_file import ServoCalibrationError, fit_actuator

    fit = fit_actuator("shoulder", "deg", _servo(), [P(50.0, 1900), P(115.0, 1250)])
    assert (fit.servo.zero_us, fit.servo.direction) == (pytest.approx(2400.0), -1)
    assert fit.servo.us_per_unit == pytest.approx(10.0)
    with pytest.raises(ServoCalibrationError, match="two references at different values"):
        fit_actuator("shoulder", "deg", _servo(), [P(50.0, 1900), P(50.0, 1250)])
    with pytest.raises(ServoCalibrationError, match="the servo did not move"):
        fit_actuator("shoulder", "deg", _servo(), [P(50.0, 1500), P(115.0, 1500)])


def test_apply_refuses_another_channel_and_limits_outside_the_pulse_range():
    """A fit on another channel, or one that maps a limit outside [min_us, max_us], is
    refused naming the actuator and the field."""
    from mearm.config import Config
    from mearm.config.servo_file import CalibrationPoint as P
    from mearm.config.servo_file import (
        ServoCalibrationError,
        apply_servo_calibration,
        fit_actuator,
    )
    from mearm.exceptions import ConfigError

    config = Config()
    wrong = fit_actuator("shoulder", "deg", _servo(channel=3), [P(50, 1100), P(115, 1750)])
    with pytest.raises(ServoCalibrationError, match="calibrated on channel 3"):
        apply_servo_calibration(config, [wrong])
    steep = fit_actuator("shoulder", "deg", _servo(), [P(50, 1100), P(115, 2400)])  # 20 µs/deg
    with pytest.raises(ConfigError, match=r"shoulder|joints\.1"):
        apply_servo_calibration(config, [steep])


def test_save_refuses_to_replace_without_force_and_keeps_a_backup(tmp_path):
    """An existing file stays without force; with force the old one becomes .bak."""
    from mearm.config.servo_file import CalibrationPoint as P
    from mearm.config.servo_file import (
        ServoCalibrationError,
        ServoCalibrationFile,
        fit_actuator,
        save_servo_calibration,
    )

    fit = fit_actuator("shoulder", "deg", _servo(), [P(50, 1100), P(115, 1750)])
    cal = ServoCalibrationFile("mearm_paper", "test board", "", "2026-01-01T00:00:00+00:00", (fit,))
    path = tmp_path / "s.yaml"
    path.write_text("old\n")
    with pytest.raises(ServoCalibrationError, match="exists: pass --force"):
        save_servo_calibration(path, cal)
    assert path.read_text() == "old\n"
    save_servo_calibration(path, cal, force=True)
    assert (tmp_path / "s.yaml.bak").read_text() == "old\n"
    back = load_servo_calibration(path).actuators[0].servo  # written to 1e-4 µs, 1e-6 µs/deg
    assert back.zero_us == pytest.approx(fit.servo.zero_us, abs=1e-4)
    assert back.us_per_unit == pytest.approx(fit.servo.us_per_unit, abs=1e-6)
    assert (back.channel, back.direction) == (fit.servo.channel, fit.servo.direction)


def test_load_names_a_missing_field(tmp_path):
    """A file without its board id is refused naming the field."""
    from mearm.config.servo_file import ServoCalibrationError

    path = tmp_path / "s.yaml"
    path.write_text(
        "format: mearm-servo-calibration\nversion: 1\nkind: servos\narm: a\ndate: d\n"
        "actuators: {base: {channel: 0, unit: deg}}\n"
    )
    with pytest.raises(ServoCalibrationError, match="missing field 'board_id'"):
        load_servo_calibration(path)


def test_a_config_naming_a_missing_servo_calibration_file_is_refused(tmp_path):
    """``servo.calibration_file`` must name a file (relative to the config's folder)."""
    text = (ROOT / "configs" / "sim.yaml").read_text()
    config = tmp_path / "mine.yaml"
    config.write_text(re.sub(r"(?m)^servo:\n", "servo:\n  calibration_file: gone.yaml\n", text))
    from mearm.exceptions import ConfigError

    with pytest.raises(ConfigError, match=r"servo\.calibration_file: 'gone.yaml' is not a file"):
        load_config(config)


# --------------------------------------------------------------------------- a servo over joints

MEARM = ROOT / "configs" / "sim_mearm_v1.yaml"


@pytest.mark.slow
def test_calibrate_a_servo_that_turns_shoulder_plus_elbow(tmp_path):
    """The MeArm v1's elbow servo, on the sim: the screen asks for the forearm's angle to
    the table (shoulder + elbow), at the library's -45° and +45° (a fifth in from the ±75°
    its pulse range reaches); the file records the combination, and the config takes it
    back through the file and through the printed overrides."""
    out = tmp_path / "servos.yaml"
    cmd = PtyCommand(*_args(out, "--config", str(MEARM), "--actuators", "elbow"))
    config = load_config(MEARM)
    truth = ServoMap.from_arm(config.arm)["elbow"]  # the sim's servo is the config's
    try:
        cmd.expect(r"\[1/1\] elbow \(joint, channel 2\): its servo turns shoulder \+ elbow: "
                   r"\[-75, 75\] deg")  # fmt: skip
        for ref in (-45.0, 45.0):
            shown = cmd.expect(r"move elbow's servo until shoulder \+ elbow = (-?[\d.]+) deg")
            assert float(shown.group(1)) == ref
            start = int(cmd.expect(r"elbow: pulse (\d+) µs").group(1))
            goal = truth.command_us(ref)
            jog_to(cmd, start, goal)
            cmd.expect(r"target shoulder \+ elbow = -?[\d.]+ deg  simulated arm: (-?[\d.]+) deg")
            cmd.send("\r")
            cmd.expect(rf"recorded elbow at {ref:g} deg: {goal} µs")
        assert cmd.wait() == 0, cmd.text[-2000:]
    finally:
        cmd.close()
    assert [round(truth.pulse_us(v)) for v in (-45.0, 45.0)] == [915, 2029]  # 36, 144 servo °
    cal = load_servo_calibration(out)
    (fit,) = cal.actuators
    assert fit.drives is not None and dict(fit.drives.terms) == {"shoulder": 1.0, "elbow": 1.0}
    check_fit(out, {"elbow": TrueServo(truth.zero_us, truth.direction, truth.us_per_unit)},
              {"elbow": (-45.0, 45.0)})  # fmt: skip
    lines = re.findall(r"--set '([^']+)'", cmd.text)
    assert lines == servo_overrides(config.arm, cal.actuators) and "drives:" in lines[0]
    via_set = load_config(MEARM, lines)
    via_file = apply_servo_calibration_file(config, out)
    assert via_set.arm.joints[2].servo == via_file.arm.joints[2].servo
    assert via_file.arm.joints[2].servo.drives == config.arm.joints[2].servo.drives


def test_a_fit_of_a_servo_over_joints_keeps_its_combination(tmp_path):
    """Fitted on shoulder + elbow, the servo keeps its ``drives`` through the file; the
    file applies only to a servo that turns the same combination."""
    from mearm.config.servo_file import CalibrationPoint as P
    from mearm.config.servo_file import (
        ServoCalibrationError,
        ServoCalibrationFile,
        apply_servo_calibration,
        fit_actuator,
        save_servo_calibration,
        servo_of,
    )

    config = load_config(MEARM)
    fit = fit_actuator("elbow", "deg", servo_of(config.arm, "elbow"), [P(-45, 915), P(45, 2029)])
    assert fit.servo.zero_us == pytest.approx(1472.0) and fit.servo.direction == 1
    assert fit.servo.us_per_unit == pytest.approx(1114 / 90)
    assert fit.drives == config.arm.joints[2].servo.drives
    path = save_servo_calibration(
        tmp_path / "s.yaml", ServoCalibrationFile("mearm_v1", "b", "", "d", (fit,))
    )
    entry = yaml.safe_load(path.read_text())["actuators"]["elbow"]
    assert entry["drives"] == {"terms": {"shoulder": 1.0, "elbow": 1.0}, "offset": 0.0}
    back = load_servo_calibration(path).actuators[0]
    assert back.drives == fit.drives and back.servo.zero_us == pytest.approx(1472.0)
    applied = apply_servo_calibration(config, [back])
    assert applied.arm.joints[2].servo.drives == fit.drives
    # the same elbow, its servo turning the elbow alone: the fit does not apply
    alone = load_config(MEARM, ["arm.joints.elbow.servo.drives=null",
                                "arm.joints.elbow.servo.zero_us=358",
                                "arm.joints.elbow.servo.direction=-1"])  # fmt: skip
    with pytest.raises(ServoCalibrationError, match="calibrated turning shoulder \\+ elbow, "
                       "the config's turns elbow: recalibrate"):  # fmt: skip
        apply_servo_calibration(alone, [back])
    per_joint = fit_actuator("elbow", "deg", servo_of(alone.arm, "elbow"), [P(-135, 2028),
                             P(-45, 915)])  # fmt: skip
    with pytest.raises(ServoCalibrationError, match="calibrated turning elbow, the config's "
                       "turns shoulder \\+ elbow"):  # fmt: skip
        apply_servo_calibration(config, [per_joint])


@pytest.mark.parametrize(
    ("field", "value", "words"),
    [
        (
            "pulse_us",
            ".inf",
            "base.points[0].pulse_us must be a whole number in 0 … 10000, got inf",
        ),
        (
            "pulse_us",
            "1500.5",
            "base.points[0].pulse_us must be a whole number in 0 … 10000, got 1500.5",
        ),
        ("value", ".nan", "base.points[0].value must be a number in -1000 … 1000, got nan"),
        ("residual_us", ".inf", "base.residual_us must be a number in 0 … 10000, got inf"),
    ],
)
def test_a_number_out_of_range_in_the_file_is_named(tmp_path, field, value, words):
    """``.inf`` as a pulse raised OverflowError (a traceback); NaN as a value was taken."""
    from mearm.config.servo_file import (
        CalibrationPoint,
        ServoCalibrationError,
        ServoCalibrationFile,
        fit_actuator,
        load_servo_calibration,
    )

    points = [CalibrationPoint(60.0, 1200), CalibrationPoint(120.0, 1800)]
    fit = fit_actuator("base", "deg", _servo(), points)
    text = ServoCalibrationFile("paper", "mearm 1", "", "2026-01-01", (fit,)).text()
    data = yaml.safe_load(text)
    target = data["actuators"]["base"]
    if field == "residual_us":
        target["residual_us"] = "X"
    else:
        target["points"][0][field] = "X"
    path = tmp_path / "servos.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False).replace("X", value).replace("'", ""))
    with pytest.raises(ServoCalibrationError) as caught:
        load_servo_calibration(path)
    assert str(caught.value) == f"{path}: {words}"


def test_the_overrides_and_the_file_keep_the_servos_speed(tmp_path):
    """A calibration sets zero, direction and µs per unit; the servo's speed
    (``seconds_per_60deg``) stays the arm's. It was reset to the default 0.1 s/60°, so a
    calibrated arm planned moves faster than its servos turn."""
    from mearm.config.servo_file import CalibrationPoint as P
    from mearm.config.servo_file import (
        ServoCalibrationFile,
        fit_actuator,
        save_servo_calibration,
        servo_of,
    )

    path = ROOT / "configs" / "sim.yaml"
    config = load_config(path)
    before = servo_of(config.arm, "base")
    assert before.seconds_per_60deg == 0.15  # the paper's RDS3135
    fit = fit_actuator("base", "deg", before, [P(50.0, 1110), P(130.0, 1900)])
    (line,) = servo_overrides(config.arm, [fit])
    assert "seconds_per_60deg: 0.15" in line
    file = save_servo_calibration(
        tmp_path / "s.yaml", ServoCalibrationFile(config.arm.name, "b", "", "d", (fit,))
    )
    for calibrated in (load_config(path, [line]), apply_servo_calibration_file(config, file)):
        servo = servo_of(calibrated.arm, "base")
        assert servo.seconds_per_60deg == 0.15
        assert servo.us_per_unit == pytest.approx(790 / 80)


def test_the_pose_for_a_joints_references_moves_only_what_it_must():
    """Each servo over its own joint: the others stay. The MeArm v1's elbow servo: with
    the shoulder at 90° (home) both references keep the elbow inside its limits, and the
    shoulder stays; at 120° or 40° one of them would put the elbow on a stop, and the
    shoulder goes home; the base, which no reference moves, stays where it is."""
    from mearm.maker.calibrate_servos import actuators_of, reference_pose

    for config_path, name, others in (
        (ROOT / "configs" / "sim.yaml", "elbow", {"base": 70.0, "shoulder": 60.0}),
        (MEARM, "elbow", {"base": 60.0, "shoulder": 90.0}),
    ):
        config = load_config(config_path)
        smap = ServoMap.from_arm(config.arm)
        act = {a.name: a for a in actuators_of(config)}[name]
        home = smap.servo_values(config.arm.home())
        assert reference_pose(smap, act, others, home) == others
    for shoulder in (120.0, 40.0):
        pose = reference_pose(smap, act, {"base": 60.0, "shoulder": shoulder}, home)
        assert pose == {"base": 60.0, "shoulder": 90.0}
        for ref in act.references:
            joints = smap.joints_of({**pose, "elbow": ref})
            assert -150.0 < joints["elbow"] < -20.0
