r"""The arm's check of the camera calibration: put an object down, see where the camera sees it.

The arm takes one object lying on the table and, for each check point, picks it up where
the camera sees it and sets it down at the point: down to its grip height, jaws open,
straight up to ``task.approach_height_cm``, then home so the camera's view is clear. A
frame is read and the object located (:attr:`~mearm.vision.Detection.table_cm`). The
residual of a point is

.. math::

    r_i = s_i - c_i

with :math:`s_i` where the camera sees the object and :math:`c_i` where the arm put it
(x, y) [cm]. The object goes back to where it lay at the end.

**Refining the camera's pose.** A calibrated camera that is turned about the vertical or
shifted on the table by a little sees every point moved by the same planar rigid motion.
The rotation :math:`R_z(\theta)` and shift :math:`t` that best map the seen points onto
the commanded ones (least squares: Kabsch/Umeyama in 2-D, no scale) are

.. math::

    \theta = \operatorname{atan2}\Big(\sum \bar s_i \times \bar c_i,\;
        \sum \bar s_i \cdot \bar c_i\Big), \qquad t = \hat c - R_z(\theta)\,\hat s

(:math:`\hat s, \hat c` the centroids, :math:`\bar s_i = s_i - \hat s`,
:math:`\bar c_i = c_i - \hat c`). Moving the camera by the same motion,
:math:`R' = R_z R`, :math:`C' = R_z C + (t_x, t_y, 0)`, moves every ray, and so every
located point on a horizontal plane, by it.

Every motion is planned in full (:class:`~mearm.task.plan.Planner`) before any of it is
sent (:class:`~mearm.task.execute.Executor`), as in the sort; a move whose plan fails
is not made and its point carries the reason.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mearm.config import ColorClass, Config
from mearm.config.errors import CalibrationError
from mearm.errors import MearmError
from mearm.ik import IKTarget
from mearm.task.execute import Executor
from mearm.task.plan import Planner
from mearm.task.rig import open_rig
from mearm.task.route import Route
from mearm.vision import Camera, ColorDetector, Detection
from mearm.vision.calibration import CameraGeometry, camera_geometry
from mearm.vision.pinhole import Extrinsics, PerspectiveCamera, today

#: How many check points the check takes at least and at most.
MIN_POINTS, MAX_POINTS = 2, 12
#: Candidate check points lie on a lattice of this pitch [cm].
LATTICE_CM = 1.0
#: The object put down is the detection of its class nearest the point, within this [cm].
FIND_RADIUS_CM = 5.0
#: A detection this near to another object's place is that object, not the one moved [cm].
SAME_OBJECT_CM = 1.5


class ArmCheckError(MearmError):
    """A bad argument to the check (the number of points, an unknown class)."""


class NothingToCheck(ArmCheckError):
    """The table does not allow the check: no object to take, or no room for the points."""


@dataclass(frozen=True)
class CheckPoint:
    """One check point.

    Attributes:
        commanded_cm: Where the arm set the object down (x, y) [cm], (2,).
        seen_cm: Where the camera then saw it (x, y) [cm], (2,), or ``None``.
        failure: Why the point has no measurement (a move that could not be planned, the
            object not found), or ``None``.
    """

    commanded_cm: np.ndarray
    seen_cm: np.ndarray | None = None
    failure: str | None = None

    @property
    def residual_cm(self) -> np.ndarray | None:
        """Seen − commanded (x, y) [cm], (2,), or ``None`` without a measurement."""
        return None if self.seen_cm is None else self.seen_cm - self.commanded_cm


@dataclass(frozen=True)
class ArmCheck:
    """What the check found.

    Attributes:
        class_name: The class of the object moved.
        start_cm: Where it lay at first, as the camera saw it (x, y) [cm], (2,).
        points: One record per check point, in the order visited.
        refined: The camera pose refined by the points, or ``None`` (not asked for, or
            not enough points measured).
        refined_seen_cm: Where the refined camera sees the object in the same frames,
            (k, 2) for the measured points, or ``None``.
        returned: Whether the object was put back where it lay.
        failure: Why the check could not complete, or ``None``.
    """

    class_name: str
    start_cm: np.ndarray
    points: tuple[CheckPoint, ...]
    refined: Extrinsics | None = None
    refined_seen_cm: np.ndarray | None = None
    returned: bool = False
    failure: str | None = None

    @property
    def measured(self) -> tuple[CheckPoint, ...]:
        """The points with a measurement."""
        return tuple(p for p in self.points if p.seen_cm is not None)

    @property
    def residuals_cm(self) -> np.ndarray:
        """Seen − commanded of the measured points [cm], (k, 2)."""
        return np.array([p.residual_cm for p in self.measured], dtype=float).reshape(-1, 2)

    @property
    def refined_residuals_cm(self) -> np.ndarray | None:
        """Seen by the refined camera − commanded [cm], (k, 2), or ``None``."""
        if self.refined_seen_cm is None:
            return None
        commanded = np.array([p.commanded_cm for p in self.measured]).reshape(-1, 2)
        return self.refined_seen_cm - commanded

    @property
    def complete(self) -> bool:
        """Whether every point was measured and the object put back."""
        return self.failure is None and self.returned and len(self.measured) == len(self.points)


def rms_cm(residuals_cm: npt.ArrayLike) -> float:
    r"""Root mean square length of residuals (k, 2) [cm]: :math:`\sqrt{\frac1k\sum |r_i|^2}`."""
    r = np.asarray(residuals_cm, dtype=float).reshape(-1, 2)
    return float(np.sqrt(np.mean(np.sum(r**2, axis=1)))) if len(r) else math.nan


def max_cm(residuals_cm: npt.ArrayLike) -> float:
    """The largest residual's length [cm] (NaN for none)."""
    r = np.asarray(residuals_cm, dtype=float).reshape(-1, 2)
    return float(np.linalg.norm(r, axis=1).max()) if len(r) else math.nan


def fit_planar_rigid(
    seen_cm: npt.ArrayLike, commanded_cm: npt.ArrayLike
) -> tuple[float, np.ndarray]:
    """The rotation about z and shift mapping seen points onto commanded ones (module docstring).

    Args:
        seen_cm: Seen points (x, y) [cm], (k, 2), k ≥ 2.
        commanded_cm: The same points as commanded [cm], (k, 2).

    Returns:
        The angle θ [rad] and the shift t [cm], (2,): commanded ≈ R_z(θ)·seen + t.
    """
    s = np.asarray(seen_cm, dtype=float).reshape(-1, 2)
    c = np.asarray(commanded_cm, dtype=float).reshape(-1, 2)
    s_mean, c_mean = s.mean(axis=0), c.mean(axis=0)
    sb, cb = s - s_mean, c - c_mean
    cross = float(np.sum(sb[:, 0] * cb[:, 1] - sb[:, 1] * cb[:, 0]))
    dot = float(np.sum(sb * cb))
    theta = math.atan2(cross, dot)
    t = c_mean - _rz2(theta) @ s_mean
    return theta, t


def _rz2(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


def refine_extrinsics(ext: Extrinsics, theta_rad: float, shift_cm: npt.ArrayLike) -> Extrinsics:
    """The camera moved by R_z(θ) and the table shift: R' = R_z·R, C' = R_z·C + (t, 0).

    The reprojection error of the markers it was fitted to (``rms_px``) is kept; the
    result is marked ``refined_by_arm``.
    """
    Rz = np.eye(3)
    Rz[:2, :2] = _rz2(theta_rad)
    t = np.asarray(shift_cm, dtype=float).reshape(2)
    return dataclasses.replace(
        ext,
        rotation=Rz @ ext.rotation,
        position_cm=Rz @ ext.position_cm + np.array([t[0], t[1], 0.0]),
        refined_by_arm=True,
        date=today(),
    )


# --------------------------------------------------------------------- check points


def _field_cm(geometry: CameraGeometry, config: Config, margin_cm: float) -> np.ndarray:
    """The table box the camera sees, shrunk by ``margin_cm``: (x0, x1, y0, y1) [cm]."""
    w, h = config.camera.width_px, config.camera.height_px
    corners = np.array([[0, 0], [w - 1, 0], [w - 1, h - 1], [0, h - 1]], dtype=float)
    xy = np.asarray(geometry.pixel_to_table(corners), dtype=float)
    xs, ys = np.sort(xy[:, 0]), np.sort(xy[:, 1])
    return np.array([xs[1] + margin_cm, xs[2] - margin_cm, ys[1] + margin_cm, ys[2] - margin_cm])


def jaw_reach_cm(config: Config) -> float:
    """How far the open jaws' outer faces reach from the object's centre [cm]."""
    g = config.arm.tool.gripper
    return g.open_cm / 2 + g.jaw_thickness_cm


def check_points(
    config: Config,
    geometry: CameraGeometry,
    planner: Planner,
    cls: ColorClass,
    n: int,
    others_cm: Sequence[tuple[float, float, float]],
) -> np.ndarray:
    """``n`` check points on a grid over the reachable part of the camera's view, (n, 2) [cm].

    A candidate (a lattice point of :data:`LATTICE_CM`) lies one object diameter inside
    the camera's view, the open jaws around it clear every bin's footprint and every
    other object (``others_cm``: x, y, radius [cm]), and its pick and approach points
    are planned from home. The grid has ⌊√n⌋ rows over the candidates' extent; each node
    takes the nearest candidate not taken.

    Raises:
        NothingToCheck: fewer than ``n`` candidates.
    """
    reach = jaw_reach_cm(config)
    x0, x1, y0, y1 = _field_cm(geometry, config, cls.diameter_cm)
    xs = np.arange(math.ceil(x0 / LATTICE_CM), math.floor(x1 / LATTICE_CM) + 1) * LATTICE_CM
    ys = np.arange(math.ceil(y0 / LATTICE_CM), math.floor(y1 / LATTICE_CM) + 1) * LATTICE_CM
    cand = np.array([(x, y) for y in ys for x in xs], dtype=float).reshape(-1, 2)
    keep = np.ones(len(cand), dtype=bool)
    for c in config.task.classes:
        half = c.bin_inner_width_cm / 2 + reach
        keep &= ~(
            (np.abs(cand[:, 0] - c.bin_cm[0]) <= half) & (np.abs(cand[:, 1] - c.bin_cm[1]) <= half)
        )
    for ox, oy, r in others_cm:
        keep &= np.hypot(cand[:, 0] - ox, cand[:, 1] - oy) >= reach + r
    cand = cand[keep]
    home = planner.model.home
    reachable: dict[int, bool] = {}

    def reaches(i: int) -> bool:
        if i not in reachable:
            pick = planner.pick_target(cls, *cand[i])
            targets = [pick]
            h = config.task.approach_height_cm
            if h is not None:
                targets.append(planner.above_target(pick, h))
            reachable[i] = all(
                planner.plan(Route("", cls.name, "pick", 1, t), home).planned for t in targets
            )
        return reachable[i]

    # the extent first: the candidates any node could take
    rows = max(1, math.isqrt(n))
    cols = math.ceil(n / rows)
    chosen: list[int] = []
    if len(cand):
        lo, hi = cand.min(axis=0), cand.max(axis=0)
        for k in range(rows * cols):
            if len(chosen) == n:
                break
            i, j = divmod(k, cols)
            node = lo + (hi - lo) * np.array([(j + 0.5) / cols, (i + 0.5) / rows])
            order = np.argsort(np.hypot(*(cand - node).T), kind="stable")
            for idx in order[:400]:
                if int(idx) not in chosen and reaches(int(idx)):
                    chosen.append(int(idx))
                    break
    if len(chosen) < n:
        raise NothingToCheck(
            f"found room for {len(chosen)} of {n} check points in the camera's view that the "
            "arm reaches, clear of the bins and the other objects: ask for fewer points or "
            "clear the table"
        )
    return cand[chosen]


# --------------------------------------------------------------------- the check


class _Arm:
    """Moves one object with the sort's planner and executor, every move planned first."""

    def __init__(self, config: Config, planner: Planner, executor: Executor):
        self.config = config
        self.planner = planner
        self.ex = executor

    def transfer(
        self, cls: ColorClass, from_cm: npt.ArrayLike, to_cm: npt.ArrayLike, object_id: str
    ) -> str | None:
        """Take the object at ``from_cm`` to ``to_cm`` and go home; the failure, or ``None``.

        Every route (above, down, up, across, down, up) is planned in full, each from
        where the one before ends, before the first is sent.
        """
        p, h = self.planner, self.config.task.approach_height_cm
        pick = p.pick_target(cls, *np.asarray(from_cm, dtype=float))
        place = p.pick_target(cls, *np.asarray(to_cm, dtype=float))
        steps: list[tuple[str, IKTarget]] = []
        if h is not None:
            steps.append(("approach", p.above_target(pick, h)))
        steps.append(("pick", pick))
        up_pick = p.above_target(pick, h) if h is not None else p.lift_target(pick)
        up_place = p.above_target(place, h) if h is not None else p.lift_target(place)
        steps += [("lift", up_pick), ("approach", up_place), ("pick", place), ("lift", up_place)]
        routes: list[Route] = []
        q = self.ex.q_now()
        for step, target in steps:
            route = Route(object_id, cls.name, step, 1, target)  # type: ignore[arg-type]
            if not p.plan(route, q).planned:
                where = ", ".join(f"{v:.2f}" for v in target.position_cm)
                return f"{step} to ({where}) cm cannot be planned: {route.failure}"
            assert route.plan is not None
            q = route.plan.q
            routes.append(route)
        ex = self.ex
        *to_pick, lift, across, down, up = routes
        for route in to_pick:
            ex.stream(route, "travel", closed=False)
        ex.set_tool("grip", closed=False)
        ex.set_tool("grip", closed=True)
        ex.set_tool("travel", closed=True)
        ex.stream(lift, "travel", closed=True)
        ex.stream(across, "travel", closed=True)
        ex.stream(down, "travel", closed=True)
        ex.set_tool("grip", closed=True)  # the jaws come down around the spot, then open
        ex.set_tool("grip", closed=False)
        ex.stream(up, "grip", closed=False)  # straight up, the open jaws clear of the object
        self.home()
        return None

    def home(self) -> None:
        """Home along a straight line in joint space, the gripper open."""
        self.ex.move_joints(self.planner.model.home, "travel", closed=False)
        self.ex.home_pose()


def _table_detections(
    detector: ColorDetector, config: Config, frame: np.ndarray
) -> list[Detection]:
    """Whole objects on the table, outside every bin."""
    h, w = frame.shape[:2]
    out = []
    for d in detector.detect(frame):
        x, y, bw, bh = d.bbox_px
        if x <= 0 or y <= 0 or x + bw >= w or y + bh >= h or d.table_cm is None:
            continue
        tx, ty = (float(v) for v in d.table_cm)
        if any(c.in_bin(tx, ty) for c in config.task.classes):
            continue
        out.append(d)
    return out


def _find(
    found: list[Detection], cls: ColorClass, near_cm: np.ndarray, others_cm: np.ndarray
) -> Detection | None:
    """The detection of ``cls`` nearest ``near_cm`` within :data:`FIND_RADIUS_CM`, not another."""
    best, best_d = None, FIND_RADIUS_CM
    for d in found:
        assert d.table_cm is not None
        if d.color != cls.name or d.merged:
            continue
        if len(others_cm) and np.hypot(*(others_cm - d.table_cm).T).min() < SAME_OBJECT_CM:
            continue
        dist = float(np.hypot(*(d.table_cm - near_cm)))
        if dist <= best_d:
            best, best_d = d, dist
    return best


def run_check(
    config: Config,
    *,
    points: int = 4,
    class_name: str | None = None,
    refine: bool = False,
    echo: Callable[[str], None] | None = print,
) -> ArmCheck:
    """Open the rig, run the arm's check of the camera, put the object back, close the rig.

    Args:
        config: The whole configuration.
        points: How many check points (:data:`MIN_POINTS` … :data:`MAX_POINTS`).
        class_name: Take an object of this class (default: the first detected).
        refine: Also fit the camera pose to the points (needs a perspective calibration).
        echo: Called with one line per step (``None``: silent).

    Raises:
        ArmCheckError: a bad argument (before the rig opens).
        NothingToCheck: no object of the class on the table, or no room for the points
            (before anything but going home moves).
        CalibrationError: ``refine`` without a perspective calibration.
    """
    say = echo if echo is not None else (lambda _line: None)
    geometry = _checked_geometry(config, points, class_name, refine=refine)
    detector = ColorDetector(config.vision, geometry, config.task.classes)
    with open_rig(config) as rig:
        planner = Planner(config, rig.model)
        ex = Executor(config, rig.bus, rig.model)
        if not rig.bus.is_connected:
            rig.bus.connect()
        ex.home_pose()
        found = _table_detections(detector, config, rig.camera.read())
        obj = _chosen_object(found, class_name)
        cls = config.task.class_named(obj.color)
        assert obj.table_cm is not None
        start = np.array(obj.table_cm, dtype=float)
        others_xy, others_cm = _other_objects(config, found, obj)
        targets = check_points(config, geometry, planner, cls, points, others_cm)
        say(f"object: {cls.name} at ({start[0]:.2f}, {start[1]:.2f}) cm")
        arm = _Arm(config, planner, ex)
        visit = _visit_points(
            arm, rig.camera, detector, config, cls, start, targets, others_xy, say
        )
        returned = False
        failure = visit.failure
        if failure is None:
            problem = arm.transfer(cls, visit.here, start, cls.name)
            returned = problem is None
            if problem is not None:
                failure = f"the object was not put back: {problem}"
        refined = refined_seen = None
        measured = [r for r in visit.records if r.seen_cm is not None]
        if refine and len(measured) >= 2:
            assert isinstance(geometry, PerspectiveCamera)
            refined, refined_seen = _refit_pose(
                config, geometry, cls, measured, visit.frames, others_xy
            )
    return ArmCheck(
        class_name=cls.name,
        start_cm=start,
        points=tuple(visit.records),
        refined=refined,
        refined_seen_cm=refined_seen,
        returned=returned,
        failure=failure,
    )


def _checked_geometry(
    config: Config, points: int, class_name: str | None, *, refine: bool
) -> CameraGeometry:
    """Validate :func:`run_check`'s arguments and return the camera geometry."""
    if not MIN_POINTS <= points <= MAX_POINTS:
        raise ArmCheckError(f"points must be in {MIN_POINTS} … {MAX_POINTS}, got {points}")
    if class_name is not None and class_name not in config.task.class_names:
        raise ArmCheckError(
            f"no class {class_name!r}; classes: {', '.join(config.task.class_names)}"
        )
    geometry = camera_geometry(config.calibration, config.camera)
    if refine and not isinstance(geometry, PerspectiveCamera):
        raise CalibrationError(
            "refining the camera pose needs a perspective calibration "
            "(calibration.model: perspective), not the homography"
        )
    return geometry


def _chosen_object(found: list[Detection], class_name: str | None) -> Detection:
    """The first detection of ``class_name`` (any class when ``None``)."""
    chosen = [d for d in found if class_name is None or d.color == class_name]
    if not chosen:
        what = "object" if class_name is None else f"{class_name} object"
        raise NothingToCheck(f"no {what} seen on the table: put one in the camera's view")
    return chosen[0]


def _other_objects(
    config: Config, found: list[Detection], obj: Detection
) -> tuple[np.ndarray, list[tuple[float, float, float]]]:
    """The other objects seen: their centres (k, 2) and (x, y, radius) each [cm]."""
    others = [d for d in found if d is not obj]
    others_xy = np.array([d.table_cm for d in others], dtype=float).reshape(-1, 2)
    others_cm = [
        (float(x), float(y), config.task.class_named(d.color).diameter_cm / 2)
        for d, (x, y) in zip(others, others_xy, strict=True)
    ]
    return others_xy, others_cm


@dataclass
class _Visit:
    """What moving the object through the check points left behind."""

    records: list[CheckPoint]
    frames: list[np.ndarray]  # one per measured point
    here: np.ndarray  # where the object was last seen [cm]
    failure: str | None


def _visit_points(
    arm: _Arm,
    camera: Camera,
    detector: ColorDetector,
    config: Config,
    cls: ColorClass,
    start: np.ndarray,
    targets: np.ndarray,
    others_xy: np.ndarray,
    say: Callable[[str], None],
) -> _Visit:
    """Move the object to each target in turn and find it there; stop at the first loss."""
    visit = _Visit(records=[], frames=[], here=start, failure=None)
    for k, target in enumerate(targets, 1):
        problem = arm.transfer(cls, visit.here, target, cls.name)
        if problem is not None:
            visit.records.append(CheckPoint(target, failure=problem))
            say(f"point {k}: skipped: {problem}")
            continue
        frame = camera.read()
        seen = _find(_table_detections(detector, config, frame), cls, target, others_xy)
        if seen is None:
            visit.failure = (
                f"point {k}: no {cls.name} object seen within {FIND_RADIUS_CM:g} cm of "
                f"({target[0]:.2f}, {target[1]:.2f}) cm after setting it down"
            )
            visit.records.append(CheckPoint(target, failure=visit.failure))
            break
        assert seen.table_cm is not None
        visit.here = np.array(seen.table_cm, dtype=float)
        visit.records.append(CheckPoint(target, visit.here))
        visit.frames.append(frame)
    return visit


def _refit_pose(
    config: Config,
    geometry: PerspectiveCamera,
    cls: ColorClass,
    measured: list[CheckPoint],
    frames: list[np.ndarray],
    others_xy: np.ndarray,
) -> tuple[Extrinsics, np.ndarray]:
    """Fit the camera pose to the measured points and find the object again with it."""
    seen_xy = np.array([r.seen_cm for r in measured], dtype=float)
    theta, t = fit_planar_rigid(seen_xy, [r.commanded_cm for r in measured])
    refined = refine_extrinsics(geometry.extrinsics, theta, t)
    relocate = ColorDetector(config.vision, geometry.with_extrinsics(refined), config.task.classes)
    seen_again = []
    for r, frame in zip(measured, frames, strict=True):
        d = _find(_table_detections(relocate, config, frame), cls, r.commanded_cm,
                  _moved(others_xy, theta, t))  # fmt: skip
        seen_again.append(np.full(2, np.nan) if d is None else d.table_cm)
    return refined, np.array(seen_again, dtype=float).reshape(-1, 2)


def _moved(points_cm: np.ndarray, theta: float, t: np.ndarray) -> np.ndarray:
    """Points (k, 2) moved by R_z(θ) and t, as the refined camera sees them."""
    return points_cm @ _rz2(theta).T + t if len(points_cm) else points_cm
