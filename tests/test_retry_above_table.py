"""A pick lowered by a miss stays inside the arm's target box and goes as planned if it must.

On the 5-DOF desk arm the grip of a 1 cm object is 0.2 cm above the target box's floor
(``arm.target_box.z_cm.min`` 0.3 cm), and a miss that measured the claw high lets the
collision check see the table lower still: the retry was aimed at the check's bound, below
the box, and the object left "outside the target box" (5-DOF perspective twin, seed
998021, simulated: docs/twin.md).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from conftest import ROOT, rays_at_each_looks_height

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.sim.table_collision import collision_model
from mearm.task.claw_loop import TABLE_ROOM_CM
from mearm.task.pick_place import PickAndPlace
from mearm.task.plan import Planner
from mearm.task.table_tracking import TrackedObject

DESK = ROOT / "configs" / "sim_5dof_mujoco_perspective.yaml"
#: Where the seed's blue was picked again (998021, blue2), and how: the drop its miss
#: called for (seen 1.05 cm high, the open jaws 0.9 cm down its side) and how much lower
#: the check saw the table [cm].
AT_CM = (11.175, 15.776)
DROP_CM, BELOW_CM = 1.375, 0.5


@pytest.fixture(scope="module")
def picker() -> PickAndPlace:
    """A sort's pick planning alone: the desk arm, its planner and collision model."""
    config = load_config(DESK)
    model = ArmModel(config.arm)
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm)
    part = PickAndPlace.__new__(PickAndPlace)  # only what planning a pick reads
    part.config, part.model, part.collision = config, model, collision
    part._objects = []
    part.planner = Planner(config, model, collision)
    part.executor = SimpleNamespace(q_now=lambda: model.home.copy())
    return part


def _retry(picker: PickAndPlace, drop_cm: float, below_cm: float):
    blue = picker.config.task.class_named("blue")
    goal = picker.planner.pick_target(blue, *AT_CM)
    obj = TrackedObject("blue2", "blue", *AT_CM, failed_picks=1)
    picker._world(table_below_cm=below_cm)  # as the sort checks a retry
    above, pick = picker._pick_routes(obj, goal, np.array([0.0, 0.0, -drop_cm]), below_cm)
    return goal, above, pick


def test_a_retry_lowered_past_the_target_box_is_aimed_at_its_floor_and_planned(picker):
    """A drop below the box's floor, the check's table lowered: the pick goes to the floor."""
    goal, above, pick = _retry(picker, DROP_CM, BELOW_CM)
    floor = picker.config.arm.target_box.z_cm.min
    assert goal.position_cm[2] - DROP_CM < floor  # (the drop asked for more)
    assert pick.target.position_cm[2] == pytest.approx(floor)
    assert pick.target.position_cm[2] >= floor
    assert above is not None and above.planned and above.plan is not None
    assert picker.planner.plan(pick, above.plan.q, target="blue2").planned


def test_a_drop_within_both_bounds_is_kept(picker):
    """A drop that leaves the tips over the table and the TCP in the box is not changed."""
    goal, above, pick = _retry(picker, 0.03, 0.0)
    assert pick.target.position_cm[2] == pytest.approx(goal.position_cm[2] - 0.03)
    assert above is not None and above.planned


def test_a_drop_past_the_table_goes_no_lower_than_the_tips_allow(picker):
    """With the table where it is, the jaws' tips stay over it by the room kept."""
    goal, above, pick = _retry(picker, DROP_CM, 0.0)
    assert above is not None and above.plan is not None
    assert picker.planner.plan(pick, above.plan.q, target="blue2").planned
    assert pick.plan is not None
    lowest = picker.collision.tool_lowest_cm(pick.plan.q)[0]
    assert lowest >= TABLE_ROOM_CM - 0.01, lowest  # (the solver's tolerance)
    assert pick.target.position_cm[2] >= picker.config.arm.target_box.z_cm.min


def test_a_risen_pick_that_cannot_be_planned_goes_at_the_planned_height(picker, monkeypatch):
    """Where even the pick risen to its bound is refused, the retry goes as planned."""
    plan = picker.planner.plan
    blue = picker.config.task.class_named("blue")
    goal_z = float(picker.planner.pick_target(blue, *AT_CM).position_cm[2])

    def refuse_lowered(route, q, **kw):  # (as a neighbour in the way would)
        plan(route, q, **kw)
        if route.step == "pick" and route.target.position_cm[2] < goal_z - 1e-9:
            route.failure, route.failure_kind = "refused lower", "collision"
        return route

    monkeypatch.setattr(picker.planner, "plan", refuse_lowered)
    goal, above, pick = _retry(picker, DROP_CM, BELOW_CM)
    assert pick.target.position_cm[2] == pytest.approx(goal.position_cm[2])
    assert above is not None and above.planned


@pytest.mark.slow
def test_a_sort_with_a_retry_plans_every_pick_inside_the_box():
    """Seed 998044: red3's first pick pushes it aside (seen 4 cm on) and it is picked
    again where it lies; every pick the sort planned stays in the box, and nothing is left
    "outside the target box". (Until 2026-12-07 that second pick sent the disc rolling
    out of view and read ``ok``, its jaws empty; the places now come down into the bins
    straight, the arm moves otherwise, and such a pick would read ``FAILED``:
    tests/test_twin_pick_pushed_out_of_view.py.)

    Seed 998021, whose blue2 was left "outside the target box" (its retry at z = -0.05 cm),
    was traced while the planner took the bins' walls for those of the config's own 9
    objects, not the 12 the twin built them for; planned against the walls as built it
    misses nothing. The tests above drive that retry's drop directly."""
    from mearm.maker.camera_calibration.at_start import for_config
    from mearm.task.rig import run_sort
    from mearm.task.scene import random_scene

    config = load_config(DESK)
    floor = config.arm.target_box.z_cm.min
    asked: list[float] = []
    routes = PickAndPlace._pick_routes

    def kept(self, obj, goal, aim, below_cm=0.0):
        above, pick = routes(self, obj, goal, aim, below_cm)
        asked.append(float(pick.target.position_cm[2]))
        return above, pick

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(PickAndPlace, "_pick_routes", kept)
        rays_at_each_looks_height(mp)  # the scene as traced
        report = run_sort(
            config,
            scene=random_scene(config, 12, seed=998044),
            echo=None,
            calibrate_first=for_config(config),
        )
    assert min(asked) >= floor, asked
    assert "outside_box" not in report.outcome.left, report.outcome.left
    tries = [r for r in report.routes if r.object_id == "red3" and r.step in ("pick", "place")]
    assert [r.step for r in tries[:2]] == ["pick", "pick"]  # picked again where it lies
    assert not tries[0].success and "pushed it aside" in (tries[0].why_failed or "")
