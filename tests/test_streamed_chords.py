"""What the servos are sent is checked as the plan was: the chords between commands, and
the jaws opening at a release.

A route is planned as a fine polyline and sent one command per servo period
(:mod:`mearm.task.timing`); between two commands the servos move on the chord between
them. Out of a bin whose walls stand above the jaws (ten objects of a class: 11 cm walls)
a route rises, then turns: the first chord cut that corner and swung a jaw into the wall
(``mearm sort --config sim --random 30 --seed 3``, and seeds 4 and 7301-7306: the
kinematic rig faulted on every one, 2026-12-06). The executor now checks the chords and
slows a route until they are as clear as its plan; the planner checks that the jaws open
clear where a place ends.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.sim.table_collision import collision_model
from mearm.task import execute
from mearm.task.plan import Planner
from mearm.task.rig import run_sort
from mearm.task.route import Route
from mearm.task.scene import random_scene
from mearm.task.sorter import SortAborted

#: Where the place into the green bin ends on the paper arm [deg] (seed 3's table: ten
#: green objects, the bin's walls 11 cm high, the jaws between them).
IN_THE_GREEN_BIN = {"base": 113.96232, "shoulder": 72.02616, "elbow": -108.40048}
#: Where that place started: the pick before it.
PICKED = {"base": 84.36434, "shoulder": 82.82714, "elbow": -141.24981}


def _tall_bins():
    config = load_config(ROOT / "configs" / "sim.yaml")
    return config.with_scene(random_scene(config, 30, seed=3))


def test_a_table_of_tall_bins_is_sorted_without_a_fault() -> None:
    """Seed 3's 30 objects: every one sorted, no jaw on a wall on the way out of a bin."""
    config = _tall_bins()
    report = run_sort(config, echo=None)
    assert report.outcome.n_sorted == 30, report.outcome.left
    assert report.complete


def test_a_route_whose_chords_cannot_clear_is_not_sent(monkeypatch: pytest.MonkeyPatch) -> None:
    """No slower timing allowed: the route out of the green bin is refused whole, and the
    arm stays where the place left it (its chords were checked before any was sent)."""
    monkeypatch.setattr(execute, "SLOWER", ())
    with pytest.raises(SortAborted) as info:
        run_sort(_tall_bins(), echo=None)
    reason = info.value.reason
    assert "not sent: followed command by command" in reason, reason
    assert "bin_green_wall" in reason
    last = info.value.last_joints
    assert last is not None
    for name, deg in IN_THE_GREEN_BIN.items():
        assert last[name] == pytest.approx(deg, abs=0.01)  # where the place ended


def _in_the_green_bin(clearance_cm: float):
    config = _tall_bins()
    model = ArmModel(config.arm)
    collision = collision_model(config, model, clearance_cm=clearance_cm)
    chain = model.chain
    q = chain.from_named(IN_THE_GREEN_BIN)  # the levelled wrist follows
    green = config.task.class_named("green")
    collision.set_world([], opening_cm=green.diameter_cm, held=("green1", "green"))
    return config, model, collision, q, green


def test_the_jaws_opening_between_tall_walls_are_checked_at_every_step() -> None:
    """Closed on the object the jaws keep 0.5 cm from the walls; opened, they do not. The
    world is as it was afterwards: the held object and its opening."""
    config, _, collision, q, green = _in_the_green_bin(clearance_cm=0.5)
    open_cm = config.arm.tool.gripper.open_cm
    assert collision.gap(q)[0] >= 0  # as the place route left them
    contact = collision.opening_contact(q, open_cm)
    assert contact is not None
    assert contact.obstacle.startswith("bin_green_wall")
    assert contact.arm_part.startswith("gripper_jaw")
    assert collision._opening_cm == green.diameter_cm
    assert collision._held == ("green1", "green")
    assert collision.opening_contact(q, green.diameter_cm + 0.2) is None  # barely opened


def test_a_place_whose_jaws_would_open_into_a_wall_is_released_higher() -> None:
    """The planner raises such a release to where the open jaws clear every wall, and the
    jaws open clear there; the object drops the rest."""
    config, model, collision, _, green = _in_the_green_bin(clearance_cm=0.5)
    planner = Planner(config, model, collision)
    route = Route("green1", "green", "place", 1, planner.place_target(green))
    start = model.chain.from_named(PICKED)
    planner.plan_place(route, start)
    assert route.planned, route.failure
    assert route.plan is not None
    z = float(route.target.position_cm[2])
    assert z > green.bin_cm[2] + 1.0
    assert collision.opening_contact(route.plan.q, config.arm.tool.gripper.open_cm) is None
    # the same place at its own height: planned, its jaws opening into the wall
    low = Route("green1", "green", "place", 1, planner.place_target(green))
    assert planner.plan(low, start).planned
    assert low.plan is not None
    assert collision.opening_contact(low.plan.q, config.arm.tool.gripper.open_cm) is not None
    assert np.isclose(float(low.target.position_cm[2]), green.bin_cm[2])
