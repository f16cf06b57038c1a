"""The kinematic simulator's arm stops at its joints' limits, as the twin's joints do.

The error model's offset and noise realise a command at or near a limit past it; the
joint stops there instead (:func:`~mearm.sim.kinematic.joint_stops.joints_at_stops`),
whoever drives the arm. A value within the limits is realised as before, bit for bit.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mearm.config import Config, config_from_dict, load_config
from mearm.exceptions import InvalidJointsError
from mearm.hardware import ArmCommand, ServoMap
from mearm.sim import SimArm, World
from mearm.sim.kinematic.joint_stops import joints_at_stops
from mearm.sim.kinematic.servo_bus import ee_from_joints_cm

ROOT = Path(__file__).resolve().parent.parent


def _paper_arm(**error_model: Any) -> Config:
    return config_from_dict({"servo": {"error_model": error_model}})


def _mearm_v1(*overrides: str) -> Config:
    return load_config(ROOT / "configs" / "sim_mearm_v1.yaml", overrides)


def _command(config: Config, **joints: float) -> ArmCommand:
    """Home, with the named joints moved."""
    arm = config.arm
    return ArmCommand({**arm.home(), **joints}, {a.name: a.home for a in arm.tool.actuators}, False)


def _moved(config: Config, command: ArmCommand) -> SimArm:
    bus = SimArm(config, World())
    bus.connect()
    bus.move(command)
    return bus


def test_an_offset_past_the_limit_leaves_the_joint_at_the_limit() -> None:
    """Shoulder commanded at its 135° limit with a +5° offset: it stops at 135°, not 140°,
    and the TCP is the limit's."""
    config = _paper_arm(offset_deg={"shoulder": 5.0})
    bus = _moved(config, _command(config, shoulder=135.0))
    assert bus.realise(_command(config, shoulder=135.0))["shoulder"] == 140.0  # sent past
    assert bus.actual_joints["shoulder"] == 135.0
    expected = {**config.arm.home(), "shoulder": 135.0}
    assert bus.actual_joints == pytest.approx(expected, abs=1e-9)
    np.testing.assert_allclose(bus.ee_cm, ee_from_joints_cm(bus.model, expected), atol=1e-9)


def test_noise_at_a_limit_never_takes_a_joint_past_it() -> None:
    """Every joint at a limit, 3° of noise, 40 moves: none past its limits, and some at them."""
    config = _paper_arm(noise_std_deg=3.0, seed=1)
    stops = config.arm.joint_limits()
    at_limits = {"base": stops["base"].min, "shoulder": 135.0, "elbow": stops["elbow"].max}
    bus = SimArm(config, World())
    bus.connect()
    reached: set[str] = set()
    for k in range(40):
        # alternate with home so each move draws its own noise
        bus.move(_command(config, **(at_limits if k % 2 == 0 else {})))
        for name, value in bus.actual_joints.items():
            assert stops[name].contains(value), (name, value)
            if k % 2 == 0 and value == at_limits[name]:
                reached.add(name)
    assert reached == set(at_limits)


def test_the_mearm_shoulder_stops_and_its_elbow_servo_keeps_the_forearm() -> None:
    """MeArm v1, shoulder at its 150° limit with a +5° offset: the shoulder stops at 150°
    and the elbow servo (shoulder + elbow) still puts the forearm where it sent it."""
    config = _mearm_v1("servo.error_model.offset_deg={shoulder: 5}")
    command = _command(config, shoulder=150.0)
    bus = _moved(config, command)
    sent = SimArm(config, World()).realise(command)
    assert sent["shoulder"] > 150.0
    assert bus.actual_joints["shoulder"] == 150.0
    assert bus.actual_joints["shoulder"] + bus.actual_joints["elbow"] == pytest.approx(
        sent["shoulder"] + sent["elbow"], abs=1e-8
    )
    smap = ServoMap.from_arm(config.arm)
    assert bus.actual_joints == joints_at_stops(
        smap, smap.servo_values(sent), config.arm.joint_limits()
    )


@pytest.mark.parametrize(
    ("config", "inside"),
    [
        (
            _paper_arm(offset_deg={"shoulder": 0.7}, noise_std_deg=0.5),
            {"base": 157.0, "shoulder": 132.0, "elbow": -23.0},
        ),
        # the elbow servo turns shoulder + elbow, within ±75° of its pulse range
        (_mearm_v1("servo.error_model.noise_std_deg=0.5"), {"base": 132.0, "shoulder": 147.0}),
        (_mearm_v1("servo.error_model.noise_std_deg=0.5"), {"shoulder": 80.0, "elbow": -23.0}),
    ],
)
def test_a_value_inside_the_limits_is_realised_bit_for_bit(
    config: Config, inside: dict[str, float]
) -> None:
    """Commands 3° inside their limits: the arm is exactly where the error model sends
    them (the same seed's realisation), not re-solved."""
    stops = config.arm.joint_limits()
    command = _command(config, **inside)
    sent = SimArm(config, World()).realise(command)
    assert all(stops[n].contains(v) for n, v in sent.items())
    assert _moved(config, command).actual_joints == sent


def test_actuate_takes_values_already_stopped_as_they_are() -> None:
    """The virtual Uno's stopped joints (one at its limit, the shoulder pulled off its
    value by the elbow servo) put the arm exactly there."""
    config = _mearm_v1()
    smap, stops = ServoMap.from_arm(config.arm), config.arm.joint_limits()
    stopped = joints_at_stops(smap, {"base": 90.0, "shoulder": 90.0, "elbow": -75.0}, stops)
    assert stopped["elbow"] == -150.0
    bus = SimArm(config, World())
    bus.actuate(stopped, {}, gripper_closed=False, last_state=None)
    assert bus.actual_joints == stopped


def test_actuate_stops_a_joint_sent_past_its_limit() -> None:
    """Whoever drives the arm: base sent to 5° (limit 20°) stops at 20°; the others stay."""
    config = _paper_arm()
    bus = SimArm(config, World())
    bus.actuate({"base": 5.0}, {}, gripper_closed=False, last_state=None)
    assert bus.actual_joints == {**config.arm.home(), "base": 20.0}


@pytest.mark.parametrize("joints", [{"base": math.nan}, {"shoulder": -math.inf}, {"nope": 1.0}])
def test_a_value_that_is_no_joints_is_refused_not_stopped(joints: dict[str, float]) -> None:
    """MeArm v1: a non-finite value or a name not the arm's is refused by name, not solved
    to some pose at the stops."""
    bus = SimArm(_mearm_v1(), World())
    with pytest.raises(InvalidJointsError, match="finite|unknown joint"):
        bus.actuate(joints, {}, gripper_closed=False, last_state=None)
