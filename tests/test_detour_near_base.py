"""A place from a pick near the arm's base, past grown walls: the way over rises as it goes.

``sim --random 44 --seed 43011`` (the count a refusal of 500 named) left a blue by the
table's near edge, ``bin unreachable``: the straight way to its bin met the bin's wall,
and the way over the top, at the height the green bin's walls (grown for 15 greens) set,
began straight up from the pick, which the paper arm cannot rise to there (its shoulder
past its limit, 135.02 deg). The way over now leaves from the pick, rising as it goes,
checked whole as before. The table is the reduced one that still left it: 15 greens and
6 blues, the blue the last to sort (the table then empty but for the bins).
"""

from __future__ import annotations

from conftest import ROOT

from mearm.config import SceneObject, load_config
from mearm.kinematics import ArmModel
from mearm.sim.table_collision import collision_model
from mearm.task.plan import Planner
from mearm.task.route import Route

GREENS = [
    (2.01, 56.23), (5.34, 54.17), (-5.06, 56.27), (-7.32, 43.2), (8.67, 51.69),
    (3.19, 44.08), (-14.7, 56.37), (7.28, 45.75), (16.22, 56.38), (5.06, 48.96),
    (14.36, 41.8), (-10.19, 45.84), (17.42, 47.36), (1.97, 50.98), (-10.67, 56.43),
]  # fmt: skip
BLUES = [(-13.01, 31.16), (-12.12, 50.56), (17.48, 32.09), (1.97, 33.44), (16.88, 37.08)]
#: The blue left: 32 cm from the base, by the table's near edge.
NEAR = (9.08, 31.15)


def test_a_place_from_near_the_base_goes_over_the_walls_rising_as_it_goes() -> None:
    scene = [SceneObject(color="green", x=x, y=y) for x, y in GREENS] + [
        SceneObject(color="blue", x=x, y=y) for x, y in [*BLUES, NEAR]
    ]
    config = load_config(ROOT / "configs" / "sim.yaml").with_scene(scene)
    model = ArmModel(config.arm)
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm)
    planner = Planner(config, model, collision)
    blue = config.task.class_named("blue")
    collision.set_world([])
    pick = Route("blue6", "blue", "pick", 1, planner.pick_target(blue, *NEAR))
    assert planner.plan(pick, model.home, target="blue6").planned, pick.failure
    assert pick.plan is not None
    collision.set_world([], opening_cm=blue.diameter_cm, held=("blue6", "blue"))
    place = Route("blue6", "blue", "place", 1, planner.place_target(blue))
    planner.plan_place(place, pick.plan.q)
    assert place.planned, place.failure
    assert place.plan is not None and place.detour_cm is not None  # over the walls
    # checked as every plan is: within the limits, and clear of the bins all the way
    assert planner.pose_allowed(place.plan.q_path)
    assert collision.first_contact(place.plan.q_path) is None
