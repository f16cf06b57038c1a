"""Picks that look: the camera watching the claw corrects the aim of the way down.

Over the object the arm looks once and shifts the pick route (:func:`aim_over`); where the
way down passes a bin's wall, it stops just above the walls' tops and looks again
(:func:`aim_low`); with the open jaws round the object it looks again and corrects, a few
times at most (:func:`aim_by_eye`). The looks and their maths are
:mod:`mearm.task.claw_loop`'s.
"""

from __future__ import annotations

import numpy as np

from mearm.config import Config
from mearm.config.shape_catalogue import SHAPES
from mearm.kinematics.collision import CollisionModel
from mearm.task.claw_loop import GOOD_ENOUGH_CM, MAX_LOOKS, ClawEye, shifted
from mearm.task.execute import Executor
from mearm.task.plan import Planner
from mearm.task.route import Route
from mearm.task.table_tracking import TrackedObject

#: A way down that passes a bin's wall within the clearance and this much more stops
#: just above the walls' tops to look again (:func:`aim_low`) [cm]: the claw's error in
#: the table plane changes between the look over the object and the pick by up to 0.9 cm
#: (fixed kits 3, 11, 21, 52, 53 at spread 0.12, seeds 1300-1302, simulated), as much as
#: the jaws' room beside a 2 cm object; an open jaw that far off lands on the wall's top.
WALL_MARGIN_CM = 1.0
#: A look aside (:func:`aim_aside`) moves the claw in steps of this [cm] ...
ASIDE_STEP_CM = 0.5
#: ... up to this far from the low point [cm]: a few centimetres, well within the
#: neighbourhood over which the picks' corrections are taken to hold
#: (:data:`~mearm.task.claw_loop.NEIGHBOURHOOD_CM`).
MAX_ASIDE_CM = 4.0


def aim_over(
    eye: ClawEye, planner: Planner, ex: Executor, obj: TrackedObject, pick: Route, aim: np.ndarray
) -> tuple[Route, np.ndarray, bool]:
    """Over the object: look once and aim the way down by what was seen.

    The table-plane error seen here shifts the pick route before the jaws come down
    around the object. Returns the route down (replanned where the aim changed; kept
    where the new one cannot be planned), the aim [cm], (3,), and whether the camera saw
    the claw.
    """
    look = eye.look(ex.q_now())
    if look is None:
        return pick, aim, False
    off = aim[:2] + look.error_cm[:2]  # where the claw is, less where it should be
    if np.linalg.norm(off) < GOOD_ENOUGH_CM:
        return pick, aim, True
    step = np.array([-off[0], -off[1], 0.0])
    down = Route(obj.id, obj.class_name, "pick", pick.attempt,
                 shifted(pick.target, step))  # fmt: skip
    if not planner.plan(down, ex.q_now(), target=obj.id).planned:
        return pick, aim, True
    return down, aim + step, True


def beside_wall(planner: Planner, collision: CollisionModel, pick: Route) -> str | None:
    """The bin whose wall the way down passes within the clearance and :data:`WALL_MARGIN_CM`.

    ``None`` when it passes none that close (or the route has no plan).
    """
    if pick.plan is None:
        return None
    near = [(d, c) for q in pick.plan.q_path for c, _, d in collision.bins_at(q)]
    if not near:
        return None
    d_cm, color = min(near)
    return color if d_cm < planner.config.task.clearance_cm + WALL_MARGIN_CM else None


def aim_low(
    eye: ClawEye, planner: Planner, ex: Executor, obj: TrackedObject, pick: Route, aim: np.ndarray
) -> tuple[Route | None, Route, np.ndarray, bool]:
    """Where the way down passes a bin's wall: stop just above the walls, look, go on.

    The look over the object (:func:`aim_over`) corrects the claw there; on the way down
    its error changes by as much as :data:`WALL_MARGIN_CM`, and a jaw beside a bin's wall
    would come down on the wall's top, the servos pressing the arm on it until one stalls
    (a fault that stops the sort). A way down that passes a wall that close
    (:func:`beside_wall`) stops first where the tool clears every wall's top by the
    clearance and a margin (:meth:`~mearm.task.plan.Planner.safe_height_cm`), straight
    above the pick, and looks there: the rest of the way down changes the error much less
    before the jaws pass the wall. Both legs are planned in full before the first moves;
    where either cannot be, or the point above is no higher, nothing changes. The low
    point is safe to reach where the camera has not seen the claw yet: there the tool
    still clears every wall's top, whatever its error in the table plane; and there the
    marker comes into the frame where, higher up over the far table, it was above the
    frame's top edge (simulated: kits 21 and 82 at seeds 901 and 1710, docs/twin.md).

    Returns:
        The route to the low point (``None`` where not taken, and then nothing moved), the
        pick route from where the arm is, the aim's shift [cm], (3,), and whether the
        camera saw the claw at the low point.
    """
    if pick.plan is None:
        return None, pick, aim, False
    q_path = pick.plan.q_path
    z_cm = planner.safe_height_cm(q_path[0])
    if z_cm >= float(planner.model.fk_cm(q_path[0])[2]):
        return None, pick, aim, False
    up_cm = z_cm - float(pick.target.position_cm[2])
    low = Route(obj.id, obj.class_name, "approach", pick.attempt,
                shifted(pick.target, np.array([0.0, 0.0, up_cm])))  # fmt: skip
    if not planner.plan(low, ex.q_now(), target=obj.id).planned:
        return None, pick, aim, False
    assert low.plan is not None
    down = Route(obj.id, obj.class_name, "pick", pick.attempt, pick.target)
    if not planner.plan(down, low.plan.q, target=obj.id).planned:
        return None, pick, aim, False
    ex.stream(low, "travel", closed=False)
    down, aim, seen = aim_over(eye, planner, ex, obj, down, aim)
    return low, down, aim, seen


def aim_aside(
    eye: ClawEye,
    planner: Planner,
    ex: Executor,
    obj: TrackedObject,
    low: Route,
    pick: Route,
    aim: np.ndarray,
) -> tuple[Route, Route, np.ndarray, bool]:
    """Where the camera saw the claw neither over the object nor at the low point: look aside.

    Over the far table the claw's marker is above the frame's top edge, and at the low
    point (:func:`aim_low`) still at it (simulated: 0.4 cm of its image inside). The arm,
    at the low point, moves at that height to the nearest point that puts the marker
    inside the frame with room for the claw's error (:func:`in_view_shift`), looks there,
    and comes back to the low point shifted by what it saw: the servos' errors vary
    smoothly over the table, and at that height the tool clears every wall's top,
    whatever its error. The way there, back and down is planned in full before the arm
    moves back; where any leg cannot be, the pick is not made.

    Returns:
        The route the arm is on now (toward the low point, or the look aside), the pick
        route from it, the aim's shift [cm], (3,), and whether the camera saw the claw.
    """
    q_low = ex.q_now()
    shift = in_view_shift(eye, planner.config, q_low)
    if shift is None:
        return low, pick, aim, False
    aside = Route(obj.id, obj.class_name, "approach", pick.attempt,
                  shifted(low.target, shift))  # fmt: skip
    if not planner.plan(aside, q_low, target=obj.id).planned:
        return low, pick, aim, False
    ex.stream(aside, "travel", closed=False)
    look = eye.look(ex.q_now())
    if look is None:
        return aside, pick, aim, False
    off = aim[:2] + look.error_cm[:2]  # where the claw is, less where it should be
    step = np.array([-off[0], -off[1], 0.0])
    back = Route(obj.id, obj.class_name, "approach", pick.attempt, shifted(low.target, step))
    down = Route(obj.id, obj.class_name, "pick", pick.attempt, shifted(pick.target, step))
    if not planner.plan(back, ex.q_now(), target=obj.id).planned:
        return aside, pick, aim, False
    assert back.plan is not None
    if not planner.plan(down, back.plan.q, target=obj.id).planned:
        return aside, pick, aim, False
    ex.stream(back, "travel", closed=False)
    return back, down, aim + step, True


def in_view_shift(eye: ClawEye, config: Config, q: np.ndarray) -> np.ndarray | None:
    """The smallest shift of the claw in the table plane that brings its marker into view [cm].

    The shift points from the marker toward where the image's centre meets the level
    plane at the marker's height, in steps of :data:`ASIDE_STEP_CM` up to
    :data:`MAX_ASIDE_CM`; at it the square of the marker's side and
    :data:`WALL_MARGIN_CM` (the claw's error) around the marker's planned centre is seen
    whole. ``None`` when no shift that far does. Returns (3,), z 0.
    """
    w, h = config.camera.width_px, config.camera.height_px
    centre = eye.planned_cm(q)
    toward = eye.camera.pixel_to_plane(np.array([w / 2.0, h / 2.0]), float(centre[2]))
    d = np.asarray(toward, dtype=float).ravel()[:2] - centre[:2]
    if np.linalg.norm(d) <= 0:
        return None
    d /= np.linalg.norm(d)
    r = eye.marker.size_cm / 2.0 + WALL_MARGIN_CM
    square = np.array([[-r, -r, 0.0], [r, -r, 0.0], [r, r, 0.0], [-r, r, 0.0]])
    for k in range(1, int(MAX_ASIDE_CM / ASIDE_STEP_CM) + 1):
        shift = np.array([d[0], d[1], 0.0]) * k * ASIDE_STEP_CM
        px = eye.camera.project(centre + shift + square)
        if np.all((px >= 0) & (px < [w, h])):
            return shift
    return None


def aim_by_eye(
    eye: ClawEye,
    planner: Planner,
    ex: Executor,
    obj: TrackedObject,
    above: Route | None,
    pick: Route,
    aim: np.ndarray,
) -> tuple[Route, np.ndarray, list[float]]:
    """With the open jaws round the object: look at the claw and correct the aim.

    (:mod:`mearm.task.claw_loop`.) Each correction goes back up to the point above the
    object and down again to the corrected pick, so that every look sees the claw
    after the same final move (the gears' play and dead band then leave the same
    error each time, and the correction takes it out), a few times at most. A
    correction that cannot be planned in full is not made: the arm stays where it is.

    Returns:
        The pick route the arm is on now, the aim's shift [cm], (3,), and the marker's
        height errors the looks saw [cm] (:class:`~mearm.task.claw_loop.GripDrops`).
    """
    seen_z_cm: list[float] = []
    for _ in range(MAX_LOOKS):
        look = eye.look(ex.q_now())
        if look is None:
            break
        seen_z_cm.append(float(look.error_cm[2]))
        off = aim[:2] + look.error_cm[:2]  # where the claw is, less where it should be
        if np.linalg.norm(off) < GOOD_ENOUGH_CM or above is None:
            break
        step = np.array([-off[0], -off[1], 0.0])
        up = Route(obj.id, obj.class_name, "approach", pick.attempt,
                   shifted(above.target, step))  # fmt: skip
        down = Route(obj.id, obj.class_name, "pick", pick.attempt,
                     shifted(pick.target, step))  # fmt: skip
        if not planner.plan(up, ex.q_now(), target=obj.id).planned:
            break
        if obj.yaw_deg is not None:  # the jaws stay across a cube's faces
            planner.turn_jaws(up, obj.yaw_deg, SHAPES["cube"].symmetry_deg)
        assert up.plan is not None
        if not planner.plan(down, up.plan.q, target=obj.id).planned:
            break
        ex.stream(up, "travel", closed=False)
        ex.stream(down, "travel", closed=False)
        above, pick, aim = up, down, aim + step
    return pick, aim, seen_z_cm


#: A pick whose own looks at the grip pose (two at least) saw the claw higher than this
#: on average goes lower before the jaws close (:func:`lower_by_looks`) [cm] ...
HIGH_LOOKS_CM = 0.3
#: ... by their mean less this [cm]: three looks' mean saw a high claw 0.14 cm lower
#: than it was, give or take 0.21 cm (kits 21, 82 at spread 0.12, simulated).
LOOKS_MARGIN_CM = 0.2
#: The lowered jaws' tips stay at least this high over the table as planned [cm].
TIPS_OVER_TABLE_CM = 0.1


def lower_by_looks(
    planner: Planner,
    collision: CollisionModel,
    ex: Executor,
    obj: TrackedObject,
    above: Route | None,
    pick: Route,
    aim: np.ndarray,
    seen_z_cm: list[float],
) -> tuple[Route, np.ndarray]:
    """Lower the open jaws round the object where the pick's own looks saw the claw high.

    A claw 0.4 cm or more high closes its pads on the top 0.1 cm of a 1 cm object, which
    tips at the lift or slips out on the way (docs/twin.md, "Picks that look"). The arm
    goes straight up to the point above and down again, lower by the looks' mean less
    :data:`LOOKS_MARGIN_CM`, no lower than :data:`TIPS_OVER_TABLE_CM` over the table as
    planned; both legs planned in full, else nothing changes. Returns the pick route the
    arm is on and the aim [cm], (3,).
    """
    if above is None or pick.plan is None or len(seen_z_cm) < 2:
        return pick, aim
    mean = float(np.mean(seen_z_cm))
    room = collision.tool_lowest_cm(pick.plan.q)[0] - TIPS_OVER_TABLE_CM
    drop = min(mean - LOOKS_MARGIN_CM, room)
    if mean <= HIGH_LOOKS_CM or drop <= 0.0:
        return pick, aim
    z = float(above.target.position_cm[2])
    up = Route(obj.id, obj.class_name, "approach", pick.attempt,
               planner.up_from(ex.q_now(), z, above.target.approach))  # fmt: skip
    if not planner.plan(up, ex.q_now(), target=obj.id).planned:
        return pick, aim
    if obj.yaw_deg is not None:  # the jaws stay across a cube's faces
        planner.turn_jaws(up, obj.yaw_deg, SHAPES["cube"].symmetry_deg)
    assert up.plan is not None
    step = np.array([0.0, 0.0, -drop])
    down = Route(obj.id, obj.class_name, "pick", pick.attempt, shifted(pick.target, step))
    if not planner.plan(down, up.plan.q, target=obj.id).planned:
        return pick, aim
    ex.stream(up, "travel", closed=False)
    ex.stream(down, "travel", closed=False)
    return down, aim + step
