"""The points the marker is looked at from, and the lines in the joints between them."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mearm.config import Config
from mearm.errors import MearmError
from mearm.ik import IKTarget
from mearm.kinematics.bodies import TableContents, bin_origin_m, bin_shapes
from mearm.kinematics.chain import Chain
from mearm.kinematics.model import ArmModel
from mearm.maker.camera_calibration.settings import (
    FREE_SHARES,
    GRID_HALF_CM,
    GRID_STEP_CM,
    HEIGHTS_ABOVE_PICK_CM,
    PATH_CHECK_STEP,
    VIEW_MARGIN_PX,
)
from mearm.task.claw_fit import ClawCamera
from mearm.task.execute import JOINT_STEP
from mearm.task.plan import Planner
from mearm.task.route import Route
from mearm.task.timing import TimedPath
from mearm.vision.detector import ColorDetector
from mearm.vision.pinhole import PerspectiveCamera


@dataclass(frozen=True)
class Point:
    """A point the marker is looked at from.

    Attributes:
        target_cm: The TCP there (x, y, z) [cm].
        q: The joints the solver puts it at from home (model units), (n,).
        spread: The actuated joints, each as a share of its range, (m,).
        free: The actuated joints (chain order) its target leaves free
            (:func:`free_joints`), set at ``q``'s wherever it is reached from.
    """

    target_cm: tuple[float, float, float]
    q: np.ndarray
    spread: np.ndarray
    free: tuple[int, ...] = ()

    def reached(self, chain: Chain, q: np.ndarray) -> np.ndarray:
        """``q``, a solution of the target, with the free joints set as at the point."""
        if not self.free:
            return q
        a, free = chain.actuated_of(q), list(self.free)
        a[free] = chain.actuated_of(self.q)[free]
        return chain.full(a)


@dataclass(frozen=True)
class Visit:
    """The moves to a point, planned and checked in full.

    Attributes:
        route: A planned route first, or ``None``.
        lines: Then straight lines in the joints, each from where the last ends, (k, n)
            model units each; the last one the final move to the point.
        timed: The route's commands as the servos follow them, checked chord by chord
            (:meth:`Executor.followed <mearm.task.execute.Executor.followed>`); ``None``
            without a route. (A line's commands lie on the line: checked with it.)
    """

    route: Route | None
    lines: tuple[np.ndarray, ...]
    timed: TimedPath | None = None

    def path(self) -> np.ndarray:
        """Every pose the visit passes, in order, (k, n) model units."""
        parts = [] if self.route is None or self.route.plan is None else [self.route.plan.q_path]
        return np.vstack([*parts, *self.lines])


def pick_height_cm(config: Config) -> float:
    """The TCP's height when the jaws close on an object: the lowest of the classes' [cm]."""
    return min(c.grip_z_cm for c in config.task.classes) + config.arm.tool.tcp_above_grip_cm


def view_centre_cm(camera: PerspectiveCamera, z_cm: float) -> np.ndarray:
    """Where the frame's centre sees the plane at height ``z_cm`` (x, y) [cm]."""
    w, h = camera.size_px
    return np.asarray(camera.pixel_to_plane(np.array([(w - 1) / 2.0, (h - 1) / 2.0]), z_cm))


def grid_points(config: Config, planner: Planner, claw: ClawCamera) -> list[Point]:
    """The points over the view the arm can reach, whose marker the camera would see.

    A grid of :data:`GRID_STEP_CM` about the view's centre at each of
    :data:`HEIGHTS_ABOVE_PICK_CM`; kept where the solver reaches it from home inside the
    limits and the marker, as the present calibration puts it, faces the camera inside
    the frame. Each such target is a point as solved, and one more for each joint it
    leaves free (:func:`free_joints`) at each of :data:`FREE_SHARES`, where those too
    are inside the limits and show the marker.
    """
    chain = planner.model.chain
    approach = config.arm.tool.pick_approach
    lo, hi = chain.actuated_lower, chain.actuated_upper
    points = []
    for dz in HEIGHTS_ABOVE_PICK_CM:
        z = pick_height_cm(config) + dz
        centre = view_centre_cm(claw.camera, z)
        for dx in np.arange(-GRID_HALF_CM[0], GRID_HALF_CM[0] + 1e-9, GRID_STEP_CM):
            for dy in np.arange(-GRID_HALF_CM[1], GRID_HALF_CM[1] + 1e-9, GRID_STEP_CM):
                target = (float(centre[0] + dx), float(centre[1] + dy), float(z))
                q = solved(planner, IKTarget(target, approach), planner.model.home)
                if q is None:
                    continue
                free = free_joints(planner.model, q, keeps_approach=approach is not None)
                for v in (q, *turned_free(chain, q, free)):
                    if planner.pose_allowed(v) and in_frame(claw, v, VIEW_MARGIN_PX):
                        spread = (chain.actuated_of(v) - lo) / (hi - lo)
                        points.append(Point(target, v, spread, free))
    return points


def free_joints(model: ArmModel, q: np.ndarray, *, keeps_approach: bool) -> tuple[int, ...]:
    """The actuated joints (chain order) whose turn at ``q`` leaves a point's target as is.

    The TCP's place stays, and its approach axis where the target keeps one: the 5-DOF
    arm's wrist roll, about the tool's axis. Such a joint still moves the marker.
    """
    chain = model.chain
    p0, R0 = model.tcp_pose(q)
    a0 = chain.actuated_of(q)
    free = []
    for i in range(chain.m):
        a = a0.copy()
        a[i] += 1e-3  # [rad or m]: moves a TCP 1 cm from the axis 1e-3 cm
        p, R = model.tcp_pose(chain.full(a))
        turn = np.linalg.norm((R - R0) @ model.approach_axis) if keeps_approach else 0.0
        if np.linalg.norm(p - p0) < 1e-7 and turn < 1e-7:
            free.append(i)
    return tuple(free)


def turned_free(chain: Chain, q: np.ndarray, free: Sequence[int]) -> list[np.ndarray]:
    """``q`` with each free joint in turn at each of :data:`FREE_SHARES` of its range."""
    lo, hi = chain.actuated_lower, chain.actuated_upper
    out = []
    for i in free:
        for share in FREE_SHARES:
            a = chain.actuated_of(q)
            a[i] = lo[i] + share * (hi[i] - lo[i])
            out.append(chain.full(a))
    return out


def solved(planner: Planner, target: IKTarget, q_start: np.ndarray) -> np.ndarray | None:
    """The joints the planner's solver reaches ``target`` at from ``q_start``, if allowed."""
    try:
        result = planner.solver.solve(target, q_start)
    except MearmError:  # outside the target box, out of reach
        return None
    if not result.converged or not planner.pose_allowed(result.q):
        return None
    return np.asarray(result.q, dtype=float)


def in_frame(claw: ClawCamera, q: np.ndarray, margin_px: float) -> bool:
    """Whether the marker at joints ``q`` faces the camera ``margin_px`` inside the frame."""
    corners = claw.corners_cm(q)
    normal = np.cross(corners[1] - corners[0], corners[0] - corners[3])  # x × y: its face
    if float(normal @ (claw.camera.centre_cm - corners.mean(axis=0))) <= 0:
        return False
    px = claw.pixels(q)
    w, h = claw.camera.size_px
    inside = (px >= margin_px) & (px <= np.array([w - 1, h - 1]) - margin_px)
    return bool(inside.all())


def thinned(chain: Chain, q_path: np.ndarray) -> np.ndarray:
    """A path's poses :data:`PATH_CHECK_STEP` apart in its largest joint turn, and its last."""
    a = chain.actuated_of(q_path)
    step = np.where(chain.prismatic[chain.actuated_index], 0.01, math.radians(1.0))
    keep, last = [0], a[0]
    for k in range(1, len(a)):
        if np.max(np.abs(a[k] - last) / step) >= PATH_CHECK_STEP or k == len(a) - 1:
            keep.append(k)
            last = a[k]
    return q_path[keep]


def joint_line(chain: Chain, q_from: np.ndarray, q_to: np.ndarray) -> np.ndarray:
    """A straight line in the joints, stepped as :meth:`Executor.joint_path` steps it, (k, n)."""
    a0, a1 = chain.actuated_of(q_from), chain.actuated_of(q_to)
    step = np.where(chain.prismatic[chain.actuated_index], JOINT_STEP[True], JOINT_STEP[False])
    k = max(1, int(np.ceil(np.max(np.abs(a1 - a0) / step))))
    return np.array([chain.full(a0 + (a1 - a0) * t) for t in np.linspace(0, 1, k + 1)])


def tops_cm(config: Config, objects: Sequence[tuple[str, str, float, float]]) -> float:
    """The highest bin wall or top of an object (id, class, x, y) above the table [cm]."""
    tops = [0.0]
    table = TableContents.of(config.task, config.belt)
    for c in table.classes:
        z0 = float(bin_origin_m(c)[2])
        tops += [
            (z0 + float(s.pose[2, 3]) + float(s.size[-1])) * 100.0
            for s in bin_shapes(c, table.objects(c.name))
        ]
    return max(tops + [config.task.class_named(o[1]).height_cm for o in objects])


def objects_seen(
    config: Config, camera: PerspectiveCamera, frame: np.ndarray
) -> list[tuple[str, str, float, float]]:
    """What the camera sees on the table, as the collision checks take it: (id, class, x, y)."""
    detector = ColorDetector(config.vision, camera, config.task.classes)
    out: list[tuple[str, str, float, float]] = []
    for d in detector.detect(frame):
        if d.table_cm is not None:
            x, y = (float(v) for v in d.table_cm)
            out.append((f"{d.color}{len(out) + 1}", d.color, x, y))
    return out
