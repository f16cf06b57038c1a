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

The refined pose records its own residual in ``rms_px``, as a marker fit records its
markers' (the unit the calibration file's rule compares, :func:`refine_extrinsics`): the
RMS distance in the frames between where the object was seen and where the pose projects
the commanded points, on the plane of the object's top (:func:`points_rms_px`). The pose
checked gets the same figure over the same points, so the two can be compared like with
like. The moved camera projects a point :math:`X` where the camera checked projects
:math:`R_z^T (X - (t_x, t_y, 0))`.

Every route to and from the object is planned in full (:class:`~mearm.task.plan.Planner`)
before any of it is sent (:class:`~mearm.task.execute.Executor`), as in the sort, and
checked against the bins, the table and the other objects (the sort's collision model,
:func:`~mearm.sim.table_collision.collision_model`), the commands the servos follow too,
chord by chord (:meth:`~mearm.task.execute.Executor.followed`); a move whose plan or
commands fail is not made and its point carries the reason. From above the point (and
after the servos' calibration at the start, in the fitted calibration) the arm goes home
the sort's checked way (:func:`~mearm.task.homing.go_home`): along a straight line in
joint space where it is clear, else up to the safe height first, or over to above home;
where no way is clear, nothing more is sent and the check stops (``not parked: the way
home …``).

**Where the points lie.** A set-down leaves the object near, not at, its point: the arm
stops a little short of its pose and the object sits a little off-centre in the jaws
(the twin's arm: up to 0.9 cm along x, 0.4 cm along y, at the far corners of the
perspective rig's view). The next move picks it where the camera sees it, so a point is
taken only where the object can be taken up from anywhere within
:data:`SET_DOWN_SLIP_CM` of it along x and y: the re-pick never lands past the reach, a
joint's limits or a servo's pulse range, nor with the jaws on a bin's wall or another
object. An object that can no longer be taken up where it lies stops the check.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np
import numpy.typing as npt

from mearm import interrupts
from mearm.config import ColorClass, Config
from mearm.config.errors import CalibrationError
from mearm.errors import MearmError
from mearm.hardware.errors import ServoError
from mearm.ik import IKTarget
from mearm.kinematics import ArmModel
from mearm.sim.table_collision import collision_model
from mearm.task.execute import CollisionError, Executor
from mearm.task.homing import go_home
from mearm.task.plan import Planner
from mearm.task.rig import Rig, open_rig
from mearm.task.route import Route
from mearm.task.sorter import CalibrateFirst, calibrates_at_start, check_calibrate_at_start
from mearm.task.timing import TimedPath
from mearm.vision import Camera, ColorDetector, Detection
from mearm.vision.arm_mask import RIM_POINTS, arm_view
from mearm.vision.calibration import CameraGeometry, camera_geometry
from mearm.vision.errors import CameraError
from mearm.vision.pinhole import Extrinsics, PerspectiveCamera, today

#: How many check points the check takes at least and at most.
MIN_POINTS, MAX_POINTS = 2, 12
#: Candidate check points lie on a lattice of this pitch [cm].
LATTICE_CM = 1.0
#: The object put down is the detection of its class nearest the point, within this [cm].
FIND_RADIUS_CM = 5.0
#: A detection this near to another object's place is that object, not the one moved [cm].
SAME_OBJECT_CM = 1.5
#: How far from its point a set-down may leave the object, along x and along y [cm]:
#: every point keeps this much room for the re-pick (the module docstring). The twins
#: put it down up to 0.90 cm off along x and 0.38 cm along y (``configs/sim_mujoco*``,
#: ``sim_5dof_mujoco*`` and ``sim_shapes_mujoco`` but the uncalibrated kits, 2 … 12
#: points each; simulated, 2026-11-30).
SET_DOWN_SLIP_CM = 1.0
#: The survey that finds where the arm reaches checks about this many lattice points.
SURVEY_POINTS = 100
#: The collision model's id of the object the check moves.
MOVED_ID = "checked"


class ArmCheckError(MearmError):
    """A bad argument to the check (the number of points, an unknown class)."""


class NothingToCheck(ArmCheckError):
    """The table does not allow the check: no object to take, or no room for the points."""


class CheckInterrupted(MearmError):
    """Ctrl-C (or a stop signal taken as one) while the check moved the arm.

    Nothing more is sent: the arm stays where it is, as ``mearm jog`` leaves it (the
    check's way home is no planned, checked route from anywhere, and the object may be
    in the jaws). The message names the last acknowledged pose.
    """


class RigNotOpened(MearmError):
    """The rig did not open: its camera, its servo port or its board's handshake.

    A servo port that cannot be opened, a board that does not answer its handshake or a
    camera that cannot be opened is found before anything moves, so it is bad input
    (exit 2), as for ``mearm sort``; the same fault once the rig is open stops the check
    (a ``ServoError`` or ``CameraError``, exit 1).
    """


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
            not enough points measured); its ``rms_px`` is its own residual over the
            points (:func:`refit_pose`).
        refined_seen_cm: Where the refined camera sees the object in the same frames,
            (k, 2) for the measured points, or ``None``.
        checked_rms_px: The pose checked: its residual over the same points, the figure
            the refined pose's ``rms_px`` compares with [px], or ``None`` (not refined).
        returned: Whether the object was put back where it lay.
        failure: Why the check could not complete, or ``None``.
        notes: The lines the servos' calibration at the start gave
            (``servo.calibrate_at_start``), to print before the figures.
    """

    class_name: str
    start_cm: np.ndarray
    points: tuple[CheckPoint, ...]
    refined: Extrinsics | None = None
    refined_seen_cm: np.ndarray | None = None
    checked_rms_px: float | None = None
    returned: bool = False
    failure: str | None = None
    notes: tuple[str, ...] = ()

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


def refine_extrinsics(
    ext: Extrinsics, theta_rad: float, shift_cm: npt.ArrayLike, *, rms_px: float
) -> Extrinsics:
    """The camera moved by R_z(θ) and the table shift: R' = R_z·R, C' = R_z·C + (t, 0).

    The result is marked ``refined_by_arm`` and carries ``rms_px``, the moved pose's own
    residual over the arm's points (:func:`refit_pose`): the markers' error the pose was
    fitted with no longer describes it, and a calibration file is replaced only by one
    whose ``rms_px`` is no higher, so keeping the markers' let every refined pose replace
    the pose it refined.
    """
    Rz = np.eye(3)
    Rz[:2, :2] = _rz2(theta_rad)
    t = np.asarray(shift_cm, dtype=float).reshape(2)
    return dataclasses.replace(
        ext,
        rotation=Rz @ ext.rotation,
        position_cm=Rz @ ext.position_cm + np.array([t[0], t[1], 0.0]),
        rms_px=rms_px,
        refined_by_arm=True,
        date=today(),
    )


def points_rms_px(
    camera: PerspectiveCamera, seen_px: npt.ArrayLike, points_cm: npt.ArrayLike, z_cm: float
) -> float:
    """RMS distance [px] between pixels seen (k, 2) and where ``camera`` projects points.

    ``points_cm``: (x, y) [cm], (k, 2), on the plane z = ``z_cm``: a pose's reprojection
    error over the arm's check points, in the unit of a marker fit's ``rms_px``.
    """
    seen = np.asarray(seen_px, dtype=float).reshape(-1, 2)
    projected = camera.table_to_pixel(np.asarray(points_cm, dtype=float).reshape(-1, 2), z_cm)
    return float(np.sqrt(np.mean(np.sum((projected - seen) ** 2, axis=1))))


def refit_pose(
    camera: PerspectiveCamera, seen_cm: npt.ArrayLike, commanded_cm: npt.ArrayLike, z_cm: float
) -> tuple[Extrinsics, float, tuple[float, np.ndarray]]:
    """The camera's pose refined by the check points, and the residuals of both poses.

    Args:
        camera: The camera checked.
        seen_cm: Where it saw the object's top (x, y) [cm], (k, 2), k ≥ 2.
        commanded_cm: Where the arm set the object down (x, y) [cm], (k, 2).
        z_cm: The height of the object's top, where it was seen [cm].

    Returns:
        The refined pose (its ``rms_px`` its residual over the points), the checked
        pose's residual over the same points [px], and the motion (θ [rad], t [cm])
        that moved it (:func:`fit_planar_rigid`).
    """
    seen = np.asarray(seen_cm, dtype=float).reshape(-1, 2)
    commanded = np.asarray(commanded_cm, dtype=float).reshape(-1, 2)
    theta, t = fit_planar_rigid(seen, commanded)
    seen_px = camera.table_to_pixel(seen, z_cm)  # where the object's top was in the frames
    checked_px = points_rms_px(camera, seen_px, commanded, z_cm)
    # the moved camera projects X where this one projects R_zᵀ(X − t) (module docstring)
    refined_px = points_rms_px(camera, seen_px, (commanded - t) @ _rz2(theta), z_cm)
    refined = refine_extrinsics(camera.extrinsics, theta, t, rms_px=refined_px)
    return refined, checked_px, (theta, t)


# --------------------------------------------------------------------- moving the object


@dataclass(frozen=True)
class Refusal:
    """A move of the object that was not made, because part of it could not be planned.

    Attributes:
        why: The step that could not be planned, and the planner's reason.
        taking_up: Whether it was taking the object up where it lies (then it cannot
            leave that place), rather than putting it down at the point.
    """

    why: str
    taking_up: bool


#: A route planned, and the world it was planned in (sets the collision model's).
_Planned = tuple[Route, Callable[[], None]]


class _Arm:
    """Moves one object with the sort's planner, collision model and executor.

    Every route is planned in full, and checked against the bins, the table and the
    other objects (``others``: ``(id, class, x_cm, y_cm)`` each), before the first is
    sent; the object moved is :data:`MOVED_ID` to the collision model.
    """

    def __init__(
        self,
        config: Config,
        planner: Planner,
        executor: Executor,
        cls: ColorClass,
        others: Sequence[tuple[str, str, float, float]],
    ):
        assert planner.collision is not None
        self.config = config
        self.planner = planner
        self.collision = planner.collision
        self.ex = executor
        self.cls = cls
        self.others = list(others)

    def _lying_at(self, xy_cm: npt.ArrayLike) -> None:
        """The collision model's world: the object on the table at ``xy_cm``, jaws open."""
        x, y = (float(v) for v in np.asarray(xy_cm, dtype=float))
        self.collision.set_world(
            [*self.others, (MOVED_ID, self.cls.name, x, y)],
            opening_cm=self.config.arm.tool.gripper.open_cm,
        )

    def _holding(self) -> None:
        """The collision model's world: the object in the jaws, closed on it."""
        self.collision.set_world(
            self.others, opening_cm=self.cls.diameter_cm, held=(MOVED_ID, self.cls.name)
        )

    def _above(self, target: IKTarget) -> IKTarget:
        """Where a route down to ``target`` starts and the way up from it ends."""
        p, h = self.planner, self.config.task.approach_height_cm
        return p.above_target(target, h) if h is not None else p.lift_target(target)

    def _plan(
        self, steps: Sequence[tuple[str, IKTarget, Callable[[], None], str | None]], q: np.ndarray
    ) -> tuple[list[_Planned], str | None]:
        """Plan ``steps`` in turn, each from where the one before ends.

        Each step: its name, its target, the world it moves in (sets the collision model's)
        and what its jaws close on (``None``: nothing). Returns the routes planned, each
        with its world, and the first failure (``None``: every step planned).
        """
        planned: list[_Planned] = []
        for step, target, world, closes_on in steps:
            world()
            route = Route(MOVED_ID, self.cls.name, step, 1, target)  # type: ignore[arg-type]
            if not self.planner.plan(route, q, target=closes_on).planned:
                where = ", ".join(f"{v:.2f}" for v in target.position_cm)
                return planned, f"{step} to ({where}) cm cannot be planned: {route.failure}"
            assert route.plan is not None
            q = route.plan.q
            planned.append((route, world))
        return planned, None

    def plan_take_up(
        self, at_cm: npt.ArrayLike, q: np.ndarray
    ) -> tuple[list[_Planned], str | None]:
        """Plan taking the object up where it lies at ``at_cm``, from pose ``q``.

        Above it (with ``task.approach_height_cm``), down around it, and up with it: the
        routes planned, each with its world, and the first failure (``None``: all planned).
        """
        pick = self.planner.pick_target(self.cls, *np.asarray(at_cm, dtype=float))
        lying = partial(self._lying_at, at_cm)
        steps: list[tuple[str, IKTarget, Callable[[], None], str | None]] = []
        if self.config.task.approach_height_cm is not None:
            steps.append(("approach", self._above(pick), lying, None))
        steps += [("pick", pick, lying, MOVED_ID), ("lift", self._above(pick), self._holding, None)]
        return self._plan(steps, q)

    def takes_up_at(self, at_cm: npt.ArrayLike) -> bool:
        """Whether the object lying at ``at_cm`` can be taken up from home."""
        return self.plan_take_up(at_cm, self.planner.model.home)[1] is None

    def may_take_up_at(self, at_cm: np.ndarray) -> np.ndarray:
        """Whether taking up the object is worth planning at each of ``at_cm``, (k,) bool.

        ``False`` where no joints reach its pick or the point above it (one batch solve,
        :meth:`Planner.reaches <mearm.task.plan.Planner.reaches>`): there
        :meth:`takes_up_at` would be ``False`` too, after every start of the solver's
        recovery.
        """
        picks = [self.planner.pick_target(self.cls, float(x), float(y)) for x, y in at_cm]
        above = [self._above(pick) for pick in picks]
        ok = self.planner.reaches([*picks, *above])
        return ok[: len(picks)] & ok[len(picks) :]

    def transfer(self, from_cm: npt.ArrayLike, to_cm: npt.ArrayLike) -> Refusal | None:
        """Take the object at ``from_cm`` to ``to_cm`` and go home; what refused it, or ``None``.

        Every route (above, down, up, across, down, up) is planned in full, each from
        where the one before ends, before the first is sent.
        """
        taking, failure = self.plan_take_up(from_cm, self.ex.q_now())
        if failure is not None:
            return Refusal(failure, taking_up=True)
        place = self.planner.pick_target(self.cls, *np.asarray(to_cm, dtype=float))
        lying = partial(self._lying_at, to_cm)
        putting, failure = self._plan(
            [("approach", self._above(place), self._holding, None),
             ("pick", place, self._holding, None),
             ("lift", self._above(place), lying, MOVED_ID)],  # the open jaws around it
            taking[-1][0].plan.q,  # type: ignore[union-attr]
        )  # fmt: skip
        if failure is not None:
            return Refusal(failure, taking_up=False)
        # the jaws open on the way to the object and up from the spot, closed between
        closed = [False] * (len(taking) - 1) + [True, True, True, False]
        timed, failure = self._followed([*taking, *putting], closed)
        if failure is not None:
            return Refusal(failure, taking_up=len(timed) < len(taking))
        ex = self.ex
        routes = [(route, t) for (route, _), t in zip([*taking, *putting], timed, strict=True)]
        *to_pick, lift = routes[: len(taking)]
        across, down, up = routes[len(taking) :]
        for route, t in to_pick:
            ex.stream(route, "travel", closed=False, timed=t)
        ex.set_tool("grip", closed=False)
        ex.set_tool("grip", closed=True)
        ex.set_tool("travel", closed=True)
        for route, t in (lift, across, down):
            ex.stream(route, "travel", closed=True, timed=t)
        ex.set_tool("grip", closed=True)  # the jaws come down around the spot, then open
        ex.set_tool("grip", closed=False)
        # straight up, the open jaws clear of the object
        ex.stream(up[0], "grip", closed=False, timed=up[1])
        self.home(to_cm)
        return None

    def _followed(
        self, planned: Sequence[_Planned], closed: Sequence[bool]
    ) -> tuple[list[TimedPath], str | None]:
        """Each route's commands as the servos follow them, all checked before any is sent.

        Between two commands the servos move on the chord between them, which cuts a
        corner of the plan (:meth:`Executor.followed
        <mearm.task.execute.Executor.followed>`): each route's chords are checked in the
        world it was planned in, as the sort's are (``closed``: whether the jaws hold the
        object along each, its speed limits then). The timed commands up to the first
        route not followed clear, and why it is not (``None``: every one is).
        """
        timed: list[TimedPath] = []
        for (route, world), holds in zip(planned, closed, strict=True):
            world()
            try:
                timed.append(self.ex.followed(route, carrying=holds))
            except CollisionError as exc:
                return timed, str(exc)
        return timed, None

    def home(self, left_at_cm: npt.ArrayLike) -> None:
        """Home the sort's checked way (:func:`~mearm.task.homing.go_home`), the gripper open.

        Checked in the world the set-down left: the object lying at ``left_at_cm``, the
        jaws open. Where no way home is clear, nothing more is sent.

        Raises:
            CollisionError: no way home is clear; the arm stays where it is.
        """
        self._lying_at(left_at_cm)
        go_home(self.ex, self.planner, closed=False)


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


def room_cells(slip_cm: float = SET_DOWN_SLIP_CM) -> list[tuple[int, int]]:
    """The lattice steps around a point where its room is checked, nearest first.

    The point itself and every lattice point of the square of half-side ``slip_cm``
    around it (rounded up to whole pitches of :data:`LATTICE_CM`).
    """
    k = math.ceil(slip_cm / LATTICE_CM - 1e-9)
    cells = [(i, j) for i in range(-k, k + 1) for j in range(-k, k + 1)]
    return sorted(cells, key=lambda c: (c[0] ** 2 + c[1] ** 2, c))


def _hidden_by_arm(
    config: Config, geometry: CameraGeometry, arm: _Arm, cand: np.ndarray
) -> np.ndarray:
    """Which candidates (x, y) [cm], (k, 2), the arm at home hides from the camera, (k,) bool.

    The object, wherever within :data:`SET_DOWN_SLIP_CM` of the candidate a set-down
    leaves it (its centre, and a ring around its footprint at the table and at its top),
    must show clear of the arm's body in the frame (:mod:`mearm.vision.arm_mask`), and
    inside the frame: an object the arm hides in part is not found, or found off its
    place. A homography knows nothing of bodies above the table: none is hidden.
    """
    body = arm_view(
        geometry, arm.planner.model, arm.collision.bodies,
        opening_cm=config.arm.tool.gripper.open_cm,
    )  # fmt: skip
    if body is None or not len(cand):
        return np.zeros(len(cand), dtype=bool)
    assert isinstance(geometry, PerspectiveCamera)
    w, h = config.camera.width_px, config.camera.height_px
    shown = body.mask(arm.planner.model.home, (h, w)) > 0
    r = arm.cls.footprint_radius_cm + SET_DOWN_SLIP_CM * math.sqrt(2)
    a = np.linspace(0.0, 2 * math.pi, RIM_POINTS, endpoint=False)
    ring = np.vstack([np.zeros(2), r * np.column_stack([np.cos(a), np.sin(a)])])
    xy = (cand[:, None, :] + ring[None, :, :]).reshape(-1, 2)
    points = np.concatenate(
        [np.column_stack([xy, np.full(len(xy), z)]) for z in (0.0, arm.cls.height_cm)]
    )
    u, v = np.round(geometry.project(points)).astype(int).T
    outside = (u < 0) | (u >= w) | (v < 0) | (v >= h)
    hidden = outside | shown[np.clip(v, 0, h - 1), np.clip(u, 0, w - 1)]
    return hidden.reshape(2, len(cand), len(ring)).any(axis=(0, 2))


def _near_reach(cells: np.ndarray, takes_up: Callable[[tuple[int, int]], bool]) -> np.ndarray:
    """Which of ``cells`` (lattice indices, (k, 2)) lie where the arm reaches, (k,) bool.

    A survey of every m-th lattice point (m chosen so that it checks about
    :data:`SURVEY_POINTS` of them) finds where the object can be taken up; a cell counts
    when it lies within m - 1 steps (along x and y) of a surveyed point that can. The
    grid's nodes spread over these, and search only these: nodes over the whole view
    would lie out of reach, and search through every pose the arm cannot take.
    """
    if not len(cells):
        return np.zeros(0, dtype=bool)
    m = max(1, round(math.sqrt(len(cells) / SURVEY_POINTS)))
    # the survey's lattice is centred on the cells' box so that it spans them evenly
    mid = (cells.min(axis=0) + cells.max(axis=0)) // 2
    on = np.all((cells - mid) % m == 0, axis=1)
    reached = np.array(
        [c for c in cells[on] if takes_up((int(c[0]), int(c[1])))], dtype=int
    ).reshape(-1, 2)
    if not len(reached):
        return np.zeros(len(cells), dtype=bool)
    steps = np.abs(cells[:, None, :] - reached[None, :, :]).max(axis=2).min(axis=1)
    return steps < m


def check_points(config: Config, geometry: CameraGeometry, arm: _Arm, n: int) -> np.ndarray:
    """``n`` check points on a grid over the reachable part of the camera's view, (n, 2) [cm].

    A candidate (a lattice point of :data:`LATTICE_CM`) lies one object diameter inside
    the camera's view, the open jaws around it clear every bin's footprint and every
    other object (``arm.others``), and the arm at home hides no part of an object set
    down there (:func:`_hidden_by_arm`). It is taken only where the object lying there, or at
    any lattice point within :data:`SET_DOWN_SLIP_CM` of it along x and y
    (:func:`room_cells`), can be taken up from home
    (:meth:`_Arm.takes_up_at`, checked against the bins, the table and the other
    objects): wherever a set-down leaves it, the next move can pick it. Each lattice
    point is planned once, shared by the candidates around it. The grid has ⌊√n⌋ rows
    over the candidates' extent; each node takes the nearest candidate not taken.

    Raises:
        NothingToCheck: fewer than ``n`` candidates.
    """
    cls = arm.cls
    reach = jaw_reach_cm(config)
    x0, x1, y0, y1 = _field_cm(geometry, config, cls.diameter_cm)
    ix = np.arange(math.ceil(x0 / LATTICE_CM), math.floor(x1 / LATTICE_CM) + 1)
    iy = np.arange(math.ceil(y0 / LATTICE_CM), math.floor(y1 / LATTICE_CM) + 1)
    cells = np.array([(i, j) for j in iy for i in ix], dtype=int).reshape(-1, 2)
    cand = cells * LATTICE_CM
    keep = np.ones(len(cand), dtype=bool)
    for c in config.task.classes:
        half = c.bin_inner_width_cm / 2 + reach
        keep &= ~(
            (np.abs(cand[:, 0] - c.bin_cm[0]) <= half) & (np.abs(cand[:, 1] - c.bin_cm[1]) <= half)
        )
    for _, color, ox, oy in arm.others:
        r = config.task.class_named(color).footprint_radius_cm
        keep &= np.hypot(cand[:, 0] - ox, cand[:, 1] - oy) >= reach + r
    keep[keep] = ~_hidden_by_arm(config, geometry, arm, cand[keep])
    cells, cand = cells[keep], cand[keep]
    around = room_cells()
    takes: dict[tuple[int, int], bool] = {}

    def takes_up(cell: tuple[int, int]) -> bool:
        if cell not in takes:
            at = np.array(cell, dtype=float) * LATTICE_CM
            takes[cell] = bool(arm.may_take_up_at(at[None])[0]) and arm.takes_up_at(at)
        return takes[cell]

    def has_room(k: int) -> bool:
        i, j = (int(v) for v in cells[k])
        room = [(i + di, j + dj) for di, dj in around]
        if any(takes.get(c) is False for c in room):  # a refusal known: nothing to plan
            return False
        return all(takes_up(c) for c in room)

    near = _near_reach(cells, takes_up)
    cells, cand = cells[near], cand[near]
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
            for idx in order:
                if int(idx) not in chosen and has_room(int(idx)):
                    chosen.append(int(idx))
                    break
    if len(chosen) < n:
        raise NothingToCheck(
            f"found room for {len(chosen)} of {n} check points in the camera's view that the "
            f"arm reaches, with {SET_DOWN_SLIP_CM:g} cm around each for a set-down's slip, "
            "clear of the bins, the other objects and the arm at home: "
            + _making_room(config, len(chosen), cls.name, len(arm.others))
        )
    return cand[chosen]


def _making_room(config: Config, found: int, class_name: str, others: int) -> str:
    """What makes room for the check's points, where ``found`` fit (fewer than asked).

    Fewer points, where at least :data:`MIN_POINTS` fit; fewer objects, where ``others``
    lie on the table besides the one of ``class_name`` the check takes (a simulated
    table's are its config's, ``task.scene``).
    """
    ways = [f"ask for --points {found}"] if found >= MIN_POINTS else []
    if others and config.simulated_table:
        ways.append(
            "leave only the object taken on the simulated table: "
            f"--set 'task.scene=[{{color: {class_name}, x: X, y: Y}}]'"
        )
    elif others:
        ways.append("take the other objects off the table")
    return " or ".join(ways) or "the camera's view and the arm's reach hold no more"


# --------------------------------------------------------------------- the check


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
    calibrate_first: CalibrateFirst | None = None,
) -> ArmCheck:
    """Open the rig, run the arm's check of the camera, put the object back, close the rig.

    Args:
        config: The whole configuration.
        points: How many check points (:data:`MIN_POINTS` … :data:`MAX_POINTS`).
        class_name: Take an object of this class (default: the first detected).
        refine: Also fit the camera pose to the points (needs a perspective calibration).
        echo: Called with one line per step (``None``: silent).
        calibrate_first: Calibrates servos never calibrated, the arm at home, before the
            object is looked for, where ``servo.calibrate_at_start`` asks for it, as the
            sort's does (:func:`mearm.maker.camera_calibration.at_start.for_config`);
            ``None``: the command cannot (a note says so, and the check uses the arm's
            nominal calibration).

    Raises:
        ArmCheckError: a bad argument (before the rig opens).
        ConfigError: ``servo.calibrate_at_start`` on a rig without what it needs (before
            the rig opens).
        NothingToCheck: no object of the class on the table, or no room for the points
            (before anything but going home, and the servos' calibration, moves).
        StartCalibrationFailed: the servos' calibration at the start gave none.
        CalibrationError: ``refine`` without a perspective calibration.
        RigNotOpened: the camera or the servo bus did not open (before anything moves).
        CheckInterrupted: Ctrl-C once the rig is open (the arm stays where it is).
        CollisionError: no way home from a set-down is clear (``not parked: the way
            home …``): nothing more is sent, the arm stays above the object.
        ServoError, CameraError: a fault once the rig is open.
    """
    say = echo if echo is not None else (lambda _line: None)
    geometry = _checked_geometry(config, points, class_name, refine=refine)
    check_calibrate_at_start(config)  # before anything moves, as the sort's
    detector = ColorDetector(config.vision, geometry, config.task.classes)
    opened = False
    try:
        with open_rig(config) as rig:  # its camera open and its bus connected
            opened = True
            try:
                check = _check(
                    config, rig, geometry, detector, points=points, class_name=class_name,
                    refine=refine, calibrate_first=calibrate_first, say=say,
                )  # fmt: skip
            except KeyboardInterrupt as exc:
                interrupts.answered()
                state = rig.bus.state
                pose = "none (no move acknowledged yet)" if state is None else str(state)
                raise CheckInterrupted(
                    f"interrupted ({interrupts.named(exc)}); the arm stays where it is, "
                    f"nothing more sent to the servos (last acknowledged pose: {pose})"
                ) from None
    except (CameraError, ServoError) as exc:
        if opened:
            raise
        raise RigNotOpened(str(exc)) from exc
    return check


def _check(
    config: Config,
    rig: Rig,
    geometry: CameraGeometry,
    detector: ColorDetector,
    *,
    points: int,
    class_name: str | None,
    refine: bool,
    calibrate_first: CalibrateFirst | None,
    say: Callable[[str], None],
) -> ArmCheck:
    """:func:`run_check`'s work on the open rig."""
    Executor(config, rig.bus, rig.model).home_pose()
    config, model, notes = _servos_calibrated(config, rig, calibrate_first)
    for line in notes:
        say(line)
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm)
    planner = Planner(config, model, collision)
    # each route's commands checked as the servos follow them, chord by chord, as the sort's
    ex = Executor(config, rig.bus, model, collision=collision)
    if model is not rig.model:  # home as the fit has it, the checked way (no object known yet)
        collision.set_world([], opening_cm=config.arm.tool.gripper.open_cm)
        go_home(ex, planner, closed=False)
    found = _table_detections(detector, config, rig.camera.read())
    obj = _chosen_object(found, class_name)
    cls = config.task.class_named(obj.color)
    assert obj.table_cm is not None
    start = np.array(obj.table_cm, dtype=float)
    others = _other_objects(found, obj)
    others_xy = np.array([xy for *_, xy in others], dtype=float).reshape(-1, 2)
    arm = _Arm(config, planner, ex, cls, [(i, c, *xy) for i, c, xy in others])
    targets = check_points(config, geometry, arm, points)
    say(f"object: {cls.name} at ({start[0]:.2f}, {start[1]:.2f}) cm")
    visit = _visit_points(arm, rig.camera, detector, config, start, targets, others_xy, say)
    returned = False
    failure = visit.failure
    if failure is None:
        refusal = arm.transfer(visit.here, start)
        returned = refusal is None
        if refusal is not None:
            failure = f"the object was not put back: {refusal.why}"
    refined = refined_seen = checked_px = None
    measured = [r for r in visit.records if r.seen_cm is not None]
    if refine and len(measured) >= 2:
        assert isinstance(geometry, PerspectiveCamera)
        refined, checked_px, refined_seen = _refit_pose(
            config, geometry, cls, measured, visit.frames, others_xy
        )
    return ArmCheck(
        class_name=cls.name,
        start_cm=start,
        points=tuple(visit.records),
        refined=refined,
        refined_seen_cm=refined_seen,
        checked_rms_px=checked_px,
        returned=returned,
        failure=failure,
        notes=tuple(notes),
    )


def _servos_calibrated(
    config: Config, rig: Rig, calibrate_first: CalibrateFirst | None
) -> tuple[Config, ArmModel, list[str]]:
    """The sort's calibration at the start (``servo.calibrate_at_start``), the arm at home.

    Servos never calibrated are calibrated by the camera as the sort's are
    (:meth:`mearm.task.sorter.Sorter.run`): the config and the arm model to check with
    (its limits narrowed where the fit says so; the caller takes the arm home in it, the
    checked way), and the lines to print. Else ``config``, ``rig.model`` and a note at most.

    Raises:
        StartCalibrationFailed: the fit did not converge or was refused.
        ServoError: a fault while moving.
    """
    if not calibrates_at_start(config):
        return config, rig.model, []
    if calibrate_first is None:
        return config, rig.model, [
            "note: servo.calibrate_at_start: this command does not calibrate the servos "
            "first; the check uses the arm's nominal calibration"
        ]  # fmt: skip
    config, lines = calibrate_first(config, rig.camera, rig.bus, rig.model, simulated=rig.simulated)
    return config, ArmModel(config.arm), lines


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


def _other_objects(found: list[Detection], obj: Detection) -> list[tuple[str, str, np.ndarray]]:
    """The other objects seen: an id for the collision model, the class, the centre [cm]."""
    others = []
    for k, d in enumerate((d for d in found if d is not obj), 1):
        assert d.table_cm is not None
        others.append((f"seen{k}", d.color, np.array(d.table_cm, dtype=float)))
    return others


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
    start: np.ndarray,
    targets: np.ndarray,
    others_xy: np.ndarray,
    say: Callable[[str], None],
) -> _Visit:
    """Move the object to each target in turn and find it there.

    A point the object cannot be put down at is skipped; the check stops at the first
    loss: the object not seen after a set-down, or where it lies, not to be taken up.
    """
    cls = arm.cls
    visit = _Visit(records=[], frames=[], here=start, failure=None)
    for k, target in enumerate(targets, 1):
        refusal = arm.transfer(visit.here, target)
        if refusal is not None and refusal.taking_up:
            x, y = visit.here
            why = f"the object at ({x:.2f}, {y:.2f}) cm cannot be taken up: {refusal.why}"
            visit.failure = f"point {k}: {why}"
            visit.records.append(CheckPoint(target, failure=why))
            break
        if refusal is not None:
            visit.records.append(CheckPoint(target, failure=refusal.why))
            say(f"point {k}: skipped: {refusal.why}")
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
) -> tuple[Extrinsics, float, np.ndarray]:
    """Fit the camera pose to the measured points and find the object again with it.

    The refined pose, the checked pose's residual over the points [px]
    (:func:`refit_pose`), and where the refined camera sees the object, (k, 2) [cm].
    """
    seen_xy = np.array([r.seen_cm for r in measured], dtype=float)
    commanded = np.array([r.commanded_cm for r in measured], dtype=float)
    refined, checked_px, (theta, t) = refit_pose(geometry, seen_xy, commanded, cls.height_cm)
    relocate = ColorDetector(config.vision, geometry.with_extrinsics(refined), config.task.classes)
    seen_again = []
    for r, frame in zip(measured, frames, strict=True):
        d = _find(_table_detections(relocate, config, frame), cls, r.commanded_cm,
                  _moved(others_xy, theta, t))  # fmt: skip
        seen_again.append(np.full(2, np.nan) if d is None else d.table_cm)
    return refined, checked_px, np.array(seen_again, dtype=float).reshape(-1, 2)


def _moved(points_cm: np.ndarray, theta: float, t: np.ndarray) -> np.ndarray:
    """Points (k, 2) moved by R_z(θ) and t, as the refined camera sees them."""
    return points_cm @ _rz2(theta).T + t if len(points_cm) else points_cm
