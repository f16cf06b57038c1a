"""A kit of servos: each twin servo a unit drawn from the spread of real ones (real MuJoCo)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.errors import ConfigError
from mearm.exceptions import ModelError
from mearm.experiment import plan_trial
from mearm.hardware.bus import ArmCommand
from mearm.sim.twin.mjcf import twin_model
from mearm.sim.twin.servo_kit import (
    KIT_RANGES,
    NEUTRAL_US,
    ServoUnit,
    draw_kit,
    kit_seed,
)
from mearm.sim.twin.twin_bus import BACKLASH_DEG, TwinArm

KITS = ROOT / "configs" / "sim_mujoco_kits.yaml"
PLAIN = ROOT / "configs" / "sim_mujoco.yaml"


@pytest.fixture(scope="module")
def plain():
    config = load_config(PLAIN)
    return config, twin_model(config)


def _kit(config, **fields):
    kit = config.twin.kit.model_copy(update=fields)
    return config.model_copy(update={"twin": config.twin.model_copy(update={"kit": kit})})


def test_the_same_seed_draws_the_same_kit_and_another_seed_another():
    bands = [3.0, 3.0, 3.0, 10.0]
    assert draw_kit(bands, 7) == draw_kit(bands, 7)
    assert draw_kit(bands, 7) != draw_kit(bands, 8)
    assert kit_seed(7, None) == 7
    assert kit_seed(7, 1) == kit_seed(7, 1) != kit_seed(7, 2)


def test_the_kit_honours_its_ranges_and_spread():
    bands = [3.0, 10.0, 12.0] * 200
    kit = draw_kit(bands, 1)
    r = KIT_RANGES
    for band, unit in zip(bands, kit, strict=True):
        assert r["zero_offset_deg"].low <= unit.zero_offset_deg <= r["zero_offset_deg"].high
        assert r["us_per_deg"].low <= unit.us_per_deg <= r["us_per_deg"].high
        assert r["backlash_deg"].low <= unit.backlash_deg <= r["backlash_deg"].high
        assert band <= unit.deadband_us <= max(band, r["deadband_us"].high)
    offsets = [u.zero_offset_deg for u in kit]
    assert min(offsets) < -1.5 and max(offsets) > 1.5  # the range is used, not a corner of it
    half = draw_kit(bands, 1, spread=0.5)
    for unit, u in zip(kit, half, strict=True):
        assert math.isclose(u.zero_offset_deg, unit.zero_offset_deg / 2)
        assert math.isclose(u.us_per_deg - 10.0, (unit.us_per_deg - 10.0) / 2, abs_tol=1e-12)
        assert (u.backlash_deg, u.deadband_us) == (unit.backlash_deg, unit.deadband_us)
    for u in draw_kit(bands, 1, spread=0.0):
        assert (u.zero_offset_deg, u.us_per_deg) == (0.0, 10.0)
    for source in (r.source for r in KIT_RANGES.values()):
        assert source


@pytest.mark.parametrize("spread", [-0.1, 5.5, math.nan])
def test_a_bad_spread_is_refused_by_the_draw(spread):
    with pytest.raises(ValueError, match="spread"):
        draw_kit([3.0], 1, spread)


@pytest.mark.parametrize(
    ("override", "field"),
    [
        ("twin.kit.spread=-1", "twin.kit.spread"),
        ("twin.kit.spread=6", "twin.kit.spread"),
        ("twin.kit.seed=-3", "twin.kit.seed"),
        ("twin.kit.per_trial=maybe", "twin.kit.per_trial"),
        ("twin.kit.size=4", "twin.kit.size"),
    ],
)
def test_bad_kit_values_name_their_field(override, field):
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        load_config(KITS, [override])


def test_a_config_without_a_kit_gives_nominal_servos(plain):
    config, m = plain
    assert config.twin.kit is None
    arm = TwinArm(config, m)
    assert arm.kit is None
    assert all(s.unit is None for s in arm.servos)
    assert all(math.isclose(s.backlash, math.radians(BACKLASH_DEG) * s.lever) for s in arm.servos)


def test_a_kit_config_draws_one_unit_per_servo(plain):
    _, m = plain
    config = load_config(KITS)
    arm = TwinArm(config, m)
    assert arm.kit is not None and len(arm.kit) == len(arm.servos)
    for s, unit in zip(arm.servos, arm.kit, strict=True):
        assert s.unit == unit
        assert math.isclose(s.backlash, math.radians(unit.backlash_deg) * s.lever)
        assert math.isclose(s.deadband, unit.deadband_us / s.amap.us_per_unit * s.scale)
    again = TwinArm(config, m)
    assert again.kit == arm.kit


def test_per_trial_kits_differ_between_trials_and_one_kit_does_not(plain):
    """Through the experiment's own trial plans: each trial's config gives its twin's kit."""
    _, m = plain
    config = load_config(KITS)
    assert config.twin.kit.per_trial
    kits = [TwinArm(plan_trial(config, 0, k).config, m).kit for k in range(3)]
    assert len(set(kits)) == 3
    assert kits[0] == TwinArm(plan_trial(config, 0, 0).config, m).kit  # a rerun keeps it
    one = _kit(config, per_trial=False)
    kept = [TwinArm(plan_trial(one, 0, k).config, m).kit for k in range(3)]
    assert kept[0] == kept[1] == kept[2] == TwinArm(one, m).kit


def test_a_kit_of_the_wrong_size_is_refused(plain):
    config, m = plain
    with pytest.raises(ModelError, match="one unit per servo"):
        TwinArm(config, m, kit=(ServoUnit(0.0, 10.0, 0.5, 3.0),))


def test_a_unit_turns_by_its_own_zero_and_scale(plain):
    """A pulse moves the physical servo where the unit's mapping, not the nominal, says."""
    config, m = plain
    units = [ServoUnit(0.0, 10.0, 0.5, 3.0) for _ in range(4)]
    units[0] = ServoUnit(2.0, 10.0, 0.5, 3.0)  # base: 2° offset at the neutral pulse
    units[1] = ServoUnit(0.0, 11.0, 0.5, 3.0)  # shoulder: 11 µs per degree
    arm = TwinArm(config, m, kit=tuple(units))
    arm.connect()
    joints = config.arm.home()
    tools = {a.name: a.home for a in config.arm.tool.actuators}
    arm.move(ArmCommand(joints, tools, False))
    arm.settle(1.0)
    base, shoulder = arm.servos[0], arm.servos[1]
    p_base = base.amap.pulse_us(joints["base"])
    p_shoulder = shoulder.amap.pulse_us(joints["shoulder"])
    want_base = base.amap.value_of(NEUTRAL_US + (p_base - NEUTRAL_US) + 20.0)
    want_shoulder = shoulder.amap.value_of(NEUTRAL_US + (p_shoulder - NEUTRAL_US) * 10 / 11)
    for name, want, s in (("base", want_base, base), ("shoulder", want_shoulder, shoulder)):
        budget = (s.deadband + s.backlash) / s.scale + 0.5 / s.amap.us_per_unit + 0.3
        assert abs(arm.actual_joints[name] - want) <= budget, (name, arm.actual_joints, want)
    # and the nominal servo would not be there: the offsets are larger than the budget
    assert abs(arm.actual_joints["base"] - joints["base"]) > 1.5
    if abs(p_shoulder - NEUTRAL_US) > 200:
        assert abs(arm.actual_joints["shoulder"] - joints["shoulder"]) > 1.0


@pytest.mark.parametrize("seed", [1, 2])
def test_the_ramp_with_a_kit_is_the_step_by_step_servo_model(plain, seed):
    """Per-unit backlash keeps the ramp equal to the per-step recurrence bit for bit."""
    _, m = plain
    arm = TwinArm(_kit(load_config(KITS), seed=seed), m)
    assert len(set(arm._half_play.tolist())) == len(arm.servos)  # each unit its own play
    rng = np.random.default_rng(seed)
    nu = len(arm.servos)
    step = arm._speed * arm.model.opt.timestep
    for _ in range(20):
        arm._motor = rng.uniform(-1.0, 1.0, nu)
        arm._target = np.where(rng.random(nu) < 0.2, arm._motor, rng.uniform(-1.0, 1.0, nu))
        arm._setpoint = arm._motor + rng.uniform(-0.5, 0.5, nu) * 2 * arm._half_play
        motor, setpoint, rows = arm._motor.copy(), arm._setpoint.copy(), []
        for _ in range(400):
            gap = arm._target - motor
            motor = np.where(np.abs(gap) <= step, arm._target, motor + np.sign(gap) * step)
            setpoint = np.clip(setpoint, motor - arm._half_play, motor + arm._half_play)
            rows.append(setpoint)
        ramp = arm._ramp(400)
        np.testing.assert_array_equal(ramp, np.array(rows)[: len(ramp)])
