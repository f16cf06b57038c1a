"""While the jaws hold an object, no servo accelerates faster than ``task.carry_accel_deg_s2``.

A kit's claw standing a few millimetres high leaves the jaws the top 0.1–0.3 cm of an
object's side; in the twin such grips held at the lift and let go at the base's full jolt
on the way to the bin (docs/twin.md, "Picks that look").
"""

from __future__ import annotations

import numpy as np
import pytest

from mearm.config import Config
from mearm.config.servo_calibration import US_PER_SERVO_DEG
from mearm.kinematics import ArmModel
from mearm.sim import SimArm, World
from mearm.task.execute import Executor, carry_limits
from mearm.task.plan import Planner
from mearm.task.route import Route

#: The cap the tests set [deg/s²]: well under the default arm's servos' own reach.
CAP_DEG_S2 = 800.0


def _config(cap_deg_s2: float | None) -> Config:
    config = Config()
    task = config.task.model_copy(update={"carry_accel_deg_s2": cap_deg_s2})
    return config.model_copy(update={"task": task})


def _servo_accel_deg_s2(config: Config, q: np.ndarray, period_s: float) -> np.ndarray:
    """Each servo's shaft acceleration over the streamed poses, at rest before and after
    them [deg/s²], (k, m)."""
    q = np.vstack([q[:1], q, q[-1:]])
    model = ArmModel(config.arm)
    chain = model.chain
    servos = {j.name: j.servo for j in config.arm.joints if j.servo is not None}
    values = chain.actuated_of(q) / chain.scale[chain.actuated_index]  # deg or cm
    shaft = values * np.array([servos[n].us_per_unit / US_PER_SERVO_DEG for n in chain.actuated])
    return np.abs(np.diff(shaft, n=2, axis=0)) / period_s**2


def _place_route(config: Config) -> tuple[Executor, Route, SimArm]:
    """An executor on the kinematic rig, and a planned route from a pick to its bin."""
    model = ArmModel(config.arm)
    bus = SimArm(config, World.from_config(config))
    ex = Executor(config, bus, model)
    planner = Planner(config, model)
    red = config.task.class_named("red")
    start = planner.plan(Route("", "red1", "pick", 1, planner.pick_target(red, 10.0, 40.0)),
                         model.home)  # fmt: skip
    assert start.planned and start.plan is not None
    place = planner.plan(Route("", "red1", "place", 1, planner.place_target(red)), start.plan.q)
    assert place.planned and place.plan is not None
    return ex, place, bus


def test_a_carried_path_keeps_every_servo_under_the_cap():
    """Timed for a carry, a straight joint move (one segment: the time law's bound is each
    servo's) accelerates no servo's shaft faster than the cap; timed empty, the same move
    is faster and accelerates harder."""
    config = _config(CAP_DEG_S2)
    ex, place, bus = _place_route(config)
    with bus:
        assert place.plan is not None
        path = ex.joint_path(place.plan.q_path[0])  # from home (where it starts) to the pick
        carried = ex.timed(path, carrying=True)
        empty = ex.timed(path)
    a_carried = _servo_accel_deg_s2(config, carried.q, carried.period_s)
    a_empty = _servo_accel_deg_s2(config, empty.q, empty.period_s)
    print(f"\npeak shaft acceleration: carried {a_carried.max():.0f}, empty {a_empty.max():.0f}")
    assert a_carried.max() <= CAP_DEG_S2 * (1 + 1e-6)
    assert a_empty.max() > 2 * CAP_DEG_S2
    assert carried.duration_s > empty.duration_s


def test_a_route_streamed_with_the_jaws_closed_is_timed_as_a_carry():
    """stream(closed=True) sends the carry's timing, closed=False the servos' own."""
    config = _config(CAP_DEG_S2)
    ex, place, bus = _place_route(config)
    with bus:
        assert place.plan is not None
        carried = len(ex.timed(place.plan.q_path, carrying=True).q) - 1
        empty = len(ex.timed(place.plan.q_path).q) - 1
        sent: list[int] = []
        move = bus.move
        bus.move = lambda command: (sent.append(1), move(command))[1]  # type: ignore[method-assign]
        ex.stream(place, "travel", closed=True)
        n_closed = len(sent)
    assert carried > empty
    assert n_closed == carried


def test_without_a_cap_a_carry_is_timed_as_any_move():
    """``null`` (the default): the carry keeps the servos' own limits."""
    config = _config(None)
    model = ArmModel(config.arm)
    ex = Executor(config, SimArm(config, World.from_config(config)), model)
    assert carry_limits(ex.limits, config, model.chain) is ex.limits
    assert ex.carry_limits is ex.limits


def test_a_cap_out_of_range_is_refused():
    """A cap under 100 deg/s² (no servo is that slow to start) is a config error; 1000 is
    taken as given."""
    from mearm.config import load_config  # noqa: PLC0415
    from mearm.errors import ConfigError  # noqa: PLC0415

    with pytest.raises(ConfigError, match="carry_accel_deg_s2"):
        load_config(None, ["task.carry_accel_deg_s2=50"])
    assert load_config(None, ["task.carry_accel_deg_s2=1000"]).task.carry_accel_deg_s2 == 1000
