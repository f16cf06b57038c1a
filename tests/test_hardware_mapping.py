"""Angle ↔ pulse mapping, refusals before sending, command records."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mearm.config import Config, config_from_dict
from mearm.exceptions import InvalidCommandError, JointLimitError, PulseRangeError
from mearm.hardware import ArmCommand, ArmState, ServoMap
from mearm.hardware.sim import quantize_deg

SMAP = ServoMap.from_config(Config())
J1, J2, J3 = SMAP.joints
J5 = SMAP.gripper_arm


@pytest.mark.parametrize(
    ("jmap", "lower_us", "upper_us"),
    [(J1, 800, 2200), (J2, 900, 1950), (J3, 800, 2200), (J5, 600, 2400)],
)
def test_pulses_at_the_joint_limits(jmap, lower_us, upper_us):
    """Each joint's limits map to the documented pulses (configs/sim.yaml comments)."""
    assert jmap.command_us(jmap.lower_deg) == lower_us
    assert jmap.command_us(jmap.upper_deg) == upper_us
    jmap.check(jmap.lower_deg)
    jmap.check(jmap.upper_deg)


@pytest.mark.parametrize(("jmap", "name"), [(J1, "joint1"), (J2, "joint2"), (J3, "joint3")])
@pytest.mark.parametrize("side", [-1, 1])
def test_just_past_a_limit_is_refused(jmap, name, side):
    """0.01° past either limit is refused with joint, value and limits in the message."""
    value = (jmap.upper_deg + 0.01) if side > 0 else (jmap.lower_deg - 0.01)
    with pytest.raises(JointLimitError) as err:
        jmap.check(value)
    e = err.value
    assert (e.joint, e.value_deg, e.lower_deg, e.upper_deg) == (
        name, value, jmap.lower_deg, jmap.upper_deg,
    )  # fmt: skip
    assert f"{name} = {value:.4g} deg is outside its limits" in str(e)


def test_gripper_arm_limit_refused():
    with pytest.raises(JointLimitError, match=r"joint5 = 95 deg .* \[-90, 90\]"):
        SMAP.pulses_us(ArmCommand((120.0, 93.0, -132.0), 95.0))


def test_reversed_channel_pulse_range():
    """direction −1: angles of the pulse range come out ascending; an angle inside the
    joint limits but past the pulse range is a PulseRangeError naming both ranges."""
    cfg = config_from_dict(
        {"servo": {"joints": {
            "joint1": {"channel": 0, "zero_us": 2600.0, "direction": -1, "min_us": 1100},
            "joint2": {"channel": 1, "zero_us": 600.0},
            "joint3": {"channel": 2, "zero_us": 2400.0},
            "joint5": {"channel": 3, "zero_us": 1500.0},
        }}}
    )  # fmt: skip
    j1 = ServoMap.from_config(cfg).joints[0]
    assert j1.command_us(20.0) == 2400 and j1.command_us(150.0) == 1100
    assert j1.pulse_limits_deg == (20.0, 150.0)
    j1.check(150.0)
    with pytest.raises(PulseRangeError) as err:
        j1.check(155.0)
    e = err.value
    assert isinstance(e, JointLimitError)
    assert (e.joint, e.value_deg, e.lower_deg, e.upper_deg) == ("joint1", 155.0, 20.0, 150.0)
    assert (e.channel, e.pulse_us, e.min_us, e.max_us) == (0, 1050.0, 1100.0, 2400.0)
    assert "joint1 = 155 deg needs a 1050.0 µs pulse on channel 0" in str(e)
    assert "[1100, 2400] µs" in str(e) and "[20, 150] deg" in str(e)


def test_pulses_of_a_command():
    """All five channels, gripper open or closed, in channel order."""
    home = ArmCommand((120, 93, -132), 60)
    assert SMAP.pulses_us(home) == {0: 1800, 1: 1530, 2: 1080, 3: 2100, 4: 1000}
    closed = ArmCommand((120, 93, -132), 60, gripper_closed=True)
    assert SMAP.pulses_us(closed)[4] == 1900
    assert SMAP.channels == (0, 1, 2, 3, 4)


def test_shared_channel_rejected_by_config():
    from mearm.exceptions import ConfigError

    with pytest.raises(ConfigError, match="share servo channel 3"):
        config_from_dict({"servo": {"gripper": {"channel": 3}}})


@given(st.floats(20, 160), st.floats(30, 135), st.floats(-160, -20), st.floats(-90, 90))
def test_accepted_angles_give_pulses_in_range(t1, t2, t3, t5):
    """Any angle within the limits maps to an integer pulse within its channel's range,
    and the pulse maps back to within half a microsecond's angle."""
    pulses = SMAP.pulses_us(ArmCommand((t1, t2, t3), t5))
    for jmap, angle in zip(SMAP.all_joints, (t1, t2, t3, t5), strict=True):
        us = pulses[jmap.channel]
        assert isinstance(us, int) and jmap.min_us <= us <= jmap.max_us
        assert abs(jmap.angle_deg(us) - angle) <= 0.5 / jmap.us_per_deg + 1e-9


def test_servo_write_degrees_are_whole_dh_degrees():
    """With 600..2400 µs over 0..180° and 10 µs/deg, Servo.write's grid is whole DH degrees."""
    assert J1.servo_step_us == 10.0
    assert J1.servo_degree(120.4) == 120 and J3.servo_degree(-132.0) == 48
    assert quantize_deg(J1, 120.4, "degree") == 120.0
    assert quantize_deg(J3, -132.6, "degree") == -133.0
    assert quantize_deg(J1, 120.04, "microsecond") == pytest.approx(120.0)
    assert quantize_deg(J1, 120.04, "none") == 120.04


def test_servo_write_uses_arduino_integer_map():
    """A 544..2400 µs channel (the Servo library's default) truncates like map()."""
    cfg = config_from_dict({"servo": {"joints": {
        "joint1": {"channel": 0, "zero_us": 544.0, "us_per_deg": 1856 / 180, "min_us": 544},
        "joint2": {"channel": 1, "zero_us": 600.0},
        "joint3": {"channel": 2, "zero_us": 2400.0},
        "joint5": {"channel": 3, "zero_us": 1500.0},
    }}})  # fmt: skip
    j1 = ServoMap.from_config(cfg).joints[0]
    assert j1.servo_degree_us(1) == 544 + 1856 // 180 == 554  # 554.3 truncated
    assert j1.servo_degree_us(180) == 2400


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"joints_deg": (1.0, 2.0), "gripper_arm_deg": 0.0}, "got 2 values"),
        ({"joints_deg": (1.0, math.nan, 2.0), "gripper_arm_deg": 0.0}, "θ2 must be finite"),
        ({"joints_deg": (1.0, 2.0, 3.0), "gripper_arm_deg": math.inf}, "θ5 must be finite"),
        ({"joints_deg": 5, "gripper_arm_deg": 0.0}, "joints_deg must be"),
        ({"joints_deg": (1, 2, "x"), "gripper_arm_deg": 0.0}, "θ3 must be a number"),
        ({"joints_deg": (1, 2, 3), "gripper_arm_deg": 0.0, "gripper_closed": 1}, "True or False"),
    ],
)
def test_bad_commands(kwargs, match):
    with pytest.raises(InvalidCommandError, match=match):
        ArmCommand(**kwargs)


def test_records():
    cmd = ArmCommand([120, 93, -132], 60, True)
    assert cmd.joints_deg == (120.0, 93.0, -132.0) and cmd.angles_deg[-1] == 60.0
    state = ArmState.from_command(cmd)
    assert state.to_command() == cmd
    assert (
        str(state) == "joints (120.00, 93.00, -132.00) deg, gripper arm 60.00 deg, gripper closed"
    )
