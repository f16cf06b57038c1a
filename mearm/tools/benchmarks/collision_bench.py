"""The ``collision`` section: a collision check per pose and per route, beside IK."""

from __future__ import annotations

import functools
import itertools
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from mearm.tools.benchmarks.bench_base import BenchOptions, Row, best_seconds, section

if TYPE_CHECKING:
    from mearm.config import Config


def collision_routes(
    config: Config, collision: Any
) -> list[tuple[np.ndarray, str | None, Any, list]]:
    """The scene's picks and places planned one after another, as the sorter plans them.

    Each entry: the route's joint path (checked, detoured where needed), the object the
    jaws close on (picks), the held object (places) and the objects on the table then.
    """
    from mearm.sim.kinematic.world import World  # noqa: PLC0415
    from mearm.task.plan import Planner  # noqa: PLC0415
    from mearm.task.route import Route  # noqa: PLC0415

    model = collision.model
    planner = Planner(config, model, collision)
    on_table = list(World.from_config(config).table_objects())
    order = sorted(on_table, key=lambda o: config.task.class_names.index(o.color))
    g = config.arm.tool.gripper
    q = model.home
    out: list[tuple[np.ndarray, str | None, Any, list]] = []
    for obj in order:
        cls = config.task.class_named(obj.color)
        objects = [(o.id, o.color, o.x_cm, o.y_cm) for o in on_table]
        collision.set_world(objects, opening_cm=g.open_cm, held=None)
        target = planner.pick_target(cls, obj.x_cm, obj.y_cm)
        pick = planner.plan(Route(obj.id, obj.color, "pick", 1, target), q, target=obj.id)
        assert pick.planned and pick.plan is not None, pick.failure
        out.append((pick.plan.q_path, obj.id, None, objects))
        on_table = [o for o in on_table if o is not obj]
        objects = [(o.id, o.color, o.x_cm, o.y_cm) for o in on_table]
        held = (obj.id, obj.color)
        collision.set_world(objects, opening_cm=cls.diameter_cm, held=held)
        place = planner.plan(
            Route(obj.id, obj.color, "place", 1, planner.place_target(cls)), pick.plan.q
        )
        assert place.planned and place.plan is not None, place.failure
        out.append((place.plan.q_path, None, held, objects))
        q = place.plan.q
    return out


@section("collision")
def bench_collision(options: BenchOptions) -> list[Row]:
    """A collision check per pose and per route, beside the IK solve of the same route."""
    import pinocchio as pin  # noqa: PLC0415

    from mearm.config import load_config  # noqa: PLC0415
    from mearm.ik import make_solver  # noqa: PLC0415
    from mearm.kinematics import ArmModel  # noqa: PLC0415
    from mearm.sim.table_collision import collision_model  # noqa: PLC0415

    config = load_config("sim_mujoco")  # the paper's arm, jaws down, its 12-object scene
    model = ArmModel(config.arm)
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm)
    solver = make_solver(model, config.controller)
    routes = collision_routes(config, collision)
    g = config.arm.tool.gripper

    def world(k: int) -> None:
        _, _, held, objects = routes[k]
        opening = g.open_cm if held is None else config.task.class_named(held[1]).diameter_cm
        collision.set_world(objects, opening_cm=opening, held=held)

    checks = poses = 0
    for k, (path, target, _, _) in enumerate(routes):
        world(k)
        before = collision.checks
        collision.forget_paths()
        assert collision.first_contact(path, target=target) is None
        checks += collision.checks - before
        poses += len(path)
    calls: dict[str, Callable[[], object]] = {}
    for k, (path, target, _, _) in enumerate(routes):
        calls[f"route/{k}"] = functools.partial(_checked_route, world, k, collision, path, target)
        calls[f"ik/{k}"] = functools.partial(solver.solve, model.fk_cm(path[-1]), path[0])
    world(0)
    path0 = routes[0][0]
    two_poses = itertools.cycle([path0[len(path0) // 2], path0[len(path0) // 3]])
    q_mid = path0[len(path0) // 2]

    def pose() -> object:  # two poses in turn: a repeated pose is not checked again
        return collision.gap(next(two_poses), target=routes[0][1])

    calls["pose"] = pose
    geom, gdata = collision.geometry, collision.gdata
    calls["all pairs"] = functools.partial(
        pin.computeDistances, model.model, collision.data, geom, gdata, q_mid
    )
    worlds = itertools.cycle([0, 1])
    calls["world"] = lambda: world(next(worlds))  # two worlds in turn: a new one each call
    best = best_seconds(
        calls, options.repeat, {"pose": 50, "all pairs": 50, "world": 10}, "collision"
    )
    counts = (
        f"{checks / len(routes):.1f} checks a route, {poses / len(routes):.1f} poses in its path"
    )
    return _rows(best, len(routes), len(geom.collisionPairs), counts, options.repeat)


def _rows(best: dict[str, float], n: int, pairs: int, counts: str, repeat: int) -> list[Row]:
    """The section's rows from the best times [s] of :func:`bench_collision`'s calls."""
    route_s = sum(best[f"route/{k}"] for k in range(n)) / n
    ik_s = sum(best[f"ik/{k}"] for k in range(n)) / n
    note = (
        f"{n} routes of the paper's twin scene (configs/sim_mujoco.yaml), best of {repeat} rounds"
    )
    return [
        Row(
            "collision",
            "check of one pose (the pairs that count, min distance)",
            best["pose"] * 1e6,
            "µs",
            note,
        ),
        Row(
            "collision",
            f"peer: pin.computeDistances alone, the pairs switched on of {pairs}",
            best["all pairs"] * 1e6,
            "µs",
            "same pose",
        ),
        Row(
            "collision",
            "one pose / computeDistances alone",
            best["pose"] / best["all pairs"],
            "×",
            "the check adds the joints' kinematics and the jaws' target",
        ),
        Row(
            "collision",
            "check of one route (conservative advancement)",
            route_s * 1e3,
            "ms",
            counts,
        ),
        Row("collision", "the same route's IK solve (PD-PIJ)", ik_s * 1e3, "ms", ""),
        Row("collision", "route check / IK solve", route_s / ik_s, "×", ""),
        Row(
            "collision",
            "world update (objects, jaws, held object)",
            best["world"] * 1e6,
            "µs",
            "the objects' places moved, the pairs of those gone switched off",
        ),
    ]


def _checked_route(
    world: Callable[[int], None], k: int, collision: Any, path: np.ndarray, target: str | None
) -> object:
    world(k)
    collision.forget_paths()  # (each timing checks the whole route, not its memory of it)
    return collision.first_contact(path, target=target)
