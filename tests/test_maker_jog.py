"""``mearm jog`` driven with real keystrokes through a pseudo-terminal.

The test types keys and reads the readout; on the boards (the fake Uno and the real
firmware in simavr, the ``board`` fixture of ``test_maker_calibrate``) it also reads the
pulses the board outputs and turns them back into joints and a TCP position with the
config's calibration and the arm model: the pose the arm really reached.
"""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from badinput import run_in_process
from fakeboard import FakeMearmBoard
from test_maker_calibrate import (  # noqa: F401  (virtual_uno_build: a fixture)
    BOARD_TRUTH,
    BOARDS,
    ROOT,
    BoardUnderTest,
    PtyCommand,
    make_board,
    operate,
    serial_args,
    virtual_uno_build,
)

from mearm.config import load_config
from mearm.hardware import ServoMap
from mearm.kinematics import ArmModel
from mearm.maker.jog import CARTESIAN_STEPS_CM, JOINT_STEPS, TCP_ON_BOUND_CM

SIM = ROOT / "configs" / "sim.yaml"


@pytest.fixture(params=BOARDS)
def board(request: pytest.FixtureRequest) -> Iterator[BoardUnderTest]:
    """The fake Uno, or the real firmware in simavr (see ``test_maker_calibrate``)."""
    yield from make_board(request)


CONFIG = load_config(SIM)
MODEL = ArmModel(CONFIG.arm)
SMAP = ServoMap.from_arm(CONFIG.arm)
#: Cartesian steps land within the IK tolerance of their target: |e|² < tolerance_cm2.
IK_TOL_CM = float(np.sqrt(CONFIG.controller.tolerance_cm2))
#: Default step index 2: 2° per joint step, 1 cm per TCP step.
JOINT_STEP = JOINT_STEPS[2]
TCP_STEP = CARTESIAN_STEPS_CM[2]


READOUT = re.compile(
    r"((?:[* ] \w+ +-?[\d.]+ deg.*\n)+)  TCP x (-?[\d.]+)  y (-?[\d.]+)  z (-?[\d.]+) cm"
)


def _parse(m: re.Match[str]) -> tuple[dict[str, float], np.ndarray]:
    joints = {
        j.group(1): float(j.group(2))
        for j in re.finditer(r"[* ] (\w+) +(-?[\d.]+) deg", m.group(1))
    }
    return joints, np.array([float(m.group(k)) for k in (2, 3, 4)])


def readout(cmd: PtyCommand) -> tuple[dict[str, float], np.ndarray]:
    """Wait for the next full readout; its joints [deg] and TCP [cm]."""
    return _parse(cmd.expect(READOUT.pattern))


def last_readout(cmd: PtyCommand) -> tuple[dict[str, float], np.ndarray]:
    """The last complete readout on the screen so far (no waiting)."""
    found = list(READOUT.finditer(cmd.text))
    assert found, cmd.text[-2000:]
    return _parse(found[-1])


def fk_of(joints: dict[str, float]) -> np.ndarray:
    actuated = {n: joints[n] for n in MODEL.chain.actuated}
    return MODEL.fk_cm(MODEL.chain.from_named(actuated))


def jog_session(cmd: PtyCommand) -> tuple[dict[str, float], np.ndarray, np.ndarray]:
    """Home; shoulder +3 steps, elbow -2 steps; then TCP +2 x and +1 z.

    Returns the joints after the joint moves, the TCP then, and the final readout's TCP.
    """
    home, tcp_home = readout(cmd)
    assert home == pytest.approx(
        {**CONFIG.arm.home(), "wrist": -CONFIG.arm.home()["shoulder"] - CONFIG.arm.home()["elbow"]}
    )
    cmd.send("2+++")
    cmd.send("3--")
    for _ in range(7):
        joints, tcp = readout(cmd)
    expected = dict(CONFIG.arm.home())
    expected["shoulder"] += 3 * JOINT_STEP
    expected["elbow"] -= 2 * JOINT_STEP
    for name, value in expected.items():
        assert joints[name] == pytest.approx(value, abs=1e-3)
    assert tcp == pytest.approx(fk_of(joints), abs=2e-3)
    cmd.send("XXZ")
    for _ in range(3):
        final_joints, final_tcp = readout(cmd)
    assert final_tcp == pytest.approx(fk_of(final_joints), abs=2e-3)
    return joints, tcp, final_tcp


@pytest.mark.slow
def test_jog_on_the_sim_reaches_the_poses_keyed(tmp_path):
    """Joint steps land exactly; TCP steps land within the IK tolerance of their targets
    (aimed from the previous target, so errors do not add up); q parks at home."""
    cmd = PtyCommand("jog", "--config", str(SIM))
    try:
        _, tcp, final_tcp = jog_session(cmd)
        goal = tcp + np.array([2 * TCP_STEP, 0.0, TCP_STEP])
        assert np.linalg.norm(final_tcp - goal) <= IK_TOL_CM + 2e-3
        cmd.send("q")
        cmd.expect("going home")
        assert cmd.wait() == 0, cmd.text[-2000:]
    finally:
        cmd.close()
    assert "done" in cmd.text


@pytest.mark.heavy
@pytest.mark.parametrize("command", ["jog", "calibrate-servos"])
def test_a_port_given_to_a_simulated_arm_is_refused(command, tmp_path):
    """``--port`` with ``servo.backend: sim`` drove the simulated arm and exited 0, the
    maker believing a board was moved (or calibrated)."""
    out = ["--output", str(tmp_path / "s.yaml")] if command == "calibrate-servos" else []
    cmd = PtyCommand(command, "--config", str(SIM), "--port", "/dev/ttyACM0", *out)
    try:
        assert cmd.wait() == 2, cmd.text[-2000:]
    finally:
        cmd.close()
    said = "--port: /dev/ttyACM0: servo.backend is 'sim', which opens no serial port"
    assert said in cmd.text
    assert not (tmp_path / "s.yaml").exists()


def board_pose(board) -> tuple[dict[str, float], np.ndarray]:
    """The joints the board's pulses give through the config's calibration, and their FK."""
    joints = {a.name: a.value_of(board.pulse_us(a.channel)) for a in SMAP.joints}
    return joints, MODEL.fk_cm(MODEL.chain.from_named(joints))


def settled_pulses(board: BoardUnderTest) -> list[float]:
    """Every joint's pulse after 0.3 s without keys [µs] (a move in flight has landed)."""
    time.sleep(0.3)
    return [board.pulse_us(a.channel) for a in SMAP.joints]


def wait_board_joints(board, expected: dict[str, float]) -> None:
    for a in SMAP.joints:
        board.wait_pulse(a.channel, a.command_us(expected[a.name]))


def pulses_at(board: BoardUnderTest, joints: dict[str, float]) -> list[float]:
    """Every joint's pulse once the board outputs the readout's ``joints`` [µs]: on a loaded
    machine the firmware in simavr can still be gliding to it well after the readout."""
    wait_board_joints(board, joints)
    return settled_pulses(board)


@pytest.mark.slow
def test_jog_on_a_board_reaches_the_poses_and_parks(board):
    """The pulses the board outputs are the readout's joints (to 1 µs plus the board's
    accuracy); the TCP they give is the keyed target within the IK tolerance plus what
    whole-µs pulses allow; q brings the board's pulses back to home."""
    cmd = PtyCommand("jog", *serial_args(board.port))
    try:
        joints, tcp, final_tcp = jog_session(cmd)
        final_joints, _ = last_readout(cmd)
        assert fk_of(final_joints) == pytest.approx(final_tcp, abs=2e-3)
        wait_board_joints(board, final_joints)
        for a in SMAP.joints:
            assert board.pulse_us(a.channel) == pytest.approx(
                a.pulse_us(final_joints[a.name]), abs=0.5 + board.accuracy_us
            )
        _, reached = board_pose(board)
        goal = tcp + np.array([2 * TCP_STEP, 0.0, TCP_STEP])
        # 1.5 µs at 10 µs/deg is 0.15° per joint: under 0.15 cm at this arm's reach
        assert np.linalg.norm(reached - goal) <= IK_TOL_CM + 0.15
        cmd.send("q")
        assert cmd.wait() == 0, cmd.text[-2000:]
    finally:
        cmd.close()
    home = CONFIG.arm.home()
    for a in SMAP.joints:
        got = board.wait_pulse(a.channel, a.command_us(home[a.name]))
        assert got == pytest.approx(a.command_us(home[a.name]), abs=board.accuracy_us)


@pytest.mark.slow
def test_a_move_past_a_limit_is_refused_and_sends_nothing(board):
    """Shoulder at 93° in 10° steps: 133° goes, the step to 143° stops on the 135° limit,
    and the next, to 145°, is refused with its limits named, and no frame reaches the
    board; so does a TCP step up out of the target box: it stops at the box's top (said,
    the board at the pose the screen shows), and the next is refused."""
    cmd = PtyCommand("jog", *serial_args(board.port))
    try:
        readout(cmd)
        cmd.send("2]]" + "+" * 5)
        for _ in range(8):
            joints, _ = readout(cmd)
        assert joints["shoulder"] == pytest.approx(135.0, abs=1e-3)
        held, moves = pulses_at(board, joints), board.move_count()
        cmd.send("+")
        cmd.expect(
            r"refused: shoulder would be at 145 deg, outside its limits \[30, 135\] deg; "
            r"nothing sent"
        )
        assert settled_pulses(board) == pytest.approx(held, abs=board.accuracy_us)
        assert board.move_count() == moves  # None == None on the simavr board
        cmd.send("Z" * 6)  # 5 cm steps up from z 34.9 cm: the box ends at z = 60 cm
        cmd.expect(
            r"stopped after 0\.\d\d of the 5 cm step along \+z: z = 60\.?\d* is outside the "
            r"target box z ∈ \[10, 60\] cm"
        )
        joints_after, tcp_after = readout(cmd)
        assert tcp_after[2] == pytest.approx(60.0, abs=TCP_ON_BOUND_CM + IK_TOL_CM + 2e-3)
        held, moves = pulses_at(board, joints_after), board.move_count()
        cmd.send("Z")
        cmd.expect(r"refused: z = 65 is outside the target box .*; nothing sent")
        assert settled_pulses(board) == pytest.approx(held, abs=board.accuracy_us)
        assert board.move_count() == moves
        cmd.send("Q")
        assert cmd.wait() == 0
    finally:
        cmd.close()
    # Q leaves the arm where it was: the board still outputs the last readout's pose
    for a in SMAP.joints:
        assert board.pulse_us(a.channel) == pytest.approx(
            a.pulse_us(joints_after[a.name]), abs=0.5 + board.accuracy_us
        )


@pytest.mark.slow
def test_ctrl_c_stops_where_the_arm_is(board):
    """Ctrl-C: exit 130, nothing more sent, the arm holds its pose."""
    cmd = PtyCommand("jog", *serial_args(board.port))
    try:
        readout(cmd)
        cmd.send("1++")
        readout(cmd)
        readout(cmd)
        joints, _ = readout(cmd)
        held, moves = pulses_at(board, joints), board.move_count()
        cmd.send("\x03")
        assert cmd.wait() == 130
    finally:
        cmd.close()
    assert settled_pulses(board) == pytest.approx(held, abs=board.accuracy_us)
    assert board.move_count() == moves  # None == None on the simavr board
    base = SMAP["base"]
    assert board.pulse_us(base.channel) == pytest.approx(
        base.pulse_us(CONFIG.arm.home()["base"] + 2 * JOINT_STEP), abs=0.5 + board.accuracy_us
    )
    assert "interrupted" in cmd.text


#: Each command's pulse is whole µs, off the exact one by up to 0.5 µs (the 0.5 µs these
#: tests allow a pulse against the readout): a step between two commands by up to 1 µs.
PULSE_ROUNDING_US = 1.0


@pytest.mark.slow
@pytest.mark.parametrize(
    "sets",
    [
        # the paper arm's servos turn 400°/s (0.15 s/60°): at 250 Hz 1.6° a command, not
        # the 2° of a joint path's step (500°/s)
        ["servo.rate_hz=250"],
        # a slow base: 60°/s, at the paper's 50 Hz 1.2° a command (a 2° step was 100°/s)
        ["arm.joints.base.servo.seconds_per_60deg=1.0"],
    ],
    ids=["250Hz", "slow_base"],
)
def test_every_jog_move_keeps_the_servos_speed_limits(sets: list[str]):
    """Joint steps, TCP steps, ``h`` and ``q`` (home) are streamed as the sort streams
    its moves, timed within every servo's speed limit: on the fake Uno no two commands
    in a row turn a joint servo further than its ``seconds_per_60deg`` allows in a bus
    period (whole-µs pulses aside), and the moves land where the readout says."""
    config = load_config(SIM, overrides=["servo.backend=serial", *sets])
    smap = ServoMap.from_arm(config.arm)
    seconds = {j.name: j.servo.seconds_per_60deg for j in config.arm.actuated_joints()}
    period_s = 1.0 / config.servo.rate_hz
    with FakeMearmBoard() as fake:
        args = ["--config", str(SIM), "--set", "servo.backend=serial", "--port", fake.port,
                "--set", "servo.banner_timeout_s=5", "--set", "servo.ack_timeout_s=2"]  # fmt: skip
        for kv in sets:
            args += ["--set", kv]
        cmd = PtyCommand("jog", *args)
        try:
            readout(cmd)
            # base +2° twice, shoulder +2° three times, elbow -2° twice, the TCP +x, +x,
            # +z 1 cm, then 10° steps: base -10°, home, base +10°, and q: home, quit
            for keys, readouts in (("1++", 3), ("2+++", 4), ("3--", 3), ("XXZ", 3),
                                   ("]]", 2), ("1-", 2), ("h", 1), ("+", 1)):  # fmt: skip
                cmd.send(keys)
                for _ in range(readouts):
                    joints, _ = readout(cmd)
            assert joints["base"] == pytest.approx(CONFIG.arm.home()["base"] + 10.0, abs=1e-3)
            cmd.send("q")
            assert cmd.wait() == 0, cmd.text[-2000:]
        finally:
            cmd.close()
        assert "refused" not in cmd.text, cmd.text[-2000:]
        moves = list(fake.moves)
    home = CONFIG.arm.home()
    for a in smap.joints:
        values = np.array([a.value_of(m[a.channel]) for m in moves])
        steps = np.abs(np.diff(values))
        allowed = 60.0 / seconds[a.name] * period_s + PULSE_ROUNDING_US / a.us_per_unit
        assert steps.max() <= allowed + 1e-9, (a.name, steps.max(), allowed)
        assert values[-1] == pytest.approx(home[a.name], abs=0.5 / a.us_per_unit)
    base = smap["base"]
    base_steps = np.abs(np.diff([base.value_of(m[base.channel]) for m in moves]))
    # not crawling: the base's 10° steps ran at its limit
    assert base_steps.max() >= 0.9 * 60.0 / seconds["base"] * period_s


@pytest.mark.slow
def test_calibrate_then_jog_puts_the_true_servo_at_the_angle(board, tmp_path):
    """Calibrate base on the board's true servo, then jog with that file: at home the
    board's pulse puts the true servo at the home angle (within the fit's error)."""
    out = tmp_path / "servos.yaml"
    cmd = PtyCommand(
        "calibrate-servos", "--output", str(out), "--actuators", "base", *serial_args(board.port)
    )
    try:
        operate(cmd, BOARD_TRUTH, 1)
        assert cmd.wait() == 0, cmd.text[-2000:]
    finally:
        cmd.close()
    cmd = PtyCommand("jog", *serial_args(board.port), "--servo-calibration", str(out))
    try:
        readout(cmd)
        base = SMAP["base"]
        (pulse,) = board.steady_pulses_us([base.channel])
        cmd.send("Q")
        assert cmd.wait() == 0
    finally:
        cmd.close()
    home = CONFIG.arm.home()["base"]
    # the config alone would put it 4.6° off (640 vs 600 µs zero, 10.4 vs 10 µs/deg)
    assert abs(BOARD_TRUTH["base"].value_of(SMAP["base"].pulse_us(home)) - home) > 3.0
    assert BOARD_TRUTH["base"].value_of(pulse) == pytest.approx(home, abs=0.2)


@pytest.mark.heavy
def test_jog_without_a_terminal_is_exit_2(tmp_path: Path):
    """No terminal: exit 2 with one line."""
    import subprocess
    import sys

    result = subprocess.run(
        [sys.executable, "-m", "mearm.maker.jog", "--config", str(SIM)],
        stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60, cwd=ROOT,
    )  # fmt: skip
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "needs a terminal" in lines[0], result.stderr


@pytest.mark.heavy
def test_jog_with_a_bad_calibration_file_is_exit_2(tmp_path: Path):
    """--servo-calibration naming something else: exit 2 naming the file."""
    bad = tmp_path / "x.yaml"
    bad.write_text("a: 1\n")
    r = run_in_process(["jog", "--config", str(SIM), "--servo-calibration", str(bad)])
    assert r.code == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "not a mearm servo calibration" in r.stderr and str(bad) in r.stderr


# --------------------------------------------------------------------------- a servo over joints


def test_jog_checks_the_mearm_forearm_servo_on_shoulder_plus_elbow():
    """The MeArm v1 on the sim: the readout shows the elbow servo's value, shoulder +
    elbow, and its room to each end of the pulse range; a 10° shoulder step that keeps
    every joint inside its limits but would take that sum from +70° to +80° stops where
    it reaches the end of the pulse range (+75.0002°, 2400 µs), the readout showing no
    room left; the next step is refused, nothing sent."""
    import io

    from mearm.maker.calibrate_servos import open_arm_bus
    from mearm.maker.jog import Jogger, Refused

    config = load_config(ROOT / "configs" / "sim_mearm_v1.yaml")
    forearm = ServoMap.from_arm(config.arm)["elbow"]
    end = forearm.pulse_limits[1]  # 75.0002°: 2400 µs
    out = io.StringIO()
    with open_arm_bus(config) as bus:
        jogger = Jogger(config, bus, out)
        jogger.executor.home_pose()
        jogger.readout()
        line = (
            r"  elbow's servo \(shoulder \+ elbow\): (-?[\d.]+) deg   to its pulse range "
            r"-[\d.]+ / \+(-?[\d.]+) deg"
        )
        assert float(re.findall(line, out.getvalue())[-1][0]) == pytest.approx(0.0)
        jogger.step_index = JOINT_STEPS.index(10.0)
        jogger.selected = 2  # the elbow joint: up to -20°, the forearm at +70°
        for _ in range(7):
            jogger.move_joint(+1)
        jogger.readout()
        assert float(re.findall(line, out.getvalue())[-1][0]) == pytest.approx(70.0)
        jogger.selected = 1  # the shoulder from 90° to 100° would put the forearm at +80°
        jogger.move_joint(+1)
        joints = jogger.chain.named(jogger.executor.q_now())
        assert joints["shoulder"] + joints["elbow"] == pytest.approx(end, abs=1e-9)
        assert joints["shoulder"] + joints["elbow"] <= end  # on the end, not past it
        assert joints["shoulder"] == pytest.approx(90.0 + end - 70.0, abs=1e-9)
        assert bus.state is not None
        assert forearm.command_us(forearm.servo_value(bus.state.joints)) == 2400
        jogger.readout()
        assert re.findall(line, out.getvalue())[-1] == ("75.000", "0.000")
        sent = bus.state
        past = (
            r"elbow's servo \(shoulder \+ elbow\) = 7[5-9][.\d]* deg needs a [\d.]+ µs "
            r"pulse on channel 2, outside its \[544, 2400\]"
        )
        with pytest.raises(Refused, match=past):
            jogger.move_joint(+1)  # the first pose of the path past +75° is named
        assert bus.state == sent  # refused before anything was sent
        jogger.selected = 2  # the elbow joint past its own limit: refused by the joint's
        with pytest.raises(Refused, match=r"elbow would be at -10 deg, outside its limits"):
            jogger.move_joint(+1)
        assert bus.state == sent


# --------------------------------------------------------------------------- a TCP step on a bound


def test_a_tcp_step_past_the_target_box_stops_at_its_edge():
    """The sim's TCP in 5 cm steps along +y from home (y 34.9 cm): five go whole; the
    sixth, to 64.9 cm past the box's y = 60 cm, stops within TCP_ON_BOUND_CM of it and
    says so, the TCP there within the IK tolerance and x, z aimed as before; the seventh
    is refused whole, nothing sent; a step back goes whole."""
    import io

    from mearm.maker.calibrate_servos import open_arm_bus
    from mearm.maker.jog import Jogger, Refused

    out = io.StringIO()
    with open_arm_bus(CONFIG) as bus:
        jogger = Jogger(CONFIG, bus, out)
        jogger.executor.home_pose()
        jogger.step_index = CARTESIAN_STEPS_CM.index(5.0)
        start = MODEL.fk_cm(jogger.executor.q_now())
        for _ in range(5):
            jogger.move_tcp(1, +1)
        assert "stopped" not in out.getvalue()
        jogger.move_tcp(1, +1)
        said = out.getvalue().strip().splitlines()[-1]
        assert re.fullmatch(
            r"stopped after 0\.\d\d of the 5 cm step along \+y: y = 60\.0\d* is outside the "
            r"target box y ∈ \[20, 60\] cm",
            said,
        ), said
        assert jogger.target_cm is not None
        assert 60.0 - TCP_ON_BOUND_CM <= jogger.target_cm[1] <= 60.0
        assert jogger.target_cm[[0, 2]] == pytest.approx(start[[0, 2]], abs=1e-12)
        tcp = MODEL.fk_cm(jogger.executor.q_now())
        assert np.linalg.norm(tcp - jogger.target_cm) <= IK_TOL_CM
        assert bus.state is not None
        assert fk_of(bus.state.joints) == pytest.approx(tcp, abs=1e-9)  # sent
        sent = bus.state
        with pytest.raises(Refused, match=r"y = 65 is outside the target box"):
            jogger.move_tcp(1, +1)
        assert bus.state == sent
        jogger.move_tcp(1, -1)
        assert jogger.target_cm[1] == pytest.approx(60.0 - 5.0, abs=TCP_ON_BOUND_CM)


def test_a_tcp_step_stops_before_a_joint_would_pass_its_limit():
    """The MeArm v1's TCP in 5 cm steps along -x from home (x 0): two go whole; the third
    would need the elbow past its -20° limit (the arm stretched out) and stops where the
    IK still lands inside it, saying which limit; the next is refused, nothing sent."""
    import io

    from mearm.maker.calibrate_servos import open_arm_bus
    from mearm.maker.jog import Jogger, Refused

    config = load_config(ROOT / "configs" / "sim_mearm_v1.yaml")
    out = io.StringIO()
    with open_arm_bus(config) as bus:
        jogger = Jogger(config, bus, out)
        jogger.executor.home_pose()
        jogger.step_index = CARTESIAN_STEPS_CM.index(5.0)
        for _ in range(3):
            jogger.move_tcp(0, -1)
        said = out.getvalue().strip().splitlines()[-1]
        assert re.fullmatch(
            r"stopped after [34]\.\d\d of the 5 cm step along -x: needs elbow = -19\.9\d* deg, "
            r"outside its limits \[-150, -20\] deg",
            said,
        ), said
        assert jogger.target_cm is not None and -15.0 < jogger.target_cm[0] < -10.0
        elbow = jogger.chain.named(jogger.executor.q_now())["elbow"]
        assert -22.0 < elbow <= -20.0  # inside, near the limit (stretched out: IK tolerance)
        sent = bus.state
        with pytest.raises(Refused):
            jogger.move_tcp(0, -1)
        assert bus.state == sent
