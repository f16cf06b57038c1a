"""Whether the config's scene can be built: objects, bins, the arm's base and the belt clear.

Also the scene objects' ids and where the belt's objects wait and land, which the model
and the twin's bus share.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mearm.config import Config
from mearm.kinematics.bodies import TableContents, base_radius_m, bin_half_outer_m, wall_height_m
from mearm.kinematics.errors import ModelError
from mearm.sim.belt import Arrival, Belt
from mearm.sim.twin.twin_geoms import M_PER_CM


def object_ids(config: Config) -> list[str]:
    """Scene objects' ids in scene order (``red1``, ``red2``, … per class)."""
    counts: dict[str, int] = {}
    out = []
    for obj in config.task.scene:
        counts[obj.color] = counts.get(obj.color, 0) + 1
        out.append(f"{obj.color}{counts[obj.color]}")
    return out


#: Where the belt's objects wait for their arrival, off the table: the first at this
#: (x, y) [m], the next ones :data:`PARK_STEP_M` further along x.
PARK_ORIGIN_M = (-3.0, -3.0)
PARK_STEP_M = 0.1


def parked_m(config: Config, index: int, arrival: Arrival) -> list[float]:
    """Where the ``index``-th object the belt brings waits, its centre (x, y, z) [m]."""
    h = config.task.class_named(arrival.color).height_cm * M_PER_CM
    return [PARK_ORIGIN_M[0] - index * PARK_STEP_M, PARK_ORIGIN_M[1], h / 2]


def arrival_centre_m(config: Config, arrival: Arrival) -> list[float]:
    """Where an object the belt brings lands: its centre (x, y, z) [m], on the belt's top."""
    assert config.belt is not None
    h = config.task.class_named(arrival.color).height_cm * M_PER_CM
    top = config.belt.surface_cm * M_PER_CM
    return [arrival.x_cm * M_PER_CM, arrival.y_cm * M_PER_CM, top + h / 2]


def _bin_half_outer_m(config: Config, color: str) -> float:
    return bin_half_outer_m(config.task.class_named(color))


def _wall_height_m(config: Config, color: str) -> float:
    table = TableContents.of(config.task, config.belt)
    return wall_height_m(table.class_named(color), table.objects(color))


def _check_scene(config: Config) -> None:
    task = config.task
    ids = object_ids(config)
    base_r = base_radius_m(config.arm)
    placed: list[tuple[str, np.ndarray, float]] = []
    for oid, obj in zip(ids, task.scene, strict=True):
        c = task.class_named(obj.color)
        xy = np.array([obj.x, obj.y]) * M_PER_CM
        r = c.footprint_radius_cm * M_PER_CM  # (the circle around a cube's or a prism's)
        for other, oxy, orr in placed:
            d = float(np.linalg.norm(xy - oxy))
            if d < r + orr:
                raise ModelError(
                    f"scene objects {other} and {oid} overlap: centres {d * 100:.3g} cm apart, "
                    f"less than their radii's sum {(r + orr) * 100:.3g} cm; move one "
                    "(task.scene)"
                )
        if float(np.linalg.norm(xy)) < base_r + r:
            raise ModelError(
                f"scene object {oid} at ({obj.x:g}, {obj.y:g}) cm stands on the arm's base "
                f"(radius {base_r * 100:.3g} cm around the origin); move it (task.scene)"
            )
        for b in task.classes:
            h = _bin_half_outer_m(config, b.name)
            bxy = np.array(b.bin_cm[:2]) * M_PER_CM
            if np.all(np.abs(xy - bxy) < h + r):
                raise ModelError(
                    f"scene object {oid} at ({obj.x:g}, {obj.y:g}) cm lies on the bin of "
                    f"class {b.name} (a {2 * h * 100:.3g} cm square around "
                    f"({b.bin_cm[0]:g}, {b.bin_cm[1]:g}) cm); move it (task.scene)"
                )
        placed.append((oid, xy, r))
    if config.belt is not None:
        _check_belt(config)
    for c in task.classes:
        if c.bin_inner_width_cm < c.diameter_cm:  # the twin's walls would hold none of them
            raise ModelError(
                f"class {c.name}: its bin is {c.bin_inner_width_cm:g} cm wide inside "
                f"(bin_width_cm), narrower than its objects ({c.diameter_cm:g} cm across): "
                f"none could land in it; make it at least {c.diameter_cm:g} cm "
                "(task.classes)"
            )
    table = TableContents.of(task, config.belt)
    problem = release_below_walls(config, table)
    if problem is not None:
        raise ModelError(f"{problem}; raise bin_cm z (task.classes), or {fewer_objects(table)}")


def release_below_walls(config: Config, table: TableContents) -> str | None:
    """Why an object of the first class that fails would land against its bin's walls, or ``None``.

    The twin builds each bin's walls to hold the table's objects of its class stacked
    (:func:`~mearm.kinematics.bodies.wall_height_m`), so more objects of a class raise its
    walls, and the release height (``bin_cm`` z less the tool's drop to the grip) that
    does for a few may leave a held object's bottom below them. Checked before anything
    is built or opened (:func:`~mearm.task.scene.check_scene`) as well as here.
    """
    for c in config.task.classes:
        wall = wall_height_m(table.class_named(c.name), table.objects(c.name))
        release = (c.bin_cm[2] - config.arm.tool.tcp_above_grip_cm - c.grip_z_cm) * M_PER_CM
        if release < wall:
            return (
                f"class {c.name}: an object released at bin_cm z = {c.bin_cm[2]:g} cm has its "
                f"bottom {release * 100:.3g} cm above the table, below the bin's "
                f"{wall * 100:.3g} cm walls ({_held(table, c.name, config)})"
            )
    return None


def fewer_objects(table: TableContents) -> str:
    """How to put fewer objects on a table whose walls grew too tall: the lever that sets them.

    A table that only a belt fills has no objects of its own to take away: a belt seed
    that drew 14 greens of 20 (``sim_conveyor``, ``belt.arrivals.seed=50300``) was told
    "give the class fewer objects".
    """
    if any(table.belt.values()) and not any(table.scene.values()):
        return "bring fewer objects (belt.arrivals.count) or draw another belt.arrivals.seed"
    return "give the class fewer objects"


def _held(table: TableContents, name: str, config: Config) -> str:
    """What a class's bin walls are built to hold, and where the count comes from.

    The walls grow with the objects they hold stacked: a belt's seed that draws many of
    one class raises them over a release height that does for the others (20 objects,
    belt seed 997012: 12 greens), and the line says so, not only "raise bin_cm z".
    """
    n = table.objects(name)
    held = f"tall enough for its {n} object{'s' if n != 1 else ''} stacked"
    brought = table.belt.get(name, 0)
    if config.belt is None or not brought:
        return held
    a = config.belt.arrivals
    return (
        f"{held}: the belt brings {brought} of its {a.count}, as belt.arrivals.seed "
        f"{a.seed} draws their classes"
    )


def _check_belt(config: Config) -> None:
    """The belt must lie clear of every bin.

    (Clear of the arm's base too: the config refuses a belt over it when it loads.)
    """
    assert config.belt is not None
    belt = Belt(config.belt)
    b = config.belt
    for c in config.task.classes:
        h = _bin_half_outer_m(config, c.name) / M_PER_CM
        corners = [(sx * h, sy * h) for sx in (-1, 1) for sy in (-1, 1)]
        along_across = [belt.along_across_cm(c.bin_cm[0] + dx, c.bin_cm[1] + dy)
                        for dx, dy in corners]  # fmt: skip
        along = [a for a, _ in along_across]
        across = [x for _, x in along_across]
        # the bin's square against the belt's strip: separated along one of the strip's axes
        # or one of the square's (both pairs are the only candidates for two rectangles)
        apart = (
            max(along) < 0
            or min(along) > b.length_cm
            or max(across) < -b.width_cm / 2
            or min(across) > b.width_cm / 2
            or _strip_clear_of_square(belt, c.bin_cm[:2], h)
        )
        if not apart:
            raise ModelError(
                f"the belt runs over the bin of class {c.name} (a {2 * h:.3g} cm square around "
                f"({c.bin_cm[0]:g}, {c.bin_cm[1]:g}) cm); move the belt or the bin "
                "(belt.start_cm, belt.length_cm, task.classes)"
            )


def _strip_clear_of_square(belt: Belt, centre_cm: Sequence[float], half_cm: float) -> bool:
    """Whether the belt's strip lies wholly beside a square (axis-aligned) in x or in y."""
    b = belt.config
    corners = [
        belt.point_cm(a, w) for a in (0.0, b.length_cm) for w in (-b.width_cm / 2, b.width_cm / 2)
    ]
    for k in (0, 1):
        values = [p[k] - centre_cm[k] for p in corners]
        if min(values) > half_cm or max(values) < -half_cm:
            return True
    return False
