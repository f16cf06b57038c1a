"""Paths that start alike are walked alike: segments checked before are not checked again."""

from __future__ import annotations

from conftest import ROOT

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.kinematics.bodies import TableContents
from mearm.kinematics.collision import Contact
from mearm.sim.table_collision import collision_model
from mearm.task.plan import Planner
from mearm.task.route import Route


def _said(contact: Contact | None) -> tuple[object, ...] | None:
    if contact is None:
        return None
    return (contact.arm_part, contact.obstacle, contact.distance_cm, contact.pose_index,
            tuple(contact.q.tolist()), contact.start_cm)  # fmt: skip


def test_paths_from_home_past_grown_walls_are_checked_as_if_each_were_the_first() -> None:
    """The paper arm's home hangs the jaws over the red bin. With its walls grown for ten
    objects a class, every pick from home goes up past them first, then over and down (a
    random table's way-in check plans one per pick). Each path, straight or over the top,
    clear or not, is found as a model that checks it afresh finds it, at every pose; and
    the walks up that the paths share are checked once, not once a path."""
    config = load_config(ROOT / "configs" / "sim.yaml")
    model = ArmModel(config.arm)
    table = TableContents(tuple(config.task.classes), dict.fromkeys(config.task.class_names, 10))

    def checker():  # noqa: ANN202
        collision = collision_model(
            config, model, clearance_cm=config.task.clearance_cm, table=table
        )
        collision.set_world([])
        return collision

    planner = Planner(config, model, checker())
    cls = config.task.classes[1]
    paths = []
    for x, y in [(-10.0, 42.0), (-4.0, 50.0), (0.0, 45.0), (6.0, 52.0), (10.0, 44.0), (2.0, 40.0)]:
        target = planner.pick_target(cls, x, y)
        paths.append(planner.solver.solve(target, model.home).q_path)  # straight
        route = planner.plan(Route("", cls.name, "pick", 1, target), model.home)
        assert route.planned and route.plan is not None, route.failure
        paths.append(route.plan.q_path)  # up, over and down
    memo, fresh = checker(), checker()
    found = []
    for path in paths:
        fresh.forget_paths()
        found.append((_said(memo.first_contact(path)), _said(fresh.first_contact(path))))
    assert [m for m, _ in found] == [f for _, f in found]
    assert {m is None for m, _ in found} == {True, False}  # (clear paths and refused ones)
    assert memo.checks < fresh.checks / 2, (memo.checks, fresh.checks)
