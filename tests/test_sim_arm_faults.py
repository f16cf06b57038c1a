"""The kinematic simulator's arm keeps its last pose on a fault and realises pulses exactly.

A move :meth:`~mearm.sim.SimArm.actuate` refuses (a value that is no joint's, a name the
arm does not actuate, a collision) leaves the joints, the tool and the gripper where they
were: a fault keeps the last confirmed pose. A command is realised where the integer-µs
pulses of the servo map put the joints, the MeArm v1's elbow included (its servo turns
shoulder + elbow).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from mearm.config import Config, config_from_dict, load_config
from mearm.errors import MearmError
from mearm.exceptions import InvalidJointsError, SimCollisionError
from mearm.hardware import ArmCommand, ServoMap
from mearm.kinematics import ArmModel
from mearm.sim import SimArm, World
from mearm.sim.kinematic.servo_bus import (
    ee_from_joints_cm,
    quantization_ee_error_cm,
    random_reachable_joints,
)

ROOT = Path(__file__).resolve().parent.parent


def _mearm_v1(*overrides: str) -> Config:
    return load_config(ROOT / "configs" / "sim_mearm_v1.yaml", overrides)


def _arm(config: Config) -> SimArm:
    bus = SimArm(config, World.from_config(config))
    bus.connect()
    return bus


# --------------------------------------------------------------------------- faults

#: Refused moves of the paper arm from home, each with the error it raises: the tool is
#: sent 10° on and the gripper closed with each, so a refusal must keep both.
_REFUSED: list[tuple[dict[str, float], type[MearmError], str]] = [
    ({"base": math.nan}, InvalidJointsError, "finite"),
    ({"shoulder": -math.inf}, InvalidJointsError, "finite"),
    ({"nope": 1.0}, InvalidJointsError, "unknown joint"),
    ({"wrist": 10.0}, InvalidJointsError, "breaks its coupling"),
    # the jaws, hanging below the TCP, into the red bin's wall on the way down
    ({"shoulder": 30.0, "elbow": -145.0}, SimCollisionError, "jaw_right_pad touches bin_red_wall"),
]


@pytest.mark.parametrize(("joints", "error", "message"), _REFUSED)
def test_a_refused_move_leaves_the_arm_where_it_was(
    joints: dict[str, float], error: type[MearmError], message: str
) -> None:
    """Joints, tool, gripper and the table are as before the move, and the TCP is home's."""
    config = config_from_dict({})
    bus = _arm(config)
    home_tcp = bus.ee_cm
    objects = [(o.id, o.x_cm, o.y_cm) for o in bus.world.table_objects()]
    tool = {n: v + 10.0 for n, v in bus.actual_tool.items()}
    with pytest.raises(error, match=message):
        bus.actuate(joints, tool, gripper_closed=True, last_state=None)
    assert bus.actual_joints == config.arm.home()
    assert bus.actual_tool == {a.name: a.home for a in config.arm.tool.actuators}
    assert not bus.gripper_closed and bus.last_grip is None
    assert [(o.id, o.x_cm, o.y_cm) for o in bus.world.table_objects()] == objects
    np.testing.assert_array_equal(bus.ee_cm, home_tcp)


@pytest.mark.parametrize(("joints", "error", "message"), _REFUSED)
def test_the_move_after_a_refused_one_arrives(
    joints: dict[str, float], error: type[MearmError], message: str
) -> None:
    """A refusal does not wedge the arm: the next good move goes where it is sent."""
    config = config_from_dict({})
    bus = _arm(config)
    with pytest.raises(error, match=message):
        bus.actuate(joints, {}, gripper_closed=False, last_state=None)
    good = {"base": 100.0, "shoulder": 80.0, "elbow": -110.0}
    bus.actuate(good, {}, gripper_closed=False, last_state=None)
    assert bus.actual_joints == good


# --------------------------------------------------------------------------- realise


def _commands(config: Config, n: int, seed: int) -> list[ArmCommand]:
    """``n`` commands the bus sends: reachable poses with every servo in its pulse range."""
    smap = ServoMap.from_arm(config.arm)
    model = ArmModel(config.arm)
    tool = {a.name: a.home for a in config.arm.tool.actuators}
    poses = random_reachable_joints(config, 2 * n, seed, model)
    poses = poses[[smap.outside_pulse_range(q) is None for q in poses]][:n]
    assert len(poses) == n
    names = model.chain.actuated
    return [ArmCommand(dict(zip(names, q.tolist(), strict=True)), tool, False) for q in poses]


def _microsecond_pulses(smap: ServoMap, command: ArmCommand) -> dict[int, float]:
    return {c: float(p) for c, p in smap.pulses_us(command).items()}


def _servo_write_pulses(smap: ServoMap, command: ArmCommand) -> dict[int, float]:
    """The pulses a ``Servo.write`` host sends: whole servo degrees, Arduino's ``map()``."""
    servo = smap.servo_values(command.joints)
    return {j.channel: float(j.servo_degree_us(j.servo_degree(servo[j.name]))) for j in smap.joints}


@pytest.mark.parametrize(
    ("mode", "pulses"), [("microsecond", _microsecond_pulses), ("degree", _servo_write_pulses)]
)
def test_the_mearm_is_realised_where_its_pulses_put_it(
    mode: str, pulses: Callable[[ServoMap, ArmCommand], dict[int, float]]
) -> None:
    """MeArm v1, 200 commands: the realised joints are the ones the sent pulses give
    back through the servo map, bit for bit, the elbow (on shoulder + elbow) included."""
    config = _mearm_v1(f"servo.error_model.quantization={mode}")
    smap = ServoMap.from_arm(config.arm)
    bus = SimArm(config, World())
    for command in _commands(config, 200, seed=3):
        assert bus.realise(command) == smap.joints_from_pulses(pulses(smap, command))


def test_the_moved_mearm_is_where_its_pulses_put_it() -> None:
    """MeArm v1: after each move the arm and its TCP are where the integer-µs pulses put
    them."""
    config = _mearm_v1()
    smap = ServoMap.from_arm(config.arm)
    bus = SimArm(config, World())  # no bins to run into between random poses
    bus.connect()
    for command in _commands(config, 20, seed=4):
        bus.move(command)
        expected = smap.joints_from_pulses(smap.pulses_us(command))
        assert bus.actual_joints == expected
        np.testing.assert_array_equal(bus.ee_cm, ee_from_joints_cm(bus.model, expected))


def test_the_mearm_without_quantisation_is_realised_as_commanded() -> None:
    """``none``: the joints are the commanded ones bit for bit (no rounding from solving
    the elbow servo's combination back)."""
    config = _mearm_v1("servo.error_model.quantization=none")
    bus = SimArm(config, World())
    for command in _commands(config, 200, seed=5):
        assert bus.realise(command) == command.joints


@pytest.mark.parametrize("mode", ["microsecond", "degree"])
def test_the_paper_arm_is_realised_joint_by_joint(mode: str) -> None:
    """Each of the paper arm's servos turns one joint: each joint is its own servo's value
    on the pulse grid, as before the servo map realised whole commands."""
    config = config_from_dict({"servo": {"error_model": {"quantization": mode}}})
    smap = ServoMap.from_arm(config.arm)
    bus = SimArm(config, World())
    for command in _commands(config, 100, seed=6):
        each = {j.name: j.realised(command.joints[j.name], mode) for j in smap.joints}
        assert bus.realise(command) == each


def test_the_mearm_quantisation_error_is_the_pulses() -> None:
    """``mearm quantization`` on the MeArm v1: each pose's TCP error is the one its
    integer-µs pulses give (unclamped: a random pose may leave the elbow servo's range)."""
    config = _mearm_v1()
    smap = ServoMap.from_arm(config.arm)
    model = ArmModel(config.arm)
    errors = quantization_ee_error_cm(config, "microsecond", n=50, seed=7)
    for error, q in zip(errors, random_reachable_joints(config, 50, 7, model), strict=True):
        exact = dict(zip(model.chain.actuated, q.tolist(), strict=True))
        servo = smap.servo_values(exact)
        pulses = {j.channel: math.floor(j.pulse_us(servo[j.name]) + 0.5) for j in smap.joints}
        realised = smap.joints_from_pulses(pulses)
        expected = ee_from_joints_cm(model, realised) - ee_from_joints_cm(model, exact)
        assert error == pytest.approx(float(np.linalg.norm(expected)), abs=1e-12)
