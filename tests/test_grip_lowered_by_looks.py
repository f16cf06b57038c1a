"""A pick whose own looks saw the claw high goes lower before the jaws close.

Traced in the twin (kits 82 and 21 at spread 0.12, seeds 900–911 and 1700–1711,
simulated; docs/twin.md, "Picks that look"): the objects lost from grips of their top
0.04–0.1 cm were picked with the claw 0.42–0.48 cm high, and the pick's own three looks
saw it 0.38–0.63 cm high on average at most of them.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.sim.table_collision import collision_model
from mearm.task.claw_loop import shifted
from mearm.task.looking_picks import (
    HIGH_LOOKS_CM,
    LOOKS_MARGIN_CM,
    TIPS_OVER_TABLE_CM,
    lower_by_looks,
)
from mearm.task.plan import Planner
from mearm.task.route import Route
from mearm.task.table_tracking import TrackedObject


class _Arm:
    """An executor that goes exactly where each route's plan ends."""

    def __init__(self, q: np.ndarray):
        self.q = q
        self.streamed: list[Route] = []

    def q_now(self) -> np.ndarray:
        return self.q

    def stream(self, route: Route, *_args, **_kwargs) -> None:
        assert route.plan is not None and route.planned
        self.streamed.append(route)
        self.q = route.plan.q


@pytest.fixture(scope="module")
def rig():
    config = load_config(ROOT / "configs" / "sim_mujoco_kits.yaml")
    model = ArmModel(config.arm)
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm)
    planner = Planner(config, model, collision)
    return config, model, collision, planner


def _at_the_grip(rig):
    """The arm with its open jaws round a red object at (0, 45) cm, as a pick leaves it."""
    config, model, collision, planner = rig
    cls = config.task.class_named("red")
    collision.set_world([("red1", "red", 0.0, 45.0)], opening_cm=config.arm.tool.gripper.open_cm)
    obj = TrackedObject("red1", "red", 0.0, 45.0)
    goal = planner.pick_target(cls, 0.0, 45.0)
    above = Route("red1", "red", "approach", 1, planner.above_target(goal, 4.0))
    pick = Route("red1", "red", "pick", 1, shifted(goal, np.zeros(3)))
    assert planner.plan(above, model.home).planned
    assert above.plan is not None
    assert planner.plan(pick, above.plan.q).planned
    assert pick.plan is not None
    return obj, above, pick, _Arm(pick.plan.q)


def test_looks_that_saw_the_claw_high_lower_the_pick_by_their_mean_less_the_margin(rig):
    """Seen 0.5 cm high on average: up and down again, 0.3 cm lower, both legs planned."""
    _, model, collision, planner = rig
    obj, above, pick, arm = _at_the_grip(rig)
    seen = [0.45, 0.6, 0.45]
    low, aim = lower_by_looks(planner, collision, arm, obj, above, pick, np.zeros(3), seen)
    drop = np.mean(seen) - LOOKS_MARGIN_CM
    assert [r.step for r in arm.streamed] == ["approach", "pick"]
    assert aim[2] == pytest.approx(-drop)
    assert low.target.position_cm[2] == pytest.approx(pick.target.position_cm[2] - drop)
    assert low.plan is not None
    z_before = float(model.fk_cm(pick.plan.q)[2])
    assert float(model.fk_cm(low.plan.q)[2]) == pytest.approx(z_before - drop, abs=0.1)
    assert collision.tool_lowest_cm(low.plan.q)[0] >= TIPS_OVER_TABLE_CM - 0.05


def test_looks_not_high_enough_or_too_few_leave_the_pick_as_it_is(rig):
    """Seen at most the threshold high, or by one look only: nothing moves."""
    _, _, collision, planner = rig
    for seen in ([HIGH_LOOKS_CM - 0.1, HIGH_LOOKS_CM], [0.9], [-0.4, -0.3, -0.2]):
        obj, above, pick, arm = _at_the_grip(rig)
        low, aim = lower_by_looks(planner, collision, arm, obj, above, pick, np.zeros(3), seen)
        assert low is pick and arm.streamed == [] and aim[2] == 0.0


def test_a_claw_seen_far_too_high_is_lowered_no_closer_to_the_table_than_the_bound(rig):
    """Seen 3 cm high: lowered only as far as leaves the tips the bound over the table."""
    _, _, collision, planner = rig
    obj, above, pick, arm = _at_the_grip(rig)
    assert pick.plan is not None
    room = collision.tool_lowest_cm(pick.plan.q)[0] - TIPS_OVER_TABLE_CM
    low, aim = lower_by_looks(planner, collision, arm, obj, above, pick, np.zeros(3), [3.0, 3.0])
    assert aim[2] == pytest.approx(-room)
    assert low.plan is not None
    assert collision.tool_lowest_cm(low.plan.q)[0] == pytest.approx(TIPS_OVER_TABLE_CM, abs=0.06)
