"""Picks that look: the camera watching the claw corrects the aim of the way down.

Over the object the arm looks once and shifts the pick route (:func:`aim_over`); with the
open jaws round the object it looks again and corrects, a few times at most
(:func:`aim_by_eye`). The looks and their maths are :mod:`mearm.task.claw_loop`'s.
"""

from __future__ import annotations

import numpy as np

from mearm.config.shape_catalogue import SHAPES
from mearm.task.claw_loop import GOOD_ENOUGH_CM, MAX_LOOKS, ClawEye, shifted
from mearm.task.execute import Executor
from mearm.task.plan import Planner
from mearm.task.route import Route
from mearm.task.table_tracking import TrackedObject


def aim_over(
    eye: ClawEye, planner: Planner, ex: Executor, obj: TrackedObject, pick: Route, aim: np.ndarray
) -> tuple[Route, np.ndarray]:
    """Over the object: look once and aim the way down by what was seen.

    The table-plane error seen here shifts the pick route before the jaws come down
    around the object. Returns the route down (replanned where the aim changed; kept
    where the new one cannot be planned) and the aim [cm], (3,).
    """
    look = eye.look(ex.q_now())
    if look is None:
        return pick, aim
    off = aim[:2] + look.error_cm[:2]  # where the claw is, less where it should be
    if np.linalg.norm(off) < GOOD_ENOUGH_CM:
        return pick, aim
    step = np.array([-off[0], -off[1], 0.0])
    down = Route(obj.id, obj.class_name, "pick", pick.attempt,
                 shifted(pick.target, step))  # fmt: skip
    if not planner.plan(down, ex.q_now(), target=obj.id).planned:
        return pick, aim
    return down, aim + step


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
