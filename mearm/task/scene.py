"""Simulated table layouts: scene files and random scenes.

A scene is a list of ``{color, x, y}`` objects in the base frame [cm] (and ``yaw_deg``,
the turn of a cube or a prism; its shape is its class's). Random scenes put
objects at least 1 cm apart (edge to edge, so centres at least 3 cm apart for the paper's
2 cm discs) where the camera sees them whole and the arm can pick them.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np
from pydantic import TypeAdapter, ValidationError

from mearm.config import ColorClass, Config, SceneObject
from mearm.config.base import MAX_SEED, loc_text, short_repr
from mearm.config.belt_config import MAX_ARRIVALS
from mearm.config.polygon import extent
from mearm.config.sections import MAX_SCENE_OBJECTS, WHOLE_FRAME_PX
from mearm.errors import ConfigError, MearmError
from mearm.ik import APPROACH_TOLERANCE_DEG
from mearm.ik.reach import ReachBound
from mearm.kinematics import ArmModel, check_in_box, closed_form_for
from mearm.kinematics.bodies import (
    M_PER_CM,
    TableContents,
    base_radius_m,
    bin_half_outer_m,
    bin_name,
    class_of,
    object_name,
    object_of,
    wall_height_m,
)
from mearm.kinematics.collision import TOUCH_CM, TOUCH_M, CollisionModel
from mearm.kinematics.model import CM_PER_M
from mearm.sim.table_collision import collision_model
from mearm.task.check import bins_near_home, too_little_spare
from mearm.task.plan import Planner
from mearm.task.route import Route
from mearm.vision.calibration import camera_geometry
from mearm.yamlio import load_yaml_file

if TYPE_CHECKING:
    from pydantic_core import ErrorDetails

#: Edge-to-edge gap between objects in a random scene [cm] (paper §5).
MIN_GAP_CM = 1.0
#: The other way out of walls grown too tall for the arm (:func:`_walls_shut_bin`).
_LOWER_WALLS = ", or set the class's bin_height_cm (task.classes)"

_SCENE = TypeAdapter(list[SceneObject])


class SceneError(MearmError):
    """A scene cannot be built (bad file, or no room for the objects asked for)."""


class _TableShut(SceneError):
    """Walls that shut every way from home to the table, said without a count."""


class _TableFull(SceneError):
    """No room on the table for the objects asked for; ``most`` one layout held.

    ``kept``: the most a layout that held every object kept once each had a way in past
    the walls (:func:`_way_in_check`; ``most`` where none held every object).
    """

    def __init__(self, message: str, most: int, kept: int):
        super().__init__(message)
        self.most = most
        self.kept = kept


def load_scene(path: str | Path, class_names: Sequence[str] | None = None) -> list[SceneObject]:
    """Read a scene file: a YAML list of ``{color, x, y}`` [cm], ``color`` a class name.

    Each entry may also give ``yaw_deg``, its turn about the vertical [deg].

    Args:
        path: The file.
        class_names: The config's classes; an entry naming another is refused.

    Raises:
        ConfigError: the file is missing, not a regular file, too large, not YAML (read
            as :func:`mearm.yamlio.load_yaml_file` reads a config), or an entry is
            malformed; more than :data:`~mearm.config.sections.MAX_SCENE_OBJECTS` objects.
    """
    p = Path(path)
    data = load_yaml_file(p, what="scene")
    if not isinstance(data, list):
        raise ConfigError(str(p), ["a scene is a list of {color, x, y} entries"])
    if len(data) > MAX_SCENE_OBJECTS:
        raise ConfigError(
            str(p), [f"{len(data)} objects: a scene holds at most {MAX_SCENE_OBJECTS}"]
        )
    try:
        scene = _SCENE.validate_python(data)
    except ValidationError as exc:
        raise ConfigError(str(p), [_scene_problem(e) for e in exc.errors()[:10]]) from None
    if class_names is not None:
        bad = [
            f"[{i}.color]: {o.color!r} is not a class (classes: {', '.join(class_names)})"
            for i, o in enumerate(scene)
            if o.color not in class_names
        ]
        if bad:
            raise ConfigError(str(p), bad)
    return scene


def _scene_problem(err: ErrorDetails) -> str:
    """One problem of a scene file's entry, in the words a config's ``task.scene`` gets.

    An unknown key suggests the one it most likely meant (``colour``: ``color``), a
    missing one is said missing, an entry that is no mapping says what an entry is.
    """
    loc, msg, kind = loc_text(err["loc"]), err["msg"], err["type"]
    if kind == "extra_forbidden":
        import difflib  # noqa: PLC0415  (a mistyped key's suggestion; a sort never needs it)

        key = str(err["loc"][-1])
        close = difflib.get_close_matches(key, list(SceneObject.model_fields), n=1, cutoff=0.6)
        meant = f"; did you mean {close[0]}?" if close else ""
        return f"[{loc}]: unknown key{meant} (an entry is {{color, x, y}}, optionally yaw_deg)"
    if kind == "missing":
        return f"[{loc}]: required but missing"
    if kind in ("model_type", "model_attributes_type", "dict_type"):
        return f"[{loc}]: an entry is {{color, x, y}} (got {short_repr(err.get('input'), 60)})"
    # an error that names the value already (``expected a number, got true``) is not
    # given it twice
    got = "" if ", got " in msg else f" (got {short_repr(err.get('input'), 60)})"
    return f"[{loc}]: {msg}{got}"


#: Points on an object's rim checked to lie in the camera's frame.
RIM_POINTS = 16


#: How far inside the image's edges an object's rim must map to be seen whole [px]: the
#: detector takes a region that reaches the outermost row or column for one cut by the
#: border (:func:`mearm.task.table_tracking.is_cut`), and the drawn rim's edge pixels
#: blend a pixel beyond it.
BORDER_PX = 1.5


def _work_area_test(config: Config) -> Callable[[float, float, float], bool] | None:
    """Whether an object of radius r at (x, y) [cm] lies whole inside ``vision.work_area_px``.

    The detector looks nowhere else (:func:`~mearm.vision.learned.area_mask`): an object
    outside it, or cut by its edge, is never seen or seen cut. Its rim maps into the
    polygon :data:`BORDER_PX` inside, as into the frame. ``None``: no polygon given
    (``null``, ``whole_frame``), so the frame is the bound.
    """
    polygon = config.vision.work_area_px
    if polygon is None or polygon == WHOLE_FRAME_PX:
        return None
    contour = np.asarray(polygon, np.float32).reshape(-1, 1, 2)
    geometry = camera_geometry(config.calibration, config.camera)
    angles = np.linspace(0.0, 2 * np.pi, RIM_POINTS, endpoint=False)
    rim = np.column_stack([np.cos(angles), np.sin(angles)])

    def inside(r: float, x: float, y: float) -> bool:
        px = geometry.table_to_pixel(np.array([x, y]) + r * rim)
        return bool(np.all(np.isfinite(px))) and all(
            cv2.pointPolygonTest(contour, (float(u), float(v)), measureDist=True) >= BORDER_PX
            for u, v in px
        )

    return inside


def _outside_work_area(config: Config) -> str:
    """What a refusal says of an object outside ``vision.work_area_px``."""
    polygon = config.vision.work_area_px or []
    return (
        f"outside the work area (vision.work_area_px: {extent(polygon)}), where nothing "
        "is detected: the whole object must lie inside it"
    )


def check_scene(
    config: Config,
    scene: Sequence[SceneObject],
    source: str = "task.scene",
    *,
    work_area: bool = False,
) -> None:
    """Refuse a simulated table the sort could not see whole: name the object and the rule.

    Every object must stand on the table clear of the arm's base plate, lie whole inside
    the camera's view (its rim maps into the frame through the calibration), overlap no
    other object (centres at least the sum of their radii apart) and stand outside every
    bin (its disc clear of the bin's square, walls included). An object that broke one of
    these would be left unseen, or seen as part of another, and the sort would report a
    table of fewer objects than it was given. A cube's or a prism's disc is the circle
    around its footprint (:attr:`~mearm.config.classes.ColorClass.footprint_radius_cm`),
    whatever its yaw, as the twin builds it and the planner sees it: its corners reach
    beyond half its side.

    A table with nothing to sort is refused too: no objects, and no belt bringing any
    (``belt.arrivals.count`` 0). The sort would end ``sorted 0 of 0 objects`` with exit 0,
    a success that did nothing, as ``--random 0`` did before it was refused.

    Args:
        config: The camera and its calibration, the classes (diameters, bins), the arm,
            the belt.
        scene: The objects.
        source: How messages name the scene (a file's path, ``task.scene``).
        work_area: A table laid out for this run (``--scene``, ``--random``): its objects
            lie whole inside ``vision.work_area_px`` too, where one is given (nothing
            outside it is detected), as :func:`random_scene` draws them. The config's own
            table is not held to it: a polygon that keeps a corner of the frame is a
            warning, and the sort goes on (:func:`mearm.sort._check_work_area`).

    Raises:
        SceneError: one line naming the first object that breaks a rule, the rule and what
            is allowed (``(+N more)`` when others do too); or saying there is nothing to sort.
    """
    if not scene:
        _check_something_to_sort(config, source)
        _check_walls(config, scene, source)  # a belt's objects stack in the bins too
        return
    base_cm = base_radius_m(config.arm) / M_PER_CM
    bins = [(c, bin_half_outer_m(c) / M_PER_CM) for c in config.task.classes]
    geometry = camera_geometry(config.calibration, config.camera)
    w, h = config.camera.width_px, config.camera.height_px
    angles = np.linspace(0.0, 2 * np.pi, RIM_POINTS, endpoint=False)
    rim = np.column_stack([np.cos(angles), np.sin(angles)])
    radius = {c.name: c.footprint_radius_cm for c in config.task.classes}
    in_area = _work_area_test(config) if work_area else None
    problems: list[str] = []
    for i, obj in enumerate(scene):
        what = f"{source}[{i}] ({obj.color} at x {obj.x:g}, y {obj.y:g} cm)"
        if obj.color not in radius:
            problems.append(
                f"{what}: no class {obj.color!r}; classes: {', '.join(config.task.class_names)}"
            )
            continue
        r = radius[obj.color]
        if math.hypot(obj.x, obj.y) < base_cm + r:
            problems.append(
                f"{what}: not on the table: it stands on the arm's base plate "
                f"({base_cm:.1f} cm radius about the origin); its centre must be at least "
                f"{base_cm + r:.1f} cm from the origin"
            )
            continue
        points = np.array([obj.x, obj.y]) + r * rim
        px = geometry.table_to_pixel(points)
        back = geometry.pixel_to_table(px)
        b = BORDER_PX
        inside = (
            np.all(np.isfinite(px))
            and np.all((px[:, 0] >= b) & (px[:, 0] <= w - b))
            and np.all((px[:, 1] >= b) & (px[:, 1] <= h - b))
            and np.allclose(back, points, atol=0.01)
        )
        if not inside:
            x0, x1, y0, y1 = camera_field_cm(config, margin_cm=r, border_px=b)
            field = (
                f" (centres within x {x0:.1f}…{x1:.1f}, y {y0:.1f}…{y1:.1f} cm are)"
                if x0 < x1 and y0 < y1
                else ""
            )
            problems.append(
                f"{what}: outside the camera's view of the table ({w}x{h} px through "
                f"calibration): the whole object must be seen{field}"
            )
            continue
        if in_area is not None and not in_area(r, obj.x, obj.y):
            problems.append(f"{what}: {_outside_work_area(config)}")
            continue
        for j, other in enumerate(scene[:i]):
            apart = r + radius[other.color]
            if math.hypot(obj.x - other.x, obj.y - other.y) < apart:
                problems.append(
                    f"{what}: overlaps {source}[{j}] ({other.color} at x {other.x:g}, "
                    f"y {other.y:g} cm): centres must be at least {apart:g} cm apart"
                )
                break
        else:
            for cls, half in bins:
                dx = max(abs(obj.x - cls.bin_cm[0]) - half, 0.0)
                dy = max(abs(obj.y - cls.bin_cm[1]) - half, 0.0)
                if math.hypot(dx, dy) < r:
                    problems.append(
                        f"{what}: inside {cls.name}'s bin (a {2 * half:.1f} cm square, walls "
                        f"included, centred at x {cls.bin_cm[0]:g}, y {cls.bin_cm[1]:g} cm): "
                        f"an object stands at least its radius ({r:g} cm) outside every bin"
                    )
                    break
    if problems:
        more = f" (+{len(problems) - 1} more)" if len(problems) > 1 else ""
        raise SceneError(problems[0] + more)
    _check_walls(config, scene, source)


def _check_walls(config: Config, scene: Sequence[SceneObject], source: str) -> None:
    """Refuse a table whose objects, the belt's too, grow a bin's walls past what the arm allows."""
    colors = [o.color for o in scene]
    what = f"{source}: " if scene else ""
    problem = _release_below_walls(config, colors)
    if problem is not None:
        from mearm.sim.twin.twin_scene_check import fewer_objects  # noqa: PLC0415  (MuJoCo)

        fewer = fewer_objects(_table_of(config, colors))
        raise SceneError(f"{what}{problem}; raise bin_cm z (task.classes), or {fewer}")
    problem = _walls_by_home(config, colors)
    if problem is not None:
        raise SceneError(f"{what}{problem}: give the class fewer objects")
    problem = _walls_shut_bin(config, colors)
    if problem is not None:
        raise SceneError(f"{what}{problem}: give the class fewer objects{_LOWER_WALLS}")
    problem = _walls_block_belt(config, colors)
    if problem is not None:
        raise SceneError(
            f"{what}{problem}: bring fewer objects (belt.arrivals.count){_LOWER_WALLS}"
        )


def _most_the_walls_take(config: Config, n: int, seed: int, *, table_too: bool = False) -> int:
    """The most objects, below ``n`` (which they refuse), whose walls the checks pass.

    More objects never lower a wall (the classes are drawn in turn), so the answer is
    bisected: a few tables built, not one per number below ``n``. ``table_too``: walls
    that shut the table are checked too (:func:`_walls_shut_table`).
    """
    good, bad = 0, n
    while bad - good > 1:
        mid = (good + bad) // 2
        if _walls_problem(config, _class_order(config, mid, seed), table_too=table_too) is None:
            good = mid
        else:
            bad = mid
    return good


def _walls_problem(config: Config, colors: Sequence[str], *, table_too: bool = False) -> str | None:
    """Why a table of objects of ``colors`` grows a bin's walls past what the arm allows.

    ``table_too``: or shuts every way from home to the table (:func:`_walls_shut_table`,
    the last: a layout asks it only once it holds every object).
    """
    checks = [_release_below_walls, _walls_by_home, _walls_shut_bin]
    for check in [*checks, _walls_shut_table] if table_too else checks:
        problem = check(config, colors)
        if problem is not None:
            return problem
    return None


def _grown(config: Config, table: TableContents) -> list[ColorClass]:
    """The classes whose bins ``table`` builds taller walls for than the config's own table."""
    own = TableContents.of(config.task, config.belt)
    return [
        c
        for c in config.task.classes
        if wall_height_m(c, table.objects(c.name)) > wall_height_m(c, own.objects(c.name))
    ]


def _walls_by_home(config: Config, colors: Sequence[str]) -> str | None:
    """Walls grown for a table of objects of ``colors`` that the arm at home comes too near.

    Both simulators build each bin's walls to hold the table's objects of its class
    stacked (:func:`~mearm.kinematics.bodies.wall_height_m`); a table with more of a
    class than the config's own raises them, and beside a bin close to home (the paper
    arm's jaws hang beside the red bin there) they may come within ``task.clearance_cm``
    of the arm at home, where every run starts and ends: the arm could not go home, and
    no route would leave it. The config's own table passed the same check when it
    loaded (:func:`~mearm.task.check.check_consistency`); ``None``: no wall grew, or the
    arm keeps its clearance.
    """
    table = _table_of(config, colors)
    grown = [c.name for c in _grown(config, table)]
    if not grown:
        return None
    model = ArmModel(config.arm)
    bins = collision_model(config, model, clearance_cm=0.0, table=table)
    for name, part, distance in bins_near_home(config, model, bins):
        if name not in grown:
            continue
        n = table.objects(name)
        wall_cm = wall_height_m(config.task.class_named(name), n) / M_PER_CM
        # a distance below 0 is how far the walls reach into the arm (it read "come within
        # -0.65 cm"); one within TOUCH_CM of 0, to two decimals, touches it
        into = f"{-distance:.2f}"
        near = (
            f"reach into the arm at home ({part}) by {into} cm"
            if distance < 0 and into != "0.00"
            else f"touch the arm at home ({part})"
            if distance <= TOUCH_CM
            else f"come within {distance:.2f} cm of the arm at home ({part}), less than "
            f"task.clearance_cm ({config.task.clearance_cm:g} cm)"
            if distance < config.task.clearance_cm
            else f"come within {too_little_spare(distance, config)}, of the arm at home ({part})"
        )
        return (
            f"class {name}: its bin's walls, built {wall_cm:.3g} cm tall to hold its {n} "
            f"objects stacked, {near}"
        )
    return None


def _walls_shut_bin(config: Config, colors: Sequence[str]) -> str | None:
    """Walls of a table of objects of ``colors`` that leave the arm no way into a bin.

    A bin's walls may stand too tall for the arm to carry an object over them: walls grown
    for more objects of its class than the config's own table holds
    (:func:`~mearm.kinematics.bodies.wall_height_m`; the MeArm v1's red bin, 6 cm for three
    objects where the release is 6 cm up, is then out of reach both straight and over the
    top, and a sort of ``--random 7`` went on to leave 5 of its 7 objects, each after its
    pick), or walls that stand above the bottom of an object held at the release (the
    config's own table with three reds: a sort of it left each red after its pick; walls
    given a ``bin_height_cm`` stand below it, or the config is refused at load). A place
    of each such class is planned from home, one of its objects held, against the bins
    alone (the objects on the table change as the sort goes; the bins do not), as the
    sorter plans it; the twin refuses a release below the walls first
    (:func:`_release_below_walls`). ``None``: no such walls, or each of their bins is
    reached.
    """
    table = _table_of(config, colors)
    grown = {c.name for c in _grown(config, table)}
    above = config.arm.tool.tcp_above_grip_cm
    tall = [
        c
        for c in config.task.classes
        if c.name in grown
        or wall_height_m(c, table.objects(c.name)) / M_PER_CM > c.bin_cm[2] - c.grip_z_cm - above
    ]
    if not tall:
        return None
    model = ArmModel(config.arm)
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm, table=table)
    planner = Planner(config, model, collision)
    for cls in tall:
        collision.set_world([], opening_cm=cls.diameter_cm, held=(cls.name, cls.name))
        route = Route(cls.name, cls.name, "place", 1, planner.place_target(cls))
        planner.plan(route, model.home)
        if route.planned:
            continue
        n = table.objects(cls.name)
        wall_cm = wall_height_m(cls, n) / M_PER_CM
        return (
            f"class {cls.name}: its bin's walls, built {wall_cm:.3g} cm tall to hold its {n} "
            f"objects stacked, leave the arm no way in with one held, even from home "
            f"({route.failure})"
        )
    return None


#: Points across the camera's table field, per side, that a pick from home is planned to by
#: :func:`_walls_shut_table`.
TABLE_CHECK_POINTS = 7


def _walls_shut_table(config: Config, colors: Sequence[str]) -> str | None:
    """Walls grown for a table of objects of ``colors`` that shut every way from home to it.

    A pick of each class on the table is planned from home, as :func:`_way_in_check`
    plans it (against the bins alone), to a :data:`TABLE_CHECK_POINTS` square grid over
    the camera's field, the points it reaches clear of the bins. Where none is planned and
    a grown bin's wall stops one (its walls met as the arm leaves home), an object of the
    class drawn anywhere is all but sure to have no way in, and a layout draws such
    objects again until its draws run out: ``sim --random 34 --seed 34345``
    (``green.diameter_cm=2.34``, ``blue.height_cm=2.20``: 13 cm walls for 12 reds beside
    home) planned a pick for most draws of the four layouts of 20,000 its refusal drew,
    each stopped by the red bin's walls (over 5 minutes, to say nothing of them); with 28
    objects, 39 of the 42 points plan, and with 30, the count it now names, the sort is
    whole. ``None``: no wall grew, a pick of each class is planned, or what stops them is
    no grown bin's wall. The check draws nothing: a layout's ``rng`` is untouched.
    """
    table = _table_of(config, colors)
    grown = {c.name for c in _grown(config, table)}
    if not grown:
        return None
    diameter, (x0, x1, y0, y1) = _scene_field(config, any_objects=False)
    if not (x0 < x1 and y0 < y1):
        return None  # (no field: the layout says so)
    reach = _reach_check(config)
    model = ArmModel(config.arm)
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm, table=table)
    collision.set_world([])
    planner = Planner(config, model, collision)
    gap = diameter / 2 + MIN_GAP_CM
    points = [
        (float(x), float(y))
        for x in np.linspace(x0, x1, TABLE_CHECK_POINTS)
        for y in np.linspace(y0, y1, TABLE_CHECK_POINTS)
        if not any(_near_bin(c, float(x), float(y), gap) for c in config.task.classes)
    ]
    for cls in config.task.classes:
        if not table.objects(cls.name):
            continue
        failures = []
        for x, y in points:
            if reach(cls, x, y) is None:
                continue
            route = Route("", cls.name, "pick", 1, planner.pick_target(cls, x, y))
            if planner.plan(route, model.home).planned:
                break
            failures.append(route.failure or "")
        else:
            stopped = _walls_that_stop(config, table, failures, grown)
            if stopped is None:
                continue
            walls, first = stopped
            return (
                f"{walls} table (a pick of a {cls.name} object planned to each of "
                f"{len(failures)} points across the camera's field: {first})"
            )
    return None


def _walls_that_stop(
    config: Config, table: TableContents, failures: Sequence[str], among: set[str] | None = None
) -> tuple[str, str] | None:
    """The first bin (of ``among``, default any) whose wall stopped one of ``failures``.

    Its words, up to where the arm has no way from home to (``"class red: its bin's walls,
    built 13 cm tall to hold its 12 objects stacked, leave the arm no way from home to the"``),
    and the first failure it stopped; ``None`` where no bin's wall stopped one.
    """
    for c in config.task.classes:
        if among is not None and c.name not in among:
            continue
        first = next((f for f in failures if bin_name(c.name) in f), None)
        if first is not None:
            n = table.objects(c.name)
            return (
                f"class {c.name}: its bin's walls, built {wall_height_m(c, n) / M_PER_CM:.3g} cm "
                f"tall to hold its {n} objects stacked, leave the arm no way from home to the",
                first,
            )
    return None


#: Points along a belt, its upstream end to its downstream one, that a pick from home is
#: planned to by :func:`_walls_block_belt`.
BELT_CHECK_POINTS = 5


def _walls_block_belt(config: Config, colors: Sequence[str]) -> str | None:
    """Walls grown for what a belt brings that leave the arm no way from home to the belt.

    A pick from home is planned to :data:`BELT_CHECK_POINTS` points along the belt's
    middle line, against the bins alone; where none is planned and a grown bin's wall
    stops one, the run could pick nothing: ``--set belt.arrivals.count=45`` on the
    kinematic belt (seed 22102: 13 cm walls for 12 reds beside home) planned and refused
    every one of its 45 picks, ``sorted 0 of 45``, where 44 sort whole. ``None``: no belt,
    a pick there is planned, or what stops them is no bin's wall. A belt's config holds its
    count, so its walls are its own table's: the check runs at every belt's start (5
    plans).
    """
    if config.belt is None:
        return None
    table = _table_of(config, colors)
    from mearm.sim.belt import Belt  # noqa: PLC0415  (a belt's start only)

    model = ArmModel(config.arm)
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm, table=table)
    planner = Planner(config, model, collision)
    collision.set_world([])
    belt = Belt(config.belt)
    cls = config.task.classes[0]
    failures = []
    for along in np.linspace(0.0, config.belt.length_cm, BELT_CHECK_POINTS):
        x, y = belt.point_cm(float(along), 0.0)
        route = Route("", cls.name, "pick", 1, planner.pick_target(cls, x, y))
        if planner.plan(route, model.home).planned:
            return None
        failures.append(route.failure or "")
    stopped = _walls_that_stop(config, table, failures)
    if stopped is None:
        return None
    walls, first = stopped
    return f"{walls} belt (a pick planned to each of {BELT_CHECK_POINTS} points along it: {first})"


def _release_below_walls(config: Config, colors: Sequence[str]) -> str | None:
    """The twin's refusal of a table whose objects outgrow a bin's walls, or ``None``.

    The twin (``simulator: mujoco``) builds each bin's walls to hold its class's objects
    stacked; a class with many objects gets walls above its release height, and the twin
    would refuse the table as it builds it, after the run log was opened
    (:func:`~mearm.sim.twin.twin_scene_check.release_below_walls`). The kinematic
    simulator grows the same walls, but a release below their top is planned and checked
    as any move there, and lowers the object in (``sim_shapes``' own 4 red cubes: 7.5 cm
    walls over a release 7.24 cm up, sorted whole): this rule is the twin's alone.
    """
    if config.simulator != "mujoco":
        return None
    from mearm.sim.twin.twin_scene_check import release_below_walls  # noqa: PLC0415  (MuJoCo)

    return release_below_walls(config, _table_of(config, colors))


def _table_of(config: Config, colors: Sequence[str]) -> TableContents:
    """The table a scene of objects of ``colors`` lays out, with what the belt brings."""
    names = config.task.class_names
    belt = TableContents.of(config.with_scene([]).task, config.belt).belt
    counts = {n: sum(1 for c in colors if c == n) for n in names}
    return TableContents(tuple(config.task.classes), counts, belt)


def _check_something_to_sort(config: Config, source: str) -> None:
    """Refuse an empty table that no belt brings objects to (:func:`check_scene`)."""
    belt = config.belt
    if belt is None:
        # the config's own table empty (a real rig's config run on the simulated camera):
        # the sort's own ways to lay one out
        lay = "; or lay one out with --random N or --scene FILE" if source == "task.scene" else ""
        raise SceneError(
            f"{source}: no objects: nothing to sort (a scene holds 1 to {MAX_SCENE_OBJECTS} "
            f"objects {{color, x, y}}{lay})"
        )
    if belt.arrivals.count == 0:
        raise SceneError(
            "belt.arrivals.count: 0: the belt brings nothing to sort (it must bring 1 to "
            f"{MAX_ARRIVALS} objects)"
        )


#: What a random scene's picks keep from bins and neighbours beyond the clearance [cm]:
#: the twin's camera locates a 1 cm tall object off where it stands (its top face seen in
#: perspective from a calibration on the table: 0.31-0.39 cm beside the bins, up to about
#: 0.49 cm at the field's corners), and the pick is planned where it is seen. Where that
#: eats this margin beside a bin's wall, the pick moves off the wall within the jaws' room
#: (:meth:`mearm.task.pick_place.PickAndPlace._off_the_wall`); the margin stays, as every
#: random scene is drawn with it.
FOOTPRINT_MARGIN_CM = 0.3
#: Draws for one object before a layout that leaves it no room starts again.
PER_OBJECT_DRAWS = 1000
#: Draws of a class whose own pick puts the tool in the table, none of the class placed,
#: after which the class is refused: its pick height puts the tool there wherever it
#: stands (were it clear at some tenth of the field, this many draws would all miss it
#: once in 10⁹ seeds).
TABLE_ONLY_DRAWS = 200


def camera_field_cm(
    config: Config, margin_cm: float, border_px: float = 0.0
) -> tuple[float, float, float, float]:
    """The table area the camera sees, shrunk by ``margin_cm``: (x_min, x_max, y_min, y_max).

    Computed from the calibration homography at the image's corners, ``border_px`` in
    from its edges (an axis-aligned box inside the imaged quadrilateral).
    """
    H_inv = np.asarray(config.calibration.homography, dtype=float)
    w, h, b = config.camera.width_px, config.camera.height_px, border_px
    corners = np.array([[b, b, 1], [w - b, b, 1], [w - b, h - b, 1], [b, h - b, 1]], dtype=float)
    xy = corners @ H_inv.T
    xy = xy[:, :2] / xy[:, 2:3]
    xs, ys = np.sort(xy[:, 0]), np.sort(xy[:, 1])
    # the inner box of a (near-)rectangle: second smallest and second largest
    return (xs[1] + margin_cm, xs[2] - margin_cm, ys[1] + margin_cm, ys[2] - margin_cm)


def _reach_check(config: Config) -> Callable[[ColorClass, float, float], np.ndarray | None]:
    """A test whether an object of a class at (x, y) can be picked: its pick pose, or None.

    Its pick point (and, with ``task.approach_height_cm``, the point above it) must lie in
    the box and be solved: by the closed form where the arm has one, else planned from
    home by the default solver. A target the links' lengths, or they and the anchor
    joint's limits, put beyond every pose's reach (:class:`~mearm.ik.reach.ReachBound`)
    is refused before it is planned: no pose within the limits meets the solver's
    stopping rule, so the plan could only fail, slowly (its direct solve to the cap, then
    the multi-start); the answer is the plan's.
    """
    closed_form = closed_form_for(config.arm)
    height = config.task.approach_height_cm
    model = ArmModel(config.arm)
    checks = Planner(config, model)  # a pose's limits and pulse ranges
    planner = None if closed_form is not None else checks
    bound = ReachBound(model, config.controller.tolerance_cm2, APPROACH_TOLERANCE_DEG)

    def reach(cls: ColorClass, x: float, y: float) -> np.ndarray | None:
        z = cls.grip_z_cm + config.arm.tool.tcp_above_grip_cm
        heights = [z] if height is None else [z, z + height]
        pose = None
        for zz in heights:
            try:
                check_in_box((x, y, zz), config.arm)
                if closed_form is not None:
                    q = closed_form.solve((x, y, zz))
                    if not checks.pose_allowed(q):  # a servo over a combination, say
                        return None
                    pose = q if pose is None else pose
            except MearmError:
                return None
            if planner is not None:
                target = planner.pick_target(cls, x, y)
                if zz != z:
                    target = planner.above_target(target, zz - z)
                # (in metres as the solver's own test has it: :meth:`PdPij._recover`)
                metres = (np.asarray(target.position_cm, dtype=float) / CM_PER_M).tolist()
                if bound.beyond_limits(metres, target.approach):
                    return None
                route = Route("", cls.name, "pick", 1, target)
                if not planner.plan(route, model.home).planned:
                    return None
                if pose is None and route.plan is not None:
                    pose = route.plan.q
        return pose

    return reach


def _footprint_check(
    config: Config, table: TableContents
) -> Callable[
    [list[SceneObject], list[np.ndarray], SceneObject, np.ndarray], tuple[str, str] | None
]:
    """A test whether a new object keeps every pick clear of the arm's body.

    The test gives ``None`` where it does, else the arm's part and what it comes too close
    to: the new object's own pick's first, then each placed object's.

    With the jaws open at each object's pick pose, the whole tool (jaws, hand, servo) keeps
    ``task.clearance_cm`` and :data:`FOOTPRINT_MARGIN_CM` (the camera's error in locating
    an object, a route's way down) from every bin and every other object: both the new
    object's pick among those placed, and each placed object's pick with the new one
    beside it (:class:`~mearm.kinematics.collision.CollisionModel`). The bins' walls are
    those of ``table``, the one being laid out (they grow with its objects of each class).
    """
    model = ArmModel(config.arm)
    margin = config.task.clearance_cm + FOOTPRINT_MARGIN_CM
    collision = collision_model(config, model, clearance_cm=margin, table=table)
    plain: list[CollisionModel] = []  # the sort's clearance, made when first needed
    # an object's pick from its own object: None (clear), or the part that comes too near
    own_hit: dict[tuple[str, float, float], tuple[str, str] | None] = {}

    def pick_clear(
        objects: list[tuple[str, str, float, float]], i: int, q: np.ndarray
    ) -> tuple[str, str] | None:
        """Object ``i``'s pick at ``q``: its own object kept at the sort's clearance only.

        The margin is for where the camera places an object, and the pick goes where the
        camera places it: the tool stands where it stands to its own object whatever the
        error (a 4.5 cm tall cylinder gripped 1.5 cm up, the hand above its top, was
        refused at every place, ``at most 1 fit``, though the sort picks it). So where
        the nearest at the margin is its own object, the others are checked at the
        margin without it, and it at the sort's clearance (once an object).
        """
        oid = objects[i][0]
        gap, part, what = collision.gap(q, target=oid)
        if gap >= TOUCH_M or what != object_name(oid):
            return None if gap >= TOUCH_M else (part, what)
        collision.set_world(objects[:i] + objects[i + 1 :])
        gap, part, what = collision.gap(q)
        collision.set_world(objects)
        if gap < TOUCH_M:
            return part, what
        key = objects[i][1:]
        if key not in own_hit:
            if not plain:
                plain.append(collision_model(config, model, table=table))
            plain[0].set_world([objects[i]])
            own_gap, own_part, own_what = plain[0].gap(q, target=oid)
            own_hit[key] = None if own_gap >= TOUCH_M else (own_part, own_what)
        return own_hit[key]

    def clear(
        placed: list[SceneObject], poses: list[np.ndarray], new: SceneObject, q: np.ndarray
    ) -> tuple[str, str] | None:
        objects = [(f"o{i}", o.color, o.x, o.y) for i, o in enumerate([*placed, new])]
        collision.set_world(objects)
        for i, pose in [(len(placed), q), *enumerate(poses)]:
            hit = pick_clear(objects, i, pose)
            if hit is not None:
                return hit
        return None

    return clear


def _way_in_check(
    config: Config, table: TableContents
) -> Callable[[ColorClass, float, float], bool] | None:
    """A test whether the arm at home has a way to a pick at (x, y) past the bins' walls.

    ``None`` where no bin's walls grow past the config's own table's (:func:`_grown`): the
    way in is then the config's own sort's. Where they grow, a pick pose may keep the tool
    clear of every wall while every way to it meets one: the paper arm's home hangs the
    jaws over the red bin, and ``sim --random 44 --seed 22001`` laid out two greens by the
    table's near edge that the sort left, from home and from over every bin, ``no route
    clear of collisions``. The pick is planned from home as the sort plans it (straight,
    else over the top), against the bins alone: the objects on the table change as the
    sort goes, the bins do not. A plan a candidate: :func:`random_scene` asks it of a
    whole layout's objects only, and of the draws that replace those it refuses.
    """
    if not _grown(config, table):
        return None
    model = ArmModel(config.arm)
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm, table=table)
    collision.set_world([])
    planner = Planner(config, model, collision)

    def way_in(cls: ColorClass, x: float, y: float) -> bool:
        route = Route("", cls.name, "pick", 1, planner.pick_target(cls, x, y))
        return planner.plan(route, model.home).planned

    return way_in


def _near_bin(cls: ColorClass, x: float, y: float, clearance_cm: float) -> bool:
    """Whether (x, y) lies within ``clearance_cm`` of the bin's square footprint."""
    half = cls.bin_inner_width_cm / 2 + clearance_cm
    return abs(x - cls.bin_cm[0]) <= half and abs(y - cls.bin_cm[1]) <= half


def _whole(n: object) -> bool:
    """Whether ``n`` is a whole number (an int or a NumPy integer, not a bool)."""
    return isinstance(n, int | np.integer) and not isinstance(n, bool)


def _class_order(config: Config, counts: dict[str, int] | int, seed: int) -> list[str]:
    """The class of each object to draw, in drawing order; SceneError on a bad count or seed."""
    whole = _whole(counts)
    if not (whole or (isinstance(counts, dict) and all(_whole(n) for n in counts.values()))):
        raise SceneError(
            "the number of objects must be a whole number, or one per class name "
            f"({{'red': 2, …}}), got {short_repr(counts)}"
        )
    if not _whole(seed):
        raise SceneError(
            f"the seed must be a whole number in [0, {MAX_SEED}], got {short_repr(seed)}"
        )
    if whole:
        counts = int(counts)  # type: ignore[arg-type]  # (a NumPy integer too)
    wanted = [counts] if isinstance(counts, int) else list(counts.values())
    if any(n < 0 for n in wanted) or sum(wanted) > MAX_SCENE_OBJECTS:
        raise SceneError(
            f"the number of objects must be ≥ 0 and at most {MAX_SCENE_OBJECTS} in all, "
            f"got {short_repr(counts)}"
        )
    if not 0 <= seed <= MAX_SEED:
        raise SceneError(f"the seed must be in [0, {MAX_SEED}], got {short_repr(seed)}")
    if isinstance(counts, int):
        names = config.task.class_names
        order = [names[i % len(names)] for i in range(counts)]
    else:
        unknown = sorted(set(counts) - set(config.task.class_names))
        if unknown:
            raise SceneError(f"no class {unknown}; classes: {', '.join(config.task.class_names)}")
        order = [c for c in config.task.class_names for _ in range(counts.get(c, 0))]
    return order


def _scene_field(
    config: Config, *, any_objects: bool
) -> tuple[float, tuple[float, float, float, float]]:
    """The largest object diameter and the camera field (x0, x1, y0, y1) one diameter in [cm]."""
    # (a cube's or a prism's: the circle around it, whatever its yaw)
    diameter = max(2 * c.footprint_radius_cm for c in config.task.classes)
    x0, x1, y0, y1 = camera_field_cm(config, margin_cm=diameter)
    if any_objects and not (x0 < x1 and y0 < y1):
        raise SceneError(
            f"the camera sees no table area for {diameter:g} cm objects (a margin of one "
            "diameter inside the calibrated frame): check camera.width_px, camera.height_px, "
            "calibration.homography and the classes' diameter_cm"
        )
    return diameter, (x0, x1, y0, y1)


def _min_centre_distance_cm(config: Config, diameter_cm: float) -> float:
    """How far apart two objects' centres must be [cm].

    The open jaws come down around an object: a neighbour must stay clear of their outer
    faces (open_cm / 2 + jaw_thickness_cm from the centre), or picking one object pushes,
    tips or traps the next.
    """
    g = config.arm.tool.gripper
    return max(diameter_cm + MIN_GAP_CM, g.open_cm / 2 + g.jaw_thickness_cm + diameter_cm / 2)


def _candidate(
    config: Config,
    color: str,
    x: float,
    y: float,
    rng: np.random.Generator,
    placed: list[SceneObject],
    poses: list[np.ndarray],
    *,
    min_dist: float,
    diameter: float,
    reach: Callable[[ColorClass, float, float], np.ndarray | None],
    margins: np.ndarray,
    footprint: Callable[
        [list[SceneObject], list[np.ndarray], SceneObject, np.ndarray], tuple[str, str] | None
    ],
    in_table: dict[str, tuple[str, str]],
    way_in: Callable[[ColorClass, float, float], bool] | None = None,
    failed: Counter[tuple[str, ...]] | None = None,
    in_area: Callable[[float, float, float], bool] | None = None,
) -> tuple[SceneObject, np.ndarray] | None:
    """A ``color`` object at (x, y) and its pick pose, or ``None`` if it may not stand there.

    It keeps clear of the objects placed and the bins, and is reachable around (x, y); a
    cube's or a prism's yaw is drawn from ``rng`` only once it is reachable. A pick of
    its own that puts the tool in the table notes the part that goes in, in ``in_table``
    under the class.

    The cheap tests run first, the answer and ``rng``'s draws the same whatever their
    order: the gaps, the pick's reach at (x, y) (its pose), then for a disc (no yaw
    drawn) the footprint, whose refusal by a bin or an object needs no margin planned;
    the margins last, farthest from the base first (beyond reach, the first to fail).
    The footprint takes no yaw (:func:`_footprint_check`).

    ``in_area``: whether it lies whole in ``vision.work_area_px`` (:func:`_work_area_test`;
    ``None``: no polygon), tested first: one outside it is never seen.

    ``failed``: counts the test a refused draw failed, by its key (``("work area",)``,
    ``("apart",)``, ``("bin",)``, ``("reach",)``, ``("footprint", part, what)``, ``("margins",)``,
    ``("way in",)``), for a refusal to say why (:func:`_none_fit`).
    """
    why = failed if failed is not None else Counter()
    if in_area is not None and not in_area(
        config.task.class_named(color).footprint_radius_cm, x, y
    ):
        why["work area",] += 1
        return None
    if any(np.hypot(o.x - x, o.y - y) < min_dist for o in placed):
        why["apart",] += 1
        return None
    if any(_near_bin(c, x, y, diameter / 2 + MIN_GAP_CM) for c in config.task.classes):
        why["bin",] += 1
        return None
    cls = config.task.class_named(color)
    q = reach(cls, x, y)
    if q is None:
        why["reach",] += 1
        return None
    new = SceneObject(color=color, x=x, y=y)
    symmetry = cls.object_shape.symmetry_deg
    own = object_name(f"o{len(placed)}")  # the new object's name in the footprint's world
    hit = None if symmetry else footprint(placed, poses, new, q)
    if hit is not None and hit[1] != "table":
        if hit[1] == own:  # its own pick meets it: so at every place (no margin needed)
            in_table[color] = (hit[0], "object")
        why["footprint", *hit] += 1
        return None  # (refused whether or not the margins are reached: no yaw drawn)
    around = [(x + float(dx), y + float(dy)) for dx, dy in margins]
    around.sort(key=lambda p: -math.hypot(*p))  # (a stable sort: ties keep their order)
    if not all(reach(cls, mx, my) is not None for mx, my in around):
        why["margins",] += 1
        return None
    if symmetry:  # a cube or a prism lies at any yaw (a disc draws none)
        new = new.model_copy(update={"yaw_deg": round(rng.uniform(0, symmetry), 1)})
        hit = footprint(placed, poses, new, q)
    if hit is not None:
        # its own pick, wherever it stands (the placed objects' picks were clear of the
        # table already, and each names its own object, not this one)
        if hit[1] in ("table", own):
            in_table[color] = (hit[0], "table" if hit[1] == "table" else "object")
        why["footprint", *hit] += 1
        return None
    if way_in is not None and not way_in(cls, x, y):  # (the last test: a plan)
        why["way in",] += 1
        return None
    return new, q


def _none_fit(
    config: Config,
    failed: Counter[tuple[str, ...]],
    field: tuple[float, float, float, float],
    diameter: float,
    order: Sequence[str],
) -> str:
    """Why no draw of a table that held none stood: ``": …"``, after ``none fit …``.

    :func:`_candidate`'s tests sieve the draws in turn: clear of the bins, the pick
    reached, the tool's footprint clear, reached around (with none placed, no draw met
    a neighbour or wanted a way in). The draws fall evenly over the camera's field, so
    each test's share of them is its share of the field: each is named, in turn, with
    the part of the tool and what it met most often at the footprint. Where the bins
    took the most (their squares, or the tool at their walls), smaller bins are named
    (the MeArm v1 scaled by half, its bins not: ``--random 12`` with seed 31001 placed
    none, and with 2.25 cm bins, 3).
    """
    total = sum(failed.values())
    if not total:
        return ""

    def share(n: int) -> str:
        p = 100 * n / total
        return f"{p:.0f} %" if p >= 1 or p == 0 else f"{p:.1g} %"

    x0, x1, y0, y1 = field
    near, unreached, around = failed["bin",], failed["reach",], failed["margins",]
    outside = failed["work area",]
    hits = Counter({key[1:]: n for key, n in failed.items() if key[0] == "footprint"})
    above = config.arm.tool.tcp_above_grip_cm
    heights = sorted({config.task.class_named(c).grip_z_cm + above for c in order})
    said = f": of the camera's table field (centres x {x0:.3g}…{x1:.3g}, y {y0:.3g}…{y1:.3g} cm), "
    if outside:
        said += (
            f"{share(outside)} lies outside the work area (vision.work_area_px: "
            f"{extent(config.vision.work_area_px or [])}), where nothing is detected, and "
        )
    if near:
        gap = diameter / 2 + MIN_GAP_CM
        said += (
            f"{share(near)} lies within {gap:.3g} cm of a bin's square, where no object "
            "stands, and "
        )
    said += (
        f"the arm reaches {share(total - outside - near - unreached)}"
        f"{' outside those' if near or outside else ''} "
        f"at the pick height{'s' if len(heights) > 1 else ''} "
        f"{', '.join(f'{z:.3g}' for z in heights)} cm"
    )
    if hits:
        (part, what), _ = hits.most_common(1)[0]
        if object_of(what) is not None:  # (none placed: the object it picks)
            what = "the object it picks"
        where = f"at {share(hits.total())} of the field" if around else "at every pick there"
        said += (
            f"; {where} the tool comes within "
            f"{config.task.clearance_cm + FOOTPRINT_MARGIN_CM:g} cm (task.clearance_cm and "
            f"the camera's {FOOTPRINT_MARGIN_CM:g} cm) of a bin, the table or the object "
            f"(most often: its {part}, at {what})"
        )
    if around:
        where = f"at {share(around)} of the field" if hits else "every pick there is"
        said += (
            f"; {where} reached, but not {FOOTPRINT_MARGIN_CM:g} cm around, where the "
            "camera may see it"
        )
    at_bins = sum(n for (_, what), n in hits.items() if class_of(what) is not None)
    if near + at_bins > max(unreached, hits.total() - at_bins, around):
        widths = sorted({c.bin_inner_width_cm for c in config.task.classes})
        said += (
            ": smaller bins leave the arm room (task.classes' bin_width_cm, now "
            f"{', '.join(f'{w:g}' for w in widths)} cm)"
        )
    return said


def _grip_said(cls: ColorClass) -> str:
    """Where a class's objects are gripped, as its refusals name it: ``grip_height_cm 1.5``.

    A class without a ``grip_height_cm`` is gripped at half its height
    (:attr:`~mearm.config.classes.ColorClass.grip_z_cm`): formatting the ``None`` stopped
    ``mearm sort --config sim_5dof --random 9 --seed 34285 --set
    task.classes.green.height_cm=0.66`` with an unexpected error (a TypeError) where it
    meant to refuse the class (2026-12-07, simulated).
    """
    if cls.grip_height_cm is not None:
        return f"grip_height_cm {cls.grip_height_cm:g}"
    return f"grip_height_cm {cls.grip_z_cm:g} (unset: half its height_cm)"


def _tool_in_table(config: Config, color: str, hit: tuple[str, str], seed: int) -> str:
    """The refusal of a class whose pick put the tool in the table, none of it placed.

    Or in the object it picks (``hit``: the part, and ``"table"`` or ``"object"``): one
    taller than the open jaws reach above its grip meets the hand at every place (a 5 cm
    tall green gripped 1.5 cm up on the kinematic arm, refused as ``at most 1 fit``).
    """
    cls = config.task.class_named(color)
    above = config.arm.tool.tcp_above_grip_cm
    part, into = hit
    if into == "object":
        return (
            f"task.classes.{color}: an object {cls.height_cm:g} cm tall picked at "
            f"{_grip_said(cls)} comes within task.clearance_cm "
            f"({config.task.clearance_cm:g} cm) of the tool's {part} at its own pick, "
            f"at {TABLE_ONLY_DRAWS} places drawn with seed {seed}, and no {color} object "
            "was placed: the hand stands above the jaws; lower height_cm or raise "
            "grip_height_cm"
        )
    return (
        f"task.classes.{color}: picked at {_grip_said(cls)} (the TCP "
        f"{above:g} cm above it, arm.tool.tcp_above_grip_cm), the open jaws' {part} reaches "
        f"the table at {TABLE_ONLY_DRAWS} places drawn with seed {seed}, and no {color} "
        "object was placed: raise grip_height_cm"
    )


def random_scene(
    config: Config,
    counts: dict[str, int] | int,
    seed: int,
    *,
    max_tries: int = 20000,
    suggest: bool = True,
) -> list[SceneObject]:
    """Draw objects at least :data:`MIN_GAP_CM` apart in the reachable camera field.

    Centres are also at least ``open_cm / 2 + jaw_thickness_cm`` plus a radius apart, so
    the open jaws around one object clear its neighbours (1.5 cm edge to edge for the
    paper's 4 cm gripper).

    Objects keep the same gap from every bin's footprint (``ColorClass.bin_inner_width_cm``),
    and every pick keeps the whole tool clear of the bins and the other objects (the
    jaws open, the hand, the gripper's servo: :func:`_footprint_check`). Each object is
    reachable at eight points :data:`FOOTPRINT_MARGIN_CM` around where it stands, as the
    camera may see it there. Where the table grows a bin's walls, each pick of a whole
    layout is planned from home past them, and one that has no way in is drawn again
    (:func:`_way_in_check`).

    Args:
        config: Supplies the camera field (calibration), the pick height and the arm.
        counts: Objects per class, or a total split over the classes in turn.
        seed: Random seed; the same seed gives the same scene.
        max_tries: Give up after this many rejected draws.
        suggest: A refusal for too many objects names a count that lays out with
            ``seed`` (:func:`_fitting`: a few more layouts); ``False``: the most one
            layout held, unchecked (the check's own layouts).

    Raises:
        SceneError: a count below 0, more than :data:`~mearm.config.sections.MAX_SCENE_OBJECTS`
            objects, a seed outside [0, 2³² − 1], or the objects do not fit (it says how
            many one layout held: with the same seed, that many or fewer are placed; fewer
            where that many would grow a bin's walls past the arm; none: why, each test's
            share of the camera's field, :func:`_none_fit`); a class whose pick
            puts the tool in the table at :data:`TABLE_ONLY_DRAWS` places drawn, none of
            it placed, is named; walls grown to hold the objects stacked that the arm at
            home comes too near, that stand over the twin's release, that leave it no
            way from home to the table (:func:`_walls_shut_table`) or no way into a bin
            are named with how many objects they take.
    """
    order = _class_order(config, counts, seed)
    problem, remedy = _walls_before_layout(config, order)
    if problem is not None:
        raise _walls_refusal(config, counts, seed, max_tries, problem, remedy, suggest=suggest)
    rng = np.random.default_rng(seed)
    diameter, (x0, x1, y0, y1) = _scene_field(config, any_objects=bool(order))
    reach, in_area = _reach_check(config), _work_area_test(config)  # (where a draw may stand)
    min_dist = _min_centre_distance_cm(config, diameter)
    footprint = _footprint_check(config, _table_of(config, order))
    # where the camera may see it: the pick must be reachable there too
    angles = np.linspace(0.0, 2 * np.pi, 8, endpoint=False)
    margins = FOOTPRINT_MARGIN_CM * np.column_stack([np.cos(angles), np.sin(angles)])
    # most: the most objects one layout held: as many as the same seed is sure to place
    # kept: the most a whole layout kept once each had a way in (0: none held every object)
    tries = most = kept = 0
    in_table: dict[str, tuple[str, str]] = {}  # (:func:`_candidate`: the part the last draw
    # put in the table or its own object, and which)
    table_only = dict.fromkeys(order, 0)  # per class never placed: its picks in the table
    way_in = _way_in_check(config, _table_of(config, order))
    placed: list[SceneObject] = []
    poses: list[np.ndarray] = []
    failed: Counter[tuple[str, ...]] = Counter()  # what each refused draw failed
    whole = False  # a layout held every object: the walls' way to the table checked

    def draw(color: str, checked: Callable[[ColorClass, float, float], bool] | None) -> bool:
        """One ``color`` object placed among ``placed``; ``False``: no room for it."""
        nonlocal tries, most
        for _ in range(PER_OBJECT_DRAWS):
            tries += 1
            if tries > max_tries:
                fit = f"at most {most} fit" if most else "none fit"
                raise _TableFull(
                    f"could not place {len(order)} objects {min_dist - diameter:.3g} cm "
                    f"apart in the reachable camera field: {fit} in {max_tries} draws "
                    f"with seed {seed}"
                    + ("" if most else _none_fit(config, failed, (x0, x1, y0, y1), diameter, order))
                    + _fewer_than(config, counts, most, seed, max_tries if suggest else 0),
                    most,
                    # (redrawn: those placed each have a way in)
                    (max(kept, len(placed)) if checked is not None else kept) or most,
                )
            x, y = round(rng.uniform(x0, x1), 2), round(rng.uniform(y0, y1), 2)
            found = _candidate(
                config, color, x, y, rng, placed, poses,
                min_dist=min_dist, diameter=diameter, reach=reach, margins=margins,
                footprint=footprint, in_table=in_table, way_in=checked, failed=failed,
                in_area=in_area,
            )  # fmt: skip
            if found is None:
                hit = in_table.pop(color, None)
                if hit is not None and color in table_only:
                    table_only[color] += 1
                    if table_only[color] >= TABLE_ONLY_DRAWS:
                        raise SceneError(_tool_in_table(config, color, hit, seed))
                continue
            table_only.pop(color, None)  # one stood: the table is not in the way
            placed.append(found[0])
            poses.append(found[1])
            most = max(most, len(placed))
            return True
        return False

    while True:  # a layout whose first objects leave no room for the next starts again
        placed.clear()
        poses.clear()
        if not all(draw(color, None) for color in order):
            continue
        if way_in is None:
            break
        # planned: once the table is known to hold the objects, as the bins below
        whole = whole or _way_to_table(config, counts, seed, max_tries, order, suggest=suggest)
        # the way in past grown walls, once the layout is whole (a table too full never
        # plans one); an object with none is drawn again where it has one
        shut = [
            i
            for i, o in enumerate(placed)
            if not way_in(config.task.class_named(o.color), o.x, o.y)
        ]
        if not shut:
            break
        again = [placed[i].color for i in shut]
        for i in reversed(shut):
            del placed[i], poses[i]
        if all(draw(color, way_in) for color in again):
            break
        kept = max(kept, len(placed))
    rng.shuffle(placed)
    # planned, so checked once the table is known to hold the objects (a table too full
    # for them says so first, at once)
    problem = _walls_shut_bin(config, order)
    if problem is not None:
        raise _walls_refusal(
            config, counts, seed, max_tries, problem, _LOWER_WALLS, suggest=suggest
        )
    return placed


def _way_to_table(
    config: Config,
    counts: dict[str, int] | int,
    seed: int,
    max_tries: int,
    order: Sequence[str],
    *,
    suggest: bool,
) -> bool:
    """``True``, or :func:`random_scene`'s refusal of walls that shut the table (a plan).

    Asked once a layout first held every object (:func:`_walls_shut_table`): a table
    too full for them says so first, at once, as before the check.
    """
    problem = _walls_shut_table(config, order)
    if problem is not None:
        raise _walls_refusal(
            config, counts, seed, max_tries, problem, _LOWER_WALLS, suggest=suggest, table_too=True
        )
    return True


def _walls_before_layout(config: Config, order: Sequence[str]) -> tuple[str | None, str]:
    """Walls the table of ``order`` grows that refuse it before a layout, and the remedy.

    Over the twin's release, or by the arm at home: no plan, so before a layout.
    """
    problem = _release_below_walls(config, order)
    if problem is not None:
        return problem, ", or raise bin_cm z (task.classes)"
    return _walls_by_home(config, order), ""


def _fewer_than(
    config: Config, counts: dict[str, int] | int, most: int, seed: int, max_tries: int
) -> str:
    """What a table that held at most ``most`` of the objects asks for: that many, or fewer.

    Fewer where ``most`` objects (a total, drawn with ``seed``) would grow a bin's walls
    past the arm (:func:`_walls_problem`): as many as the table holds would be refused
    next, by the walls. A total is laid out before it is asked for (``max_tries`` draws
    each, :func:`_fitting`; 0: not): a count draws its own layout, and one that held 26
    of 500 did not hold 26 asked for (``sim_5dof``, seed 22014). Where the walls of one
    object stop it, no count is named: what stops it is (:func:`_walls_stop_all`).
    """
    if not most:
        return ""
    if isinstance(counts, int) and _walls_problem(config, _class_order(config, most, seed)):
        walls = _most_the_walls_take(config, most, seed)
        if not walls:  # one object's walls stop it already: no count does
            return f", but the bins' walls take none: {_walls_stop_all(config, seed)}"
        return (
            f", of which the bins' walls take {walls} (more grow a bin's walls past the "
            f"arm); ask for {_asked(config, walls, seed, max_tries)}"
        )
    if not isinstance(counts, int):
        return f"; ask for {most} or fewer"
    return f"; ask for {_asked(config, most, seed, max_tries)}"


def _walls_stop_all(config: Config, seed: int) -> str:
    """Why a table of one object (drawn with ``seed``) grows walls past the arm, and the way out.

    No count helps: walls stand at least two objects tall (and 2 cm,
    :func:`~mearm.kinematics.bodies.wall_height_m`) for one object as for none, and such
    walls may stand over the bottom of an object held at the release (the MeArm v1 scaled
    by half, its 1.5 cm objects not: 3 cm walls, a red held 1 cm up released 3 cm up,
    said ``ask for fewer than 0``). The way out is the check's own: the release raised,
    or the walls' height set (1.5 cm: 3 of those 12 laid out with seed 31001).
    """
    colors = _class_order(config, 1, seed)
    for check, remedy in (
        (_release_below_walls, "raise bin_cm z (task.classes)"),
        (_walls_by_home, ""),
        (_walls_shut_bin, "set the class's bin_height_cm (task.classes)"),
        (_walls_shut_table, "set the class's bin_height_cm (task.classes)"),
    ):
        problem = check(config, colors)
        if problem is not None:
            return f"{problem}: no number of objects fits" + (f"; {remedy}" if remedy else "")
    raise AssertionError("the walls of one object stop nothing")  # (_most_the_walls_take)


#: How many counts a refusal lays out, from the one it would name down, to name one that
#: lays out with the seed (each up to the refused layout's draws: kept few).
SUGGEST_TRIES = 3


def _fitting(
    config: Config, n: int, seed: int, max_tries: int
) -> tuple[int | None, tuple[int, int] | None]:
    """The most objects, ``n`` or fewer, that :data:`SUGGEST_TRIES` layouts find room for.

    Each layout that fails says how many it held, and the next asks for no more. Where a
    layout held them all but not each with a way in past the walls (:func:`_way_in_check`)
    and the tries run out, one more lays out the most such a layout kept with one:
    ``sim --random 500 --seed 45003`` held 47, and 47, 46 and 45 each held every object,
    kept 44 with a way in and drew the rest again until their draws ran out; the refusal
    said ``ask for fewer than 47``, and 46 named 44, which lays out. A layout that holds
    them all but whose walls shut every way from home to the table
    (:func:`_walls_shut_table`, asked only of a whole layout) is followed by the most its
    walls take with that way (:func:`_most_the_walls_take`), laid out in turn: once, and
    not as a try. ``sim --random 500 --seed 43031`` (``green.height_cm=1.5``) held 48,
    then laid out 47, whose 17 cm red walls shut the way; the refusal, taking that for no
    layout, said ``ask for fewer than 48``, and 47 and 46 were refused in turn (36 sort
    whole). ``None``: none of them was laid out. With it, ``(k, m)`` where ``k`` objects'
    walls shut the table and ``m`` objects' keep a way to it, or ``None``.
    """
    shut: tuple[int, int] | None = None
    tries = kept = 0  # kept: the most a layout that held every object kept with a way in
    while tries < SUGGEST_TRIES + bool(kept):
        if tries == SUGGEST_TRIES:  # (the one more)
            n = min(n, kept)
        if n <= 0:
            return None, shut
        try:
            random_scene(config, n, seed, max_tries=max_tries, suggest=False)
        except _TableFull as full:
            n = min(n - 1, full.most)
            kept = max(kept, full.kept) if full.kept < full.most else kept
            tries += 1
            continue
        except _TableShut:
            if shut is not None:  # (fewer than the walls take shut it too: name no count)
                return None, shut
            most = _most_the_walls_take(config, n, seed, table_too=True)
            shut, n = (n, most), most
            continue
        except SceneError:
            return None, shut
        return n, shut
    return None, shut


def _shut_said(shut: tuple[int, int], fits: int | None) -> str:
    """What :func:`_fitting`'s ``shut`` says: whose walls shut the table, whose do not.

    Then, where ``fits`` is not the count whose walls keep the way, that that count does
    not lay out (and what does).
    """
    k, m = shut
    said = f"the walls of {k} leave the arm no way from home to the table"
    if not m:
        return said + ", as those of any number do"
    said += f", those of {m} leave one"
    if fits is None:
        return said + f", and {m} asked for does not lay out"
    if fits != m:
        return said + f", and {m} asked for does not lay out, {fits} does"
    return said


def _asked(config: Config, n: int, seed: int, max_tries: int) -> str:
    """``N or fewer``: ``n`` if it lays out with ``seed`` (:func:`_fitting`), else what does."""
    if not max_tries:
        return f"{n} or fewer"
    fits, shut = _fitting(config, n, seed, max_tries)
    if shut is not None:
        first = "" if shut[0] == n else f"{n} asked for does not lay out with seed {seed}, and "
        said = first + _shut_said(shut, fits)
        if fits is not None:
            return f"{fits} or fewer ({said})"
        return f"fewer than {shut[1]} ({said})" if shut[1] else f"none ({said})"
    if fits == n:
        return f"{n} or fewer"
    if fits is None:
        return f"fewer than {n} ({n} asked for does not lay out with seed {seed})"
    return f"{fits} or fewer ({n} asked for does not lay out with seed {seed}, {fits} does)"


def _walls_take(
    config: Config, n: int, seed: int, max_tries: int, *, table_too: bool
) -> tuple[int, _TableFull | None]:
    """The most objects below ``n`` the walls take, and a layout's refusal of that many.

    ``None``: that many laid out (or none taken). Where their walls shut the table, which
    a layout finds once it holds them all, fewer are taken (``table_too``).
    """
    most = _most_the_walls_take(config, n, seed, table_too=table_too)
    if not most:
        return 0, None
    try:
        random_scene(config, most, seed, max_tries=max_tries, suggest=False)
    except _TableFull as full:
        return most, full
    except _TableShut:
        if table_too:  # (the bisection asked the same check of the same table)
            raise
        return _walls_take(config, most, seed, max_tries, table_too=True)
    return most, None


def _walls_refusal(
    config: Config,
    counts: dict[str, int] | int,
    seed: int,
    max_tries: int,
    problem: str,
    remedy: str,
    *,
    suggest: bool = True,
    table_too: bool = False,
) -> SceneError:
    """:func:`random_scene`'s refusal of walls grown past the arm: ``problem``, then fewer.

    For a total, the most objects the walls take and the table holds with ``seed`` (as
    many as the walls take may not fit); for counts per class, fewer of the class. Then
    ``remedy``, the other way out. ``suggest=False``: ``problem`` only (a count laid out
    to be named, :func:`_fitting`, is only found to fit or not). ``table_too``: ``problem``
    is walls that shut the table (:func:`_walls_shut_table`), and the count named keeps
    the way there; as many as the other checks take may shut it too, then fewer are named.
    """
    if not suggest:
        return (_TableShut if table_too else SceneError)(problem)
    if not isinstance(counts, int):
        return SceneError(f"{problem}: give the class fewer objects{remedy}")
    n = len(_class_order(config, counts, seed))
    most, full = _walls_take(config, n, seed, max_tries, table_too=table_too)
    fewer = f"ask for {most} or fewer" if most else "no number of objects fits"
    if not most and remedy.startswith(", or "):  # (no fewer to say "or" to)
        remedy = "; " + remedy.removeprefix(", or ")
    if full is not None:  # as many as the walls take may not fit on the table: name the fewer
        # what one layout of that many held, not what the table holds: a count between
        # the two is drawn otherwise and may be laid out (80 with seed 18201 named 44;
        # 45 and 46 were then laid out), or may not (48 of 500 with seed 22015: 45 is)
        held = (
            f"the walls take {most}, and no layout of those drawn with seed {seed} held "
            f"more than {full.most} on the table"
        )
        fits, shut = _fitting(config, full.most, seed, max_tries) if full.most else (None, None)
        if shut is not None:  # that many laid out, or fewer, shut the way to the table
            first = "" if shut[0] == full.most else f"{full.most} asked for does not lay out, and "
            said = f"{held}; {first}{_shut_said(shut, fits)}"
            fewer = (
                f"ask for {fits} or fewer ({said})"
                if fits is not None
                else f"ask for fewer than {shut[1]} ({said})"
                if shut[1]
                else f"no number of objects fits ({said})"
            )
        elif fits is not None and fits == full.most:
            fewer = f"ask for {fits} or fewer ({held})"
        elif fits is not None:
            fewer = (
                f"ask for {fits} or fewer ({held}; {full.most} asked for does not lay "
                f"out, {fits} does)"
            )
        elif full.most:
            fewer = (
                f"ask for fewer than {full.most} ({held}; {full.most} asked for does not lay out)"
            )
        else:
            fewer = (
                f"no number of objects fits (the walls take {most}, and no layout of "
                f"those drawn with seed {seed} held one on the table)"
            )
    return SceneError(f"{problem}: {fewer}{remedy}")
