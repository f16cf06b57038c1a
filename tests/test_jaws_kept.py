"""A route keeps the jaws' roll it starts with: no target turns them.

The 5-DOF arm's wrist roll moves neither the TCP nor the approach axis, so no pick or
place target sets it, and the solver's own updates leave it; a multi-start's seed, drawn
over the whole joint box, did not. ``sim_5dof --random 26 --seed 42011`` (the count its
refusal of 500 names) placed a red picked 27 cm out over the top with a multi-start that
turned the jaws by 50.7°, and every route after kept the turn. The random layout checks
each pick's jaws as planned from home, unturned: there two blues 3.55 cm apart clear each
other; turned, from over the blue bin, each pick's straight way met the bin's wall and
its way over the top came down with a pad within the clearance of the other blue, and the
sort left both, ``no route clear of collisions``, 24 of 26 (2026-12-07, simulated). The
same walls turn the jaws the same way on the way over the top from home to a blue at
(-12.14, 24.55), the case here. The roll now stays where the route starts, every check
made on the path as sent.
"""

from __future__ import annotations

import numpy as np
from conftest import ROOT

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.sim.table_collision import collision_model
from mearm.task.plan import Planner
from mearm.task.route import Route
from mearm.task.scene import _class_order, _table_of

#: The blue whose way over the top went through a multi-start, and the two side by side.
FAR_BLUE = (-12.14, 24.55)
PAIR = [("blue3", (1.89, 23.94)), ("blue4", (3.05, 20.59))]


def _planner() -> tuple[Planner, ArmModel]:
    config = load_config(ROOT / "configs" / "sim_5dof.yaml")
    model = ArmModel(config.arm)
    table = _table_of(config, _class_order(config, 26, 42011))  # the walls of that table
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm, table=table)
    return Planner(config, model, collision), model


def _over_the_top(planner: Planner, model: ArmModel) -> Route:
    """The pick of the far blue from home, planned with nothing else on the table."""
    blue = planner.config.task.class_named("blue")
    planner.collision.set_world([])
    route = Route("blue2", "blue", "pick", 1, planner.pick_target(blue, *FAR_BLUE))
    planner.plan(route, model.home, target="blue2")
    assert route.planned and route.plan is not None
    assert route.detour_cm is not None  # over the top
    return route


def test_a_multi_start_leaves_the_jaws_as_they_were():
    planner, model = _planner()
    plan = _over_the_top(planner, model).plan
    assert plan is not None
    roll = model.chain.actuated_of(plan.q_path)[:, 4]
    assert np.all(roll == model.chain.actuated_of(model.home)[4])


def test_two_blues_side_by_side_are_picked_after_it():
    planner, model = _planner()
    plan = _over_the_top(planner, model).plan
    assert plan is not None
    blue = planner.config.task.class_named("blue")
    planner.collision.set_world([(name, "blue", x, y) for name, (x, y) in PAIR])
    for name, (x, y) in PAIR:
        pick = Route(name, "blue", "pick", 1, planner.pick_target(blue, x, y))
        planner.plan(pick, plan.q, target=name)
        assert pick.planned, pick.failure
