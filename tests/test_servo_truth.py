"""The kit's true servo calibration (``calibrate-servos --simulate --truth``) and the bound
its servos set at the picks (:mod:`mearm.analysis.servo_bound`).

Real twin, no mocks: the file is read back and compared with the twin's own units.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mearm.analysis.servo_bound import kit_half_widths, pick_jacobians, tcp_error_bound
from mearm.config import load_config
from mearm.config.servo_file import load_servo_calibration
from mearm.kinematics.model import ArmModel
from mearm.maker import calibrate_servos
from mearm.runlog.records import RouteRecord
from mearm.sim.twin.servo_kit import unit_calibration
from mearm.sim.twin.twin_bus import TwinArm

ROOT = Path(__file__).resolve().parent.parent
CONFIG = str(ROOT / "configs" / "sim_mujoco_perspective.yaml")
SETS = ["twin.kit.seed=37", "twin.kit.spread=1", "twin.kit.per_trial=false"]


def _argv(*sets: str) -> list[str]:
    return [a for s in sets for a in ("--set", s)]


def _truth(tmp_path: Path) -> Path:
    out = tmp_path / "truth.servos.yaml"
    argv = ["--config", CONFIG, "--simulate", "--truth", "--output", str(out), *_argv(*SETS)]
    assert calibrate_servos.main(argv) == 0
    return out


def test_truth_writes_each_units_own_calibration_and_play(tmp_path: Path) -> None:
    """Every servo's entry is its unit's mapping, its play the unit's backlash in its pulses."""
    fits = {a.name: a for a in load_servo_calibration(_truth(tmp_path)).actuators}
    twin = TwinArm(load_config(CONFIG, SETS))
    assert set(fits) == {s.name for s in twin.servos}
    for s in twin.servos:
        assert s.unit is not None
        a, fit = s.physical, fits[s.name]
        zero, direction, k = unit_calibration(s.unit, a.zero_us, a.direction, a.us_per_unit)
        assert fit.servo.zero_us == pytest.approx(zero, abs=1e-4)
        assert fit.servo.direction == direction
        assert fit.servo.us_per_unit == pytest.approx(k, abs=1e-6)
        assert fit.servo.play_us == pytest.approx(s.backlash / s.scale * k, abs=0.01)
        assert fit.replaces is not None and fit.replaces.zero_us == a.zero_us


def test_with_the_truth_the_twin_goes_where_it_is_told(tmp_path: Path) -> None:
    """The file's config drives the same kit; each joint ends within its dead band and a
    µs of its command (the nominal calibration was farther off). A first move sets each
    servo's side: the bus compensates the play of a servo that has moved."""
    from mearm.hardware import ArmCommand

    sets = [*SETS, f"servo.calibration_file={_truth(tmp_path)}"]
    first = {"base": 80.0, "shoulder": 90.0, "elbow": -120.0}
    goal = {"base": 70.0, "shoulder": 100.0, "elbow": -110.0}
    errors = []
    for twin in (TwinArm(load_config(CONFIG, SETS)), TwinArm(load_config(CONFIG, sets))):
        with twin:
            twin.move(ArmCommand(first, {"gripper_arm": 60.0}, False))
            twin.settle(1.0)
            twin.move(ArmCommand(goal, {"gripper_arm": 60.0}, False))
            twin.settle(1.0)
            got = twin.actual_joints
        errors.append({n: abs(got[n] - v) for n, v in goal.items()})
    widths = kit_half_widths(load_config(CONFIG, sets))
    for n in goal:
        assert errors[1][n] <= widths[n][0] + 2 * widths[n][1] + 0.35, n  # + the load's sag
    assert max(errors[1].values()) < max(errors[0].values())


@pytest.mark.heavy
def test_the_sort_runs_with_the_truth(tmp_path: Path, capsys) -> None:
    """The sort sorts a table with the true calibration of a kit as published: one object
    per class (on the nominal calibration this kit's shoulder stalls at the first pick)."""
    from mearm import sort

    sets = [*SETS, f"servo.calibration_file={_truth(tmp_path)}"]
    capsys.readouterr()
    assert sort.main(["--config", CONFIG, *_argv(*sets), "--random", "3", "--quiet"]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last == "sorted 3 of 3 objects (simulated)"


@pytest.mark.parametrize(
    ("argv", "sets"),
    [
        (["--config", CONFIG, "--truth"], SETS),  # no --simulate
        (["--config", str(ROOT / "configs" / "sim_mujoco.yaml"), "--simulate", "--truth"], []),
        (["--config", CONFIG, "--simulate", "--truth", "--camera"], SETS),
        (["--config", str(ROOT / "configs" / "sim.yaml"), "--simulate", "--truth"], []),
    ],
)
def test_truth_bad_input_exits_2_with_one_line(
    argv: list[str], sets: list[str], tmp_path: Path, capsys
) -> None:
    out = tmp_path / "x.servos.yaml"
    with pytest.raises(SystemExit) as e:
        calibrate_servos.run(calibrate_servos.main, [*argv, *_argv(*sets), "--output", str(out)])
    assert e.value.code == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1 and not out.exists()


# --------------------------------------------------------------------------- the bound


def test_one_joint_uniform_band_gives_half_its_reach() -> None:
    """J = (a, 0, 0), δq ~ U(−d, d): the mean |δs| is a·d/2."""
    a, d = 3.0, 0.4
    got = tcp_error_bound([[[a], [0.0], [0.0]]], [d], samples=200_000)
    assert got.mean_cm == pytest.approx(a * d / 2, rel=0.01)
    assert got.rms_cm == pytest.approx(a * d / np.sqrt(3), rel=0.01)


def test_two_sources_add_as_a_triangle_and_joints_along_one_axis_add() -> None:
    """Two sources U(−d, d) on one joint: triangular, mean |x| = 2d/3; a zero band adds
    nothing; two joints moving the TCP along one axis act as one of their summed reach."""
    d = 0.5
    got = tcp_error_bound([[[1.0], [0.0], [0.0]]], [[d], [d]], samples=200_000)
    assert got.mean_cm == pytest.approx(2 * d / 3, rel=0.01)
    zero = tcp_error_bound([[[1.0, 5.0], [0.0, 0.0], [0.0, 0.0]]], [d, 0.0], samples=200_000)
    assert zero.mean_cm == pytest.approx(d / 2, rel=0.01)
    # poses: a second pose twice as far from its joint doubles its own mean
    two = tcp_error_bound([[[1.0], [0], [0]], [[0], [0], [2.0]]], [d], samples=200_000)
    assert two.per_pose_cm[1] == pytest.approx(2 * two.per_pose_cm[0], rel=0.02)


@pytest.mark.parametrize(
    ("J", "h"),
    [
        (np.ones((2, 3, 3)), [0.1, 0.1]),  # one width short
        (np.ones((3, 3)), [0.1, 0.1, 0.1]),  # no pose axis
        (np.ones((2, 3, 3)), [0.1, -0.1, 0.1]),
        (np.ones((2, 3, 3)), [0.1, np.nan, 0.1]),
    ],
)
def test_bound_bad_input_is_named(J: np.ndarray, h: list[float]) -> None:
    with pytest.raises(ValueError, match="half width"):
        tcp_error_bound(J, h)


def test_pick_jacobians_match_finite_differences() -> None:
    """Per degree of each actuated joint, at a pick's end pose: FK's finite difference."""
    config = load_config(CONFIG)
    model = ArmModel(config.arm)
    joints = {"base": 100.0, "shoulder": 60.0, "elbow": -100.0}
    route = RouteRecord.model_construct(step="pick", end_joints=joints)
    place = RouteRecord.model_construct(step="place", end_joints=joints)
    (J,) = pick_jacobians(config.arm, [route, place])
    for k, name in enumerate(joints):
        up, down = dict(joints), dict(joints)
        up[name] += 1e-4
        down[name] -= 1e-4
        fd = model.fk_cm(model.chain.from_named(up)) - model.fk_cm(model.chain.from_named(down))
        np.testing.assert_allclose(J[:, k], fd / 2e-4, atol=1e-5)


def test_kit_half_widths_are_the_units_dead_bands() -> None:
    """Each joint's band is its unit's dead band in the joint's degrees."""
    config = load_config(CONFIG, SETS)
    widths = kit_half_widths(config)
    for s in TwinArm(config).servos:
        if s.name in widths:
            assert s.unit is not None
            assert widths[s.name][0] == pytest.approx(s.unit.deadband_us / s.physical.us_per_unit)


@pytest.mark.parametrize(
    "argv",
    [
        ["--config", CONFIG, *_argv(*SETS), "missing.jsonl"],  # no such log
        ["--config", CONFIG, *_argv(*SETS), "--samples", "0", "missing.jsonl"],
        ["--config", str(ROOT / "configs" / "sim_mujoco.yaml"), "missing.jsonl"],  # no kit
    ],
)
def test_bound_command_bad_input_exits_2_with_one_line(argv: list[str], capsys) -> None:
    from mearm.analysis import servo_bound

    with pytest.raises(SystemExit) as e:
        calibrate_servos.run(servo_bound.main, argv)
    assert e.value.code == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
