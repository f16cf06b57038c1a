"""Value ↔ pulse mapping by actuator name, refusals before sending, command records."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import ROOT, planar_yaw_arm_data
from hardware_helpers import HOME, command
from hypothesis import given
from hypothesis import strategies as st

from mearm.config import Config, config_from_dict, load_config
from mearm.exceptions import ConfigError, InvalidCommandError, JointLimitError, PulseRangeError
from mearm.hardware import ActuatorMap, ArmCommand, ArmState, ServoMap
from mearm.hardware.mapping import PlayCompensation
from mearm.sim import quantize_deg

SMAP = ServoMap.from_arm(Config().arm)
BASE, SHOULDER, ELBOW = SMAP.joints
GRIPPER_ARM = SMAP["gripper_arm"]


def test_paper_arm_channels():
    """The paper arm: base, shoulder, elbow on 0-2, gripper_arm on 3, the gripper on 4."""
    assert SMAP.joint_names == ("base", "shoulder", "elbow")
    assert SMAP.tool_names == ("gripper_arm",)
    assert [a.channel for a in SMAP.actuators] == [0, 1, 2, 3, 4]
    assert SMAP.gripper.name == "gripper" and SMAP.gripper.unit == "cm"
    assert SMAP.channels == (0, 1, 2, 3, 4)


@pytest.mark.parametrize(
    ("amap", "lower_us", "upper_us"),
    [(BASE, 800, 2200), (SHOULDER, 900, 1950), (ELBOW, 800, 2200), (GRIPPER_ARM, 600, 2400)],
)
def test_pulses_at_the_limits(amap, lower_us, upper_us):
    """Each actuator's limits map to the documented pulses (configs/sim.yaml comments)."""
    assert amap.command_us(amap.lower) == lower_us
    assert amap.command_us(amap.upper) == upper_us
    amap.check(amap.lower)
    amap.check(amap.upper)


@pytest.mark.parametrize("amap", [BASE, SHOULDER, ELBOW])
@pytest.mark.parametrize("side", [-1, 1])
def test_just_past_a_limit_is_refused(amap, side):
    """0.01° past either limit is refused with joint, value, limits and unit in the message."""
    value = (amap.upper + 0.01) if side > 0 else (amap.lower - 0.01)
    with pytest.raises(JointLimitError) as err:
        amap.check(value)
    e = err.value
    assert (e.joint, e.value_deg, e.lower_deg, e.upper_deg, e.unit) == (
        amap.name, value, amap.lower, amap.upper, "deg",
    )  # fmt: skip
    assert f"{amap.name} = {value:.4g} deg is outside its limits" in str(e)


def test_tool_actuator_limit_refused():
    with pytest.raises(JointLimitError, match=r"gripper_arm = 95 deg .* \[-90, 90\]"):
        SMAP.pulses_us(command(120.0, 93.0, -132.0, 95.0))


def test_prismatic_limit_names_its_unit():
    """A prismatic joint (a rail) is limited in cm and the error says so."""
    rail = ServoMap.from_arm(config_from_dict({"arm": planar_yaw_arm_data(rail=True)}).arm)["rail"]
    assert rail.unit == "cm" and rail.command_us(2.0) == 1200
    with pytest.raises(JointLimitError, match=r"rail = 11 cm is outside its limits \[0, 10\] cm"):
        rail.check(11.0)


def test_reversed_channel_pulse_range():
    """direction −1: values of the pulse range come out ascending; a value inside the
    limits but past the pulse range is a PulseRangeError naming both ranges."""
    base = ActuatorMap("base", 0, 2600.0, -1, 10.0, 1100, 2400, lower=20.0, upper=160.0, unit="deg")
    assert base.command_us(20.0) == 2400 and base.command_us(150.0) == 1100
    assert base.pulse_limits == (20.0, 150.0)
    base.check(150.0)
    with pytest.raises(PulseRangeError) as err:
        base.check(155.0)
    e = err.value
    assert isinstance(e, JointLimitError)
    assert (e.joint, e.value_deg, e.lower_deg, e.upper_deg) == ("base", 155.0, 20.0, 150.0)
    assert (e.channel, e.pulse_us, e.min_us, e.max_us) == (0, 1050.0, 1100.0, 2400.0)
    assert "base = 155 deg needs a 1050.0 µs pulse on channel 0" in str(e)
    assert "[1100, 2400] µs" in str(e) and "[20, 150] deg" in str(e)


def test_config_refuses_limits_past_the_pulse_range():
    """The same narrow pulse range in a config is refused when it loads, naming the limit."""
    with pytest.raises(ConfigError, match=r"limits.min: 20 needs a 2400 µs pulse"):
        config_from_dict({"arm": {**Config().arm.model_dump(), "joints": [
            {**Config().arm.joints[0].model_dump(), "servo": {
                "channel": 0, "zero_us": 2600.0, "direction": -1, "min_us": 1100,
                "max_us": 2300}},
            *[j.model_dump() for j in Config().arm.joints[1:]],
        ]}})  # fmt: skip


def test_pulses_of_a_command():
    """All five channels, gripper open or closed, in channel order: today's exact pulses."""
    assert SMAP.pulses_us(HOME) == {0: 1800, 1: 1530, 2: 1080, 3: 2100, 4: 1000}
    closed = command(120, 93, -132, 60, closed=True)
    assert SMAP.pulses_us(closed)[4] == 1900
    assert SMAP.gripper.command_us(SMAP.gripper_opening_cm(closed=False)) == 1000
    assert ArmCommand.home(Config().arm) == HOME


def test_shared_channel_rejected_by_config():
    arm = Config().arm.model_dump()
    arm["tool"]["gripper"]["servo"]["channel"] = 3
    with pytest.raises(ConfigError, match="share servo channel 3"):
        config_from_dict({"arm": arm})


@pytest.mark.parametrize(
    ("joints", "tool", "match"),
    [
        ({"base": 120.0, "shoulder": 93.0}, {"gripper_arm": 60.0}, "joints misses elbow"),
        (
            {"base": 120.0, "shoulder": 93.0, "elbow": -132.0, "wrist": 39.0},
            {"gripper_arm": 60.0},
            "joints names unknown wrist",
        ),
        (
            {"base": 120.0, "shoulder": 93.0, "elbow": -132.0},
            {},
            "tool actuators misses gripper_arm",
        ),
        (
            {"base": 120.0, "shoulder": 93.0, "elbow": -132.0},
            {"gripper_arm": 60.0, "wrist_roll": 0.0},
            "tool actuators names unknown wrist_roll",
        ),
    ],
)
def test_missing_or_unknown_names_refused(joints, tool, match):
    """A command must name every actuated joint and tool actuator, and only those; the
    message names the culprits and lists the arm's names."""
    with pytest.raises(InvalidCommandError, match=match) as err:
        SMAP.pulses_us(ArmCommand(joints, tool))
    assert "(this arm's joints: base, shoulder, elbow)" in str(err.value) or (
        "(this arm's tool actuators: gripper_arm)" in str(err.value)
    )


def test_names_checked_before_values():
    """A misnamed command is refused as such even when a value is out of its limits."""
    with pytest.raises(InvalidCommandError, match="misses elbow"):
        SMAP.check(ArmCommand({"base": 500.0, "shoulder": 93.0}, {"gripper_arm": 60.0}))


@given(st.floats(20, 160), st.floats(30, 135), st.floats(-160, -20), st.floats(-90, 90))
def test_accepted_values_give_pulses_in_range(base, shoulder, elbow, gripper_arm):
    """Any value within the limits maps to an integer pulse within its channel's range,
    and the pulse maps back to within half a microsecond's worth of the value."""
    cmd = command(base, shoulder, elbow, gripper_arm)
    pulses = SMAP.pulses_us(cmd)
    values = {**cmd.joints, **cmd.tool}
    for amap in (*SMAP.joints, *SMAP.tool):
        us = pulses[amap.channel]
        assert isinstance(us, int) and amap.min_us <= us <= amap.max_us
        assert abs(amap.value_of(us) - values[amap.name]) <= 0.5 / amap.us_per_unit + 1e-9


def test_five_joint_arm_channels():
    """The 5-joint desk arm (configs/sim_5dof.yaml): five joints and the gripper, each on
    its own channel, every home pulse within its servo's range."""
    cfg = load_config(ROOT / "configs" / "sim_5dof.yaml")
    smap = ServoMap.from_arm(cfg.arm)
    assert smap.joint_names == ("base_yaw", "shoulder", "elbow", "wrist_pitch", "wrist_roll")
    assert smap.tool_names == ()
    assert smap.channels == (0, 1, 2, 3, 4, 5)
    pulses = smap.pulses_us(ArmCommand.home(cfg.arm))
    assert pulses == {0: 1500, 1: 1600, 2: 1300, 3: 700, 4: 1500, 5: 1000}


def test_mearm_v1_home_pulses_in_range():
    """The MeArm v1 (configs/sim_mearm_v1.yaml, 544..2400 µs servos): home and both
    gripper settings give pulses within each servo's range."""
    cfg = load_config(ROOT / "configs" / "sim_mearm_v1.yaml")
    smap = ServoMap.from_arm(cfg.arm)
    home = ArmCommand.home(cfg.arm)
    for closed in (False, True):
        pulses = smap.pulses_us(dataclasses.replace(home, gripper_closed=closed))
        assert sorted(pulses) == list(smap.channels)
        for amap in smap.actuators:
            assert amap.min_us <= pulses[amap.channel] <= amap.max_us, amap.name
    assert all(a.min_us == 544 for a in smap.actuators)


def test_servo_write_degrees_are_whole_dh_degrees():
    """With 600..2400 µs over 0..180° and 10 µs/deg, Servo.write's grid is whole DH degrees."""
    assert BASE.servo_step_us == 10.0
    assert BASE.servo_degree(120.4) == 120 and ELBOW.servo_degree(-132.0) == 48
    assert quantize_deg(BASE, 120.4, "degree") == 120.0
    assert quantize_deg(ELBOW, -132.6, "degree") == -133.0
    assert quantize_deg(BASE, 120.04, "microsecond") == pytest.approx(120.0)
    assert quantize_deg(BASE, 120.04, "none") == 120.04
    with pytest.raises(ValueError, match="none, degree or microsecond"):
        quantize_deg(BASE, 120.0, "bogus")  # type: ignore[arg-type]


def test_servo_write_uses_arduino_integer_map():
    """A 544..2400 µs channel (the Servo library's default) truncates like map()."""
    base = dataclasses.replace(BASE, zero_us=544.0, us_per_unit=1856 / 180, min_us=544)
    assert base.servo_degree_us(1) == 544 + 1856 // 180 == 554  # 554.3 truncated
    assert base.servo_degree_us(180) == 2400


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"joints": [1.0, 2.0, 3.0]}, "joints must be a mapping"),
        ({"joints": {}}, "at least one actuated joint"),
        ({"joints": {"base": math.nan}}, r"joints\['base'\] must be finite"),
        ({"joints": {"base": 1.0}, "tool": {"gripper_arm": math.inf}}, "must be finite"),
        ({"joints": {"base": "x"}}, r"joints\['base'\] must be a number"),
        ({"joints": {"base": True}}, "must be a number, got True"),
        ({"joints": {1: 2.0}}, "names must be non-empty strings"),
        ({"joints": {"base": 1.0}, "tool": 5}, "tool must be a mapping"),
        ({"joints": {"base": 1.0}, "gripper_closed": 1}, "True or False"),
    ],
)
def test_bad_commands(kwargs, match):
    with pytest.raises(InvalidCommandError, match=match):
        ArmCommand(**kwargs)


def test_records():
    """Commands are read-only, equal and hashed by value (name order aside), readable."""
    cmd = command(120, 93, -132, 60, True)
    assert dict(cmd.joints) == {"base": 120.0, "shoulder": 93.0, "elbow": -132.0}
    assert cmd.tool["gripper_arm"] == 60.0 and isinstance(cmd.joints["base"], float)
    with pytest.raises(TypeError):
        cmd.joints["base"] = 1.0  # type: ignore[index]
    with pytest.raises(dataclasses.FrozenInstanceError):
        cmd.gripper_closed = False  # type: ignore[misc]
    shuffled = ArmCommand({"elbow": -132, "base": 120, "shoulder": 93}, {"gripper_arm": 60}, True)
    assert shuffled == cmd and hash(shuffled) == hash(cmd) and len({cmd, shuffled}) == 1
    assert cmd != command(120, 93, -132, 60, False)
    state = ArmState.from_command(cmd)
    assert state.to_command() == cmd and state != cmd
    assert (state.joints, state.tool, state.gripper_closed) == (cmd.joints, cmd.tool, True)
    assert (
        str(state) == "base=120.00 shoulder=93.00 elbow=-132.00; gripper_arm=60.00; gripper closed"
    )
    source = {"base": 1.0}
    held = ArmCommand(source)
    source["base"] = 2.0
    assert held.joints["base"] == 1.0  # a copy, not a view of the caller's dict


# --------------------------------------------------------------------------- servos over joints

#: Every config shipped in configs/ (the reference arms, their twins and rigs).
ALL_CONFIGS = sorted(p.name for p in (ROOT / "configs").glob("*.yaml"))
MEARM = load_config(ROOT / "configs" / "sim_mearm_v1.yaml")
MEARM_SMAP = ServoMap.from_arm(MEARM.arm)


def _random_commands(config: Config, n: int, seed: int) -> list[ArmCommand]:
    """Commands with every actuated joint uniform within its limits whose servo values
    map into their pulse ranges (a servo over a combination leaves some poses out)."""
    rng = np.random.default_rng(seed)
    smap = ServoMap.from_arm(config.arm)
    tool = {a.name: a.home for a in config.arm.tool.actuators}
    out: list[ArmCommand] = []
    while len(out) < n:
        joints = {j.name: float(rng.uniform(j.lower, j.upper)) for j in smap.joints}
        cmd = ArmCommand(joints, tool, bool(rng.integers(2)))
        try:
            smap.check(cmd)
        except PulseRangeError:
            continue
        out.append(cmd)
    return out


@pytest.mark.parametrize("name", ALL_CONFIGS)
def test_joints_to_pulses_to_joints_round_trips(name):
    """Every shipped config, 200 random poses: the exact map inverts to 1e-9, and the
    integer pulses the bus sends map back to the joints within their half-microsecond
    steps carried through the inverse of the servos' combinations."""
    config = load_config(ROOT / "configs" / name)
    smap = ServoMap.from_arm(config.arm)
    A, _ = config.arm.servo_matrix()
    inv = np.abs(np.linalg.inv(A))
    half_step = np.array([0.5 / j.us_per_unit for j in smap.joints])  # of each servo's value
    bound = inv @ half_step + 1e-9  # per joint
    for cmd in _random_commands(config, 200, seed=7):
        exact = smap.joints_of(smap.servo_values(cmd.joints))
        assert exact == pytest.approx(dict(cmd.joints), abs=1e-9)
        pulses = smap.pulses_us(cmd)
        back = smap.joints_from_pulses(pulses)
        error = np.array([back[n] - cmd.joints[n] for n in smap.joint_names])
        assert np.all(np.abs(error) <= bound), (name, dict(cmd.joints), back)
        realised = smap.realised(cmd.joints, "microsecond")
        assert realised == pytest.approx(back, abs=1e-9)  # what the bus sends, solved back


@pytest.mark.parametrize("name", [n for n in ALL_CONFIGS if not n.startswith("sim_mearm_v1")])
def test_a_servo_without_drives_turns_its_joint_alone(name):
    """Every other shipped config: the identity combination, and each joint's pulse is its
    own servo's p0 + s·k·q rounded, as before servos could turn combinations."""
    config = load_config(ROOT / "configs" / name)
    A, a = config.arm.servo_matrix()
    assert np.array_equal(A, np.eye(len(A))) and not a.any()
    smap = ServoMap.from_arm(config.arm)
    assert not any(j.combined or j.terms for j in smap.joints)
    for cmd in _random_commands(config, 50, seed=3):
        pulses = smap.pulses_us(cmd)
        for j in config.arm.actuated_joints():
            s = j.servo
            assert pulses[s.channel] == math.floor(s.zero_us + s.direction * s.us_per_unit
                                                   * cmd.joints[j.name] + 0.5)  # fmt: skip


def command_of(config: Config, joints: dict[str, float]) -> ArmCommand:
    """A command of these joints, the tool at home, the gripper open."""
    return ArmCommand(joints, {a.name: a.home for a in config.arm.tool.actuators})


@pytest.mark.parametrize(
    ("shoulder", "forearm", "servo_deg"),
    [
        (shoulder, forearm, servo_deg)
        for shoulder in (45.0, 90.0, 135.0)
        for forearm, servo_deg in ((45.0, 144), (0.0, 90), (-45.0, 36))
        if -150.0 <= forearm - shoulder <= -20.0  # the elbow joint within its limits
    ],
)
def test_the_mearm_elbow_servo_turns_the_forearm(shoulder, forearm, servo_deg):
    """The MeArm v1's elbow servo is calibrated on the forearm's angle to the table,
    shoulder + elbow: the York Hackspace library's elbow figures (servo degree 144 at
    +45°, 36 at -45°) hold whatever the shoulder, and the shoulder's own pulse does not
    depend on the elbow."""
    elbow = MEARM_SMAP["elbow"]
    assert elbow.combined and elbow.combination_text == "shoulder + elbow"
    joints = {"base": 90.0, "shoulder": shoulder, "elbow": forearm - shoulder}
    pulses = MEARM_SMAP.pulses_us(command_of(MEARM, joints))
    library_us = 544 + servo_deg * (2400 - 544) / 180  # Arduino's Servo.write
    assert abs(pulses[elbow.channel] - library_us) <= 0.5
    assert pulses[MEARM_SMAP["shoulder"].channel] == MEARM_SMAP["shoulder"].command_us(shoulder)


def test_a_servo_over_joints_is_checked_on_its_value_and_the_joints_on_theirs():
    """Joints inside their limits whose sum takes the elbow servo past its pulse range are
    refused naming the servo and its combination; a joint past its own limit is refused
    naming the joint, as before."""
    inside = {"base": 90.0, "shoulder": 100.0, "elbow": -20.0}  # forearm at +80°: past +75°
    with pytest.raises(PulseRangeError) as err:
        MEARM_SMAP.check(command_of(MEARM, inside))
    e = err.value
    assert e.joint == "elbow's servo (shoulder + elbow)" and e.value_deg == pytest.approx(80.0)
    assert (e.lower_deg, e.upper_deg) == pytest.approx((-75.0, 75.0), abs=0.01)
    assert "elbow's servo (shoulder + elbow) = 80 deg needs a 2461.9 µs pulse on channel 2" in str(
        e
    )
    MEARM_SMAP.check(command_of(MEARM, {**inside, "shoulder": 95.0}))  # forearm +75°: the edge
    with pytest.raises(JointLimitError) as err:
        MEARM_SMAP.check(command_of(MEARM, {**inside, "elbow": -15.0}))
    assert not isinstance(err.value, PulseRangeError)
    assert (err.value.joint, err.value.lower_deg, err.value.upper_deg) == ("elbow", -150, -20)


def test_exact_realisation_quantises_the_servos_not_the_joints():
    """With a servo over shoulder + elbow, the realised elbow carries both servos' steps:
    solving back from the quantised servo values, not quantising the joint."""
    joints = {"base": 90.3, "shoulder": 60.04, "elbow": -100.03}
    servo = MEARM_SMAP.servo_values(joints)
    assert servo["elbow"] == pytest.approx(-39.99)
    realised = MEARM_SMAP.realised(joints, "microsecond")
    forearm = MEARM_SMAP["elbow"].realised(servo["elbow"], "microsecond")
    shoulder = MEARM_SMAP["shoulder"].realised(60.04, "microsecond")
    assert realised["shoulder"] == pytest.approx(shoulder, abs=1e-12)
    assert realised["elbow"] == pytest.approx(forearm - shoulder, abs=1e-12)
    assert MEARM_SMAP.realised(joints, "none") == pytest.approx(joints, abs=1e-12)


# ----------------------------------------------------------------- play compensation


def _with_play(play_us: float) -> ServoMap:
    return ServoMap(
        tuple(dataclasses.replace(j, play_us=play_us) for j in SMAP.joints),
        SMAP.tool,
        SMAP.gripper,
        SMAP.gripper_open_cm,
        SMAP.gripper_closed_cm,
    )


def test_play_is_sent_half_further_the_way_the_pulse_moved():
    """Up: +play/2; down: −play/2; unchanged: the last move's side; first: none."""
    play = PlayCompensation(_with_play(12.0))
    base = BASE.channel
    first = SMAP.pulses_us(HOME)
    bounds = SMAP.limit_pulses_us(HOME)  # home is far inside every limit
    assert play.apply(first, bounds) == first  # no side known yet
    up = {**first, base: first[base] + 20}
    assert play.apply(up, bounds)[base] == first[base] + 26
    assert play.apply(up, bounds)[base] == first[base] + 26  # held: still from below
    down = {**first, base: first[base] + 10}
    assert play.apply(down, bounds)[base] == first[base] + 4
    sent = play.apply(down, bounds)
    assert sent[SMAP.gripper.channel] == first[SMAP.gripper.channel]  # no play: as given
    play.reset()
    assert play.apply(down, bounds) == down


def test_play_never_leaves_the_pulse_range():
    """A pulse at max_us moved up is sent at max_us, not beyond (bounds wider than it)."""
    play = PlayCompensation(_with_play(40.0))
    base = BASE.channel
    pulses = SMAP.pulses_us(HOME)
    wide = {ch: (0.0, 5000.0) for ch in pulses}
    play.apply({**pulses, base: BASE.max_us - 5}, wide)
    assert play.apply({**pulses, base: BASE.max_us}, wide)[base] == BASE.max_us


def test_a_map_without_play_compensates_nothing():
    """``without_play`` (what calibration moves by) leaves every pulse as calibrated."""
    smap = _with_play(12.0).without_play()
    assert not PlayCompensation(smap).active
    assert all(a.play_us == 0.0 for a in smap.actuators)


def test_play_in_the_calibration_reaches_the_map():
    """``servo.play_us`` reaches the actuator map; more than 100 µs is refused."""
    config = load_config(ROOT / "configs" / "sim.yaml", ["arm.joints.base.servo.play_us=9.5"])
    assert ServoMap.from_arm(config.arm)["base"].play_us == 9.5
    with pytest.raises(ConfigError, match="play_us"):
        load_config(ROOT / "configs" / "sim.yaml", ["arm.joints.base.servo.play_us=101"])
