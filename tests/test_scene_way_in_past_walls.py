"""Each pick of a random table has a way in from home past the walls the table grows.

The layout checked each pick's pose, not the way to it: ``mearm sort --config sim
--random 44 --seed 22001`` (the count the refusal of 500 names) laid out two greens by
the table's near edge, between the red bin's 20 cm walls and the arm, and the sort left
them, from home and from over every bin, ``no route clear of collisions``: 42 of 44.
"""

from __future__ import annotations

import pytest

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.sim.table_collision import collision_model
from mearm.task.plan import Planner
from mearm.task.route import Route
from mearm.task.scene import _table_of, random_scene

pytestmark = pytest.mark.heavy


def test_every_pick_of_a_table_of_grown_walls_is_planned_from_home() -> None:
    config = load_config("sim")
    scene = random_scene(config, 44, seed=22001)
    model = ArmModel(config.arm)
    table = _table_of(config, [o.color for o in scene])
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm, table=table)
    collision.set_world([])
    planner = Planner(config, model, collision)
    shut = []
    for o in scene:
        cls = config.task.class_named(o.color)
        route = Route("", cls.name, "pick", 1, planner.pick_target(cls, o.x, o.y))
        if not planner.plan(route, model.home).planned:
            shut.append((o.color, o.x, o.y, route.failure))
    assert len(scene) == 44
    assert not shut, shut
