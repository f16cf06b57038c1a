"""The start-up check's reach over the camera's view: the batch solve skips, never decides."""

import numpy as np
import pytest

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.task import check
from mearm.task.plan import Planner
from mearm.task.route import Route


def planned_one_by_one(planner, model, cls, points):
    """What the check answered before the batch: a plan from home for every point."""
    out = []
    for x, y in points:
        route = Route("", cls.name, "pick", 1, planner.pick_target(cls, float(x), float(y)))
        out.append(planner.plan(route, model.home).planned)
    return out


@pytest.mark.parametrize("name", ["sim", "sim_5dof"])
def test_view_reach_is_the_same_as_planning_every_point(name):
    """Skipping the points no joints reach changes no answer (closed form and 5-DOF arm)."""
    config = load_config(name)
    model = ArmModel(config.arm)
    planner = Planner(config, model)
    cls = config.task.classes[0]
    points = check._view_points_cm(config)
    fast = list(check._reached(planner, model, cls.name, points))
    assert fast == planned_one_by_one(planner, model, cls, points)
    assert 0 < sum(fast) < len(points)  # the grid holds both kinds


def test_unreachable_points_are_not_planned(monkeypatch):
    """A point no joints reach costs no plan (and no multi-start recovery)."""
    config = load_config("sim_5dof")
    model = ArmModel(config.arm)
    planner = Planner(config, model)
    cls = config.task.classes[0]
    far = np.array([[0.0, 200.0], [150.0, 150.0]])  # metres beyond the arm's reach
    plans = []
    monkeypatch.setattr(planner, "plan", lambda route, q: plans.append(route))
    assert list(check._reached(planner, model, cls.name, far)) == [False, False]
    assert plans == []


def test_box_reach_stops_at_the_first_point_planned(monkeypatch):
    """``any`` over the target box plans until the first point is reached, no further."""
    config = load_config("sim")
    model = ArmModel(config.arm)
    planner = Planner(config, model)
    plan = planner.plan
    calls = []

    def counted(route, q):
        calls.append(route)
        return plan(route, q)

    monkeypatch.setattr(planner, "plan", counted)
    points = check._box_points_cm(config)
    assert any(check._reached(planner, model, config.task.classes[0].name, points))
    assert 1 <= len(calls) < len(points)
