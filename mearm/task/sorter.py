"""The sorting loop: look → choose → plan → execute → report, until the table is clear.

The loop reads the table after every object, takes the classes in the order the config
lists them (within a class, first an object whose open jaws come down clear of every
neighbour, then the nearest) or, with ``task.order: nearest``, the clear object nearest
the TCP whatever its class, and starts each route where the last one ended (the arm
does not go home between objects; when an object seen before is missing from a look,
the arm goes home, out of the camera's way, and looks again before it concludes). Each
route is planned in full first (:mod:`mearm.task.plan`); only a converged plan is sent to the servos
(:mod:`mearm.task.execute`), pose by pose, paced by the bus; what happened goes to the
screen and the run log (:mod:`mearm.task.report`).

Every route is checked against the arm's body, the bins and the objects on the table
(:class:`~mearm.kinematics.collision.CollisionModel`, kept up to date with what the
camera saw, the jaws' opening and the object they hold) and detoured or refused before
anything of it moves. An object whose pick is refused for a collision (a neighbour under
the hand) waits until the others are taken, and is left (``collision``) only when no
other can go first. Objects whose pick cannot be planned (out of reach, outside the
target box, no converged solve) are reported and skipped; a failed grip (the object is still on the
table in the frame taken once the arm is over the bin, where it hides nothing) is
retried ``task.pick_retries`` times, whatever the jaws hold being let go back over its
spot. A camera or servo
failure, or Ctrl-C, parks the arm where it is safe to (home, if the servo link still
answers; otherwise nothing more is sent), writes the reason to the run log and raises
:class:`SortAborted`. A black frame, a frozen stream (:mod:`mearm.vision.frame_check`)
and objects that moved between two looks though the arm went near none of them (the
camera was knocked: its calibration no longer holds) are camera failures.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from mearm.config import Config
from mearm.config.classes import ColorClass
from mearm.config.shape_catalogue import SHAPES
from mearm.errors import MearmError
from mearm.hardware.bus import ReportsRelease, ServoBus
from mearm.hardware.errors import ServoError
from mearm.ik import IKTarget
from mearm.kinematics import ArmModel
from mearm.kinematics.bodies import M_PER_CM
from mearm.kinematics.collision import TOUCH_M, CollisionModel
from mearm.task.claw_loop import GOOD_ENOUGH_CM, MAX_LOOKS, claw_eye, shifted
from mearm.task.execute import Executor, View
from mearm.task.plan import Planner
from mearm.task.report import Outcome, Reporter, Skip, SortReport
from mearm.task.route import Route
from mearm.vision import Camera, ColorDetector, Detection
from mearm.vision.calibration import camera_geometry
from mearm.vision.errors import CameraError
from mearm.vision.frame_check import FrameCheck
from mearm.vision.tracking import Missing, explain, nearest_pairs
from mearm.vision.tracking import Seen as Sighting

if TYPE_CHECKING:
    from mearm.runlog.writer import RunLog  # a log is written only when asked for

#: A detection within this distance of a known object is that object [cm].
SAME_OBJECT_CM = 1.5
#: Objects the arm did not go for that all move farther than this between two looks, the
#: same way, mean the view moved (the camera was knocked) [cm]: a detection's jitter is a
#: few tenths of a pixel (0.0625 cm a pixel at the paper's calibration).
VIEW_SHIFT_CM = 0.5
#: How closely their shifts must agree to be one move of the view [cm] (one object moved
#: alone may be the arm's doing: a jaw that caught it).
SAME_SHIFT_CM = 0.3
#: An object whose region grew or shrank by more than this fraction since the last look
#: is partly hidden (by the arm) in one of them: its centroid moved for that [-].
SAME_AREA_RATIO = 0.15


class CollisionError(MearmError):
    """A motion would bring the arm's body too close to something; nothing of it was sent.

    Too close: within ``task.clearance_cm`` of a bin or an object, or touching the table
    (:mod:`mearm.kinematics.collision`).
    """


class EpisodeRecorder(Protocol):
    """Records the run as episodes (:class:`mearm.dataset.DatasetRecorder`).

    The sorter opens an episode as a pick-and-place of an object of ``class_name``
    starts, ends it when the pick-and-place ends, ends the run after the last one, and
    abandons the episode a fault or Ctrl-C cuts short.
    """

    def begin(self, class_name: str) -> None: ...  # noqa: D102
    def end(self) -> None: ...  # noqa: D102
    def end_run(self) -> None: ...  # noqa: D102
    def abandon(self) -> None: ...  # noqa: D102


class SortAborted(MearmError):
    """The sort stopped before the table was clear.

    Attributes:
        reason: One line: what failed.
        interrupted: Whether it was Ctrl-C.
        last_joints: The last confirmed joints by name [deg or cm], or ``None``.
        outcome: What was sorted before it stopped (the summary's counts), or ``None``.
    """

    def __init__(
        self,
        reason: str,
        *,
        interrupted: bool = False,
        last_joints: dict[str, float] | None = None,
        outcome: Outcome | None = None,
    ):
        self.reason = reason
        self.interrupted = interrupted
        self.last_joints = last_joints
        self.outcome = outcome
        super().__init__(reason)


@dataclass
class TrackedObject:
    """An object seen on the table, followed from frame to frame by its position."""

    id: str
    class_name: str
    x_cm: float
    y_cm: float
    failed_picks: int = 0
    skipped: str | None = None
    skip_kind: str | None = None
    sorted: bool = False
    #: Why its pick was refused for a collision since the last object was sorted (others
    #: go first), or ``None``.
    blocked: str | None = None
    #: Whether the last look saw it as a region of touching objects (or one the arm hid
    #: in part, or one cut by the image border): not picked while so; left as ``merged``
    #: (or ``cut``) when nothing else is left.
    merged: bool = False
    #: A cube's yaw on the table at the last look [deg, 0–90), or ``None``: the jaws
    #: turn to its faces where the arm can turn them (:meth:`Planner.turn_jaws`).
    yaw_deg: float | None = None
    #: Its region's area at the last look [px].
    area_px: int = 0
    #: The path (x, y) [cm], (k, 2), its TCP carried it along to its bin, while no
    #: simulator has confirmed the release (the twin, a real rig): an object of its class
    #: seen new near that path is it, dropped on the way (:meth:`Sorter._dropped`).
    carried_cm: np.ndarray | None = None


Seen = list[tuple[Detection, np.ndarray]]


class Sorter:
    """Runs the sort on one table.

    Args:
        config: The whole configuration.
        camera: Frame source (``read()`` returns BGR).
        bus: A servo bus; :meth:`run` connects it if needed.
        model: Arm model (built from ``config.arm`` if omitted).
        log: Run log to write routes, skips, faults and the summary to.
        view: Meshcat view to update, or ``None``.
        echo: Called with one line per route and the summary (default: print).
        trial: Trial number for the run log.
        in_bins: In simulation, how many objects of each class lie in its bin (the world,
            or the twin's physics): a place counts only up to that many; ``None`` on a
            real rig (the camera confirms: the object is no longer on the table).
        max_rounds: Pick attempts before the run gives up on a table that never clears
            (default: four per expected object and retry, at least 80 × (retries + 1)).
        recorder: Records each pick-and-place as an episode (``--record``), or ``None``.
    """

    def __init__(
        self,
        config: Config,
        camera: Camera,
        bus: ServoBus,
        *,
        model: ArmModel | None = None,
        log: RunLog | None = None,
        view: View | None = None,
        echo: Callable[[str], None] | None = print,
        trial: int | None = None,
        in_bins: Callable[[], Mapping[str, int]] | None = None,
        max_rounds: int | None = None,
        recorder: EpisodeRecorder | None = None,
    ):
        self.config = config
        self.recorder = recorder
        self.camera = camera
        self.bus = bus
        self.model = model if model is not None else ArmModel(config.arm)
        self.collision = CollisionModel(config, self.model, clearance_cm=config.task.clearance_cm)
        self.planner = Planner(config, self.model, self.collision)
        self.executor = Executor(config, bus, self.model, view)
        self.reporter = Reporter(config, self.model.chain, log, echo, trial)
        self.calibration = camera_geometry(config)
        self.detector = ColorDetector(config.vision, self.calibration, config.task.classes)
        #: The camera watching the claw's marker (picks that look), where the tool carries
        #: one, the camera is calibrated as a perspective one and the config asks for it.
        self.eye = claw_eye(config, self.model, self.calibration, camera.read, bus.hold)
        self.frame_check = FrameCheck(camera.source)
        #: The object the arm last went for (the only one it may have moved since).
        self._active: TrackedObject | None = None
        self._active_from_cm = (0.0, 0.0)
        self.view = view
        self.in_bins = in_bins
        retries = config.task.pick_retries + 1
        self.max_rounds = max_rounds or 4 * (len(config.task.scene) + 20) * retries
        self._objects: list[TrackedObject] = []

    @property
    def report(self) -> SortReport:
        """What the run did so far."""
        return self.reporter.report

    # ----------------------------------------------------------------- vision

    def _look(self, *, track_new: bool = True) -> Seen:
        """Read a frame: what lies on the table, outside the bins.

        An object cut by the image border is in it, seen in part: followed, but not
        picked until seen whole (:meth:`_track`).

        Args:
            track_new: Start following objects not seen before (off while the gripper
                holds one: the camera sees the held object too, away from the table).
        """
        frame = self.camera.read()
        self.frame_check.check(frame, self.camera.frame_time_s, self.camera.clock_s)
        # an object seen in a bin is sorted, not on the table (a camera that sees the
        # bins sees what was put in them)
        found = [(d, _table_cm(d)) for d in self.detector.detect(frame)]
        seen = [(d, p) for d, p in found if not self._in_a_bin(p)]
        self._track(seen, track_new=track_new)
        if self.view is not None:
            self.view.set_camera_frame(frame, self.calibration.pixel_to_table)
            self.view.set_objects(
                [
                    (o.id, o.class_name, o.x_cm, o.y_cm)
                    for o in self._objects
                    if self._on_table(o, seen)
                ]
            )
        return seen

    def _in_a_bin(self, xy_cm: np.ndarray) -> bool:
        """Whether a table point lies inside a class's bin (``ColorClass.in_bin``)."""
        x, y = float(xy_cm[0]), float(xy_cm[1])
        return any(c.in_bin(x, y) for c in self.config.task.classes)

    def _track(self, seen: Seen, *, track_new: bool = True) -> None:
        """Follow the objects seen: each detection is a known object, or a new one.

        Each known object takes the detection of its class nearest where it was, within
        :data:`SAME_OBJECT_CM` (:meth:`_match`). On a look that may start new objects, a
        detection left over is a known object no longer where it was, when one of its
        class is missing (:meth:`_dropped`); only one that none can be is a new object.
        A region cut by the image border, or of touching objects, is followed as
        ``merged``: not picked while so. An object the arm did not go for must not have
        moved.

        Raises:
            CameraError: two or more such objects, seen whole in both looks, all moved
                more than :data:`VIEW_SHIFT_CM` since the last look, by the same shift
                (within :data:`SAME_SHIFT_CM`): the camera was knocked.
        """
        taken = self._match(seen)
        shifts: list[tuple[TrackedObject, np.ndarray]] = []
        for k, known in taken.items():
            det, (x, y) = seen[k]
            if self._untouched(known, det):
                shifts.append((known, np.array([x - known.x_cm, y - known.y_cm])))
        if track_new:
            taken.update(self._dropped(seen, taken))
            for k, (det, _) in enumerate(seen):
                if k not in taken:
                    n = sum(1 for o in self._objects if o.class_name == det.color) + 1
                    taken[k] = TrackedObject(f"{det.color}{n}", det.color, 0.0, 0.0)
                    self._objects.append(taken[k])
        camera = self.config.camera
        for k, known in taken.items():
            det, (x, y) = seen[k]
            known.x_cm, known.y_cm = float(x), float(y)
            if track_new:  # (what the region looked like: the next look tells if it came apart)
                known.area_px = det.area_px
                # one look's merged region may be another's single object: the arm, now
                # elsewhere, hid part of it, or a neighbour picked meanwhile touched it;
                # an object cut by the image border has no centre seen either
                known.merged = det.merged or _cut(det, camera.width_px, camera.height_px)
            if det.yaw_deg is not None:
                known.yaw_deg = det.yaw_deg
        _check_view(shifts, self.camera.source)

    def _dropped(self, seen: Seen, taken: Mapping[int, TrackedObject]) -> dict[int, TrackedObject]:
        """The known objects that the detections :meth:`_match` left over are.

        On a still table nothing brings new objects (:func:`~mearm.vision.tracking.explain`):
        such a detection is a known object of its class that is missing, if one is: on the
        table but not seen where it was (pushed by the jaws, tipped and rolled), or counted
        sorted while no simulator confirmed its release (:attr:`TrackedObject.carried_cm`:
        dropped on the way, or out of its bin again), which is then no longer counted
        sorted and is picked again from where it lies. Those missing from the table come
        before those counted sorted, and the ones the arm went for or may have pushed since
        the last look before the others; the nearest pairs first.
        The other object of a region of touching objects come apart is a new one
        (:func:`_come_apart`).

        Returns:
            The detection's index → the object it is.
        """
        present = {o.id for o in taken.values()}
        missing = [
            o
            for o in self._objects
            if o.id not in present and (not o.sorted or o.carried_cm is not None)
        ]
        apart = _come_apart(seen, taken, self.config)
        left = [k for k in range(len(seen)) if k not in taken and k not in apart]
        pairs = explain(
            [
                Missing(
                    o.class_name,
                    np.array([[o.x_cm, o.y_cm]]) if o.carried_cm is None else o.carried_cm,
                    touched=o is self._active or self._near_active(o),
                    carried=o.sorted,
                )
                for o in missing
            ],
            [Sighting(d.color, float(p[0]), float(p[1])) for d, p in (seen[k] for k in left)],
        )
        found = {}
        for i, j in pairs:
            obj = found[left[j]] = missing[i]
            obj.sorted, obj.carried_cm = False, None
        return found

    def _untouched(self, obj: TrackedObject, det: Detection) -> bool:
        """Whether the arm left ``obj`` alone since the last look and both saw it whole."""
        if obj is self._active or obj.merged or det.merged or self._near_active(obj):
            return False
        # an area that changed: partly hidden (by the arm) in one look, its centroid moved
        return abs(det.area_px - obj.area_px) <= SAME_AREA_RATIO * obj.area_px

    def _near_active(self, obj: TrackedObject) -> bool:
        """Whether ``obj`` lay where the jaws coming down on the active object may push it."""
        if self._active is None:
            return False
        g = self.config.arm.tool.gripper
        r = self.config.task.class_named(obj.class_name).diameter_cm / 2
        x, y = self._active_from_cm
        return bool(np.hypot(obj.x_cm - x, obj.y_cm - y) < g.open_cm / 2 + g.jaw_thickness_cm + r)

    def _match(self, seen: Seen) -> dict[int, TrackedObject]:
        """The known objects seen where they were: detection index → object.

        Each object on the table (not counted sorted) and each detection of its class
        within :data:`SAME_OBJECT_CM` of where it was pair up, the nearest pairs first:
        of two detections near one object, the farther is another object.
        """
        known = [o for o in self._objects if not o.sorted]
        distance = np.full((len(known), len(seen)), np.inf)
        for i, o in enumerate(known):
            for k, (det, (x, y)) in enumerate(seen):
                if det.color == o.class_name:
                    distance[i, k] = float(np.hypot(x - o.x_cm, y - o.y_cm))
        return {k: known[i] for i, k in nearest_pairs(distance, SAME_OBJECT_CM)}

    @staticmethod
    def _on_table(obj: TrackedObject, seen: Seen) -> bool:
        return any(
            d.color == obj.class_name and np.hypot(x - obj.x_cm, y - obj.y_cm) <= SAME_OBJECT_CM
            for d, (x, y) in seen
        )

    def _choose(self, seen: Seen, *, final: bool = False) -> TrackedObject | None:
        """The object to pick next, or ``None``.

        ``final``: the look is from home, the last before the run ends; only then are the
        objects seen as touching others, or cut by the image border, with nothing else
        left to pick, left as merged or cut (from elsewhere the arm may hide part of one).
        """
        candidates = [
            o
            for o in self._objects
            if o.skipped is None and not o.sorted and self._on_table(o, seen)
        ]
        whole = [o for o in candidates if not o.merged]
        if not whole and not final:
            return None  # look again from home, where the arm hides nothing
        camera = self.config.camera
        for o in candidates if not whole else []:  # nothing else left: say why not these
            if _seen_cut(o, seen, camera.width_px, camera.height_px):
                self._skip(o, "cut by the image border: only part of it is seen", kind="cut")
            else:
                why = "touching objects of one class: no single centroid to pick"
                self._skip(o, why, kind="merged")
        candidates = whole
        free = [o for o in candidates if o.blocked is None]
        for o in candidates if not free else []:  # every one waits for another: none can
            self._skip(o, o.blocked or "collision", kind="collision")
        candidates = free
        ee = self.executor.ee_now_cm()

        def nearest(objs: list[TrackedObject]) -> TrackedObject:
            return min(objs, key=lambda o: (np.hypot(o.x_cm - ee[0], o.y_cm - ee[1]), o.id))

        clear = [o for o in candidates if self._jaws_clear(o, candidates)]
        if self.config.task.order == "nearest" and candidates:
            return nearest(clear or candidates)
        for cls in self.config.task.classes:
            of_class = [o for o in candidates if o.class_name == cls.name]
            if not of_class:
                continue
            clear_of_class = [o for o in of_class if o in clear]
            if clear_of_class:
                return nearest(clear_of_class)
            if clear:  # each of this class has a neighbour under the open jaws: clear one
                return nearest(clear)
            return nearest(of_class)
        return None

    def _jaws_clear(self, obj: TrackedObject, others: list[TrackedObject]) -> bool:
        """Whether the open jaws, coming down around ``obj``, touch no other object.

        A jaw's outer face is ``open_cm / 2 + jaw_thickness_cm`` from the object's centre
        (the jaws close along a fixed direction of the wrist, so any side counts).
        """
        g = self.config.arm.tool.gripper
        reach = g.open_cm / 2 + g.jaw_thickness_cm
        for o in others:
            if o is obj:
                continue
            r = self.config.task.class_named(o.class_name).footprint_radius_cm
            if np.hypot(o.x_cm - obj.x_cm, o.y_cm - obj.y_cm) < reach + r:
                return False
        return True

    def _skip(
        self, obj: TrackedObject, reason: str, target: Route | None = None, *, kind: str
    ) -> None:
        obj.skipped = reason
        obj.skip_kind = kind
        where = None if target is None else tuple(float(v) for v in target.target.position_cm)
        self.reporter.skip(Skip(obj.id, obj.class_name, reason, where, kind))  # type: ignore[arg-type]

    # ----------------------------------------------------------------- one object

    def _world(self, held: TrackedObject | None = None, opening_cm: float | None = None) -> None:
        """What the collision checks see: the objects on the table, the jaws, the held one."""
        g = self.config.arm.tool.gripper
        on_table = [
            (o.id, o.class_name, o.x_cm, o.y_cm)
            for o in self._objects
            if not o.sorted and o is not held
        ]
        pair = None if held is None else (held.id, held.class_name)
        self.collision.set_world(on_table, opening_cm=opening_cm or g.open_cm, held=pair)

    def _lift_and_plan_place(
        self, obj: TrackedObject, cls: ColorClass, above: Route | None, pick: Route
    ) -> tuple[Route, float] | None:
        """With ``obj`` held: lift it, then plan the place route in full.

        The lift (when the pick came down from ``above``) comes before anything else
        moves. Where the pick ended within the clearance of something (the object held
        beside a bin's wall), a route out may leave as long as it comes no closer
        (:mod:`mearm.kinematics.collision`). Returns the place route and when its planning
        began (``time.perf_counter``), or ``None`` when no place can be planned: nothing
        unplanned is sent, so the object is put back where it was and skipped, for the
        bin when the bin is out of reach, for the pick when no route leaves where it ended
        without coming closer to what it ended beside.
        """
        ex = self.executor
        if above is not None:
            # straight up from where the jaws closed, to the height it came down from (the
            # point above the target is off the pose by as much as the solver left: that
            # way may bring an object held beside a wall closer to it)
            z = float(above.target.position_cm[2])
            straight_up = self.planner.up_from(ex.q_now(), z, above.target.approach)
            up = Route(obj.id, obj.class_name, "lift", 1, straight_up)
            if self.planner.plan(up, ex.q_now()).planned:
                ex.stream(up, "travel", True)
        t1 = time.perf_counter()
        place = Route(obj.id, obj.class_name, "place", 1, self.planner.place_target(cls))
        self.planner.plan(place, ex.q_now())
        if not place.planned:
            self.reporter.route(pick)
            beside = self.collision.gap(ex.q_now())
            if place.failure_kind == "collision" and beside[0] < TOUCH_M:
                why = _stuck(beside, self.config.task.clearance_cm, place.failure)
                self._skip(obj, why, pick, kind="collision")
            else:
                why = f"bin unreachable: {place.failure}"
                self._skip(obj, why, place, kind="bin_unreachable")
            ex.set_tool("grip", True)
            ex.set_tool("grip", False)
            return None
        return place, t1

    def _pick_and_place(self, obj: TrackedObject) -> None:
        self._active, self._active_from_cm = obj, (obj.x_cm, obj.y_cm)
        cls = self.config.task.class_named(obj.class_name)
        ex = self.executor
        t0 = time.perf_counter()
        xy = np.array([obj.x_cm, obj.y_cm])
        goal = self.planner.pick_target(cls, obj.x_cm, obj.y_cm)
        # picks that look start from the aim the picks nearby needed (claw_loop)
        aim = np.zeros(3)
        if self.eye is not None:
            aim[:2] = self.eye.corrections.guess(xy)
        pick = Route(obj.id, obj.class_name, "pick", obj.failed_picks + 1, shifted(goal, aim))
        self._world()
        above = self._approach(obj, pick)  # planned in full with the pick, before either
        if above is not None and obj.yaw_deg is not None:  # jaws across a cube's faces
            # (the yaw is a square outline's, whatever shape the class names)
            self.planner.turn_jaws(above, obj.yaw_deg, SHAPES["cube"].symmetry_deg)
        if above is None:
            self.planner.plan(pick, ex.q_now(), target=obj.id)
        elif above.planned and above.plan is not None:
            self.planner.plan(pick, above.plan.q, target=obj.id)
        failed = pick if above is None or above.planned else above
        if not failed.planned:
            if failed.failure_kind == "collision" and obj.blocked is None:
                obj.blocked = failed.failure  # another object may clear its way
                return
            self._skip(obj, failed.failure or "no plan", failed, kind=_failure_kind(failed))
            return
        if above is not None:
            ex.stream(above, "travel", False)
            if self.eye is not None:
                pick, aim = self._aim_over(obj, above, pick, aim)
        ex.stream(pick, "travel", False, _hex(cls.draw_rgb))
        if self.eye is not None:
            pick, aim = self._aim_by_eye(obj, above, pick, aim)
            self.eye.corrections.add(xy, aim[:2])
            pick.target = goal  # the pick is judged, and logged, against the object
        ex.finish(pick, t0)  # where the TCP arrived (Table 8's)
        ex.set_tool("grip", False)
        pick.grip_ee_cm = ex.ee_now_cm()  # settled: where the jaws close
        ex.set_tool("grip", True)
        ex.set_tool("travel", True)
        self._world(held=obj, opening_cm=cls.diameter_cm)
        planned = self._lift_and_plan_place(obj, cls, above, pick)
        if planned is None:
            return
        place, t1 = planned
        # Whether the grip held is read once the arm is over the bin: there the camera sees
        # the table unobstructed, and an object held over its own spot (in view of a camera
        # above it) is not taken for one left there. (The paper re-reads the table after
        # each object.) A fault on the way leaves the pick in the log, unconfirmed.
        pick.confirmed = False
        try:
            ex.stream(place, "travel", True, _hex(cls.draw_rgb))
            pick.success = not self._on_table(obj, self._look(track_new=False))
            pick.confirmed = True
        finally:
            self.reporter.route(pick)
        if not pick.success:
            # the jaws hold nothing, or a neighbour: take it back over the spot (not into
            # this bin) and let it go there
            back = above.target if above is not None else self.planner.lift_target(pick.target)
            back_route = Route(obj.id, obj.class_name, "lift", 1, back)
            if self.planner.plan(back_route, ex.q_now()).planned:
                ex.stream(back_route, "travel", True)
            ex.set_tool("travel", False)
            obj.failed_picks += 1
            if obj.failed_picks > self.config.task.pick_retries:
                self._skip(obj, f"pick failed {obj.failed_picks} times", pick, kind="pick_failed")
            return
        ex.set_tool("travel", False)
        release = self.bus.last_release if isinstance(self.bus, ReportsRelease) else None
        place.success = release is None or release.bin == obj.class_name
        obj.sorted = place.success
        if release is None and place.plan is not None:  # unconfirmed: it may have slipped
            obj.carried_cm = np.vstack([[obj.x_cm, obj.y_cm], place.plan.ee_path_cm[:, :2]])
        for o in self._objects:  # the table changed: a blocked pick may be clear now
            o.blocked = None
        t0 = t1
        self.reporter.route(ex.finish(place, t0))

    def _aim_over(
        self, obj: TrackedObject, above: Route, pick: Route, aim: np.ndarray
    ) -> tuple[Route, np.ndarray]:
        """Over the object: look once and aim the way down by what was seen.

        The table-plane error seen here shifts the pick route before the jaws come down
        around the object. Returns the route down (replanned where the aim changed; kept
        where the new one cannot be planned) and the aim [cm], (3,).
        """
        assert self.eye is not None
        ex = self.executor
        look = self.eye.look(ex.q_now())
        if look is None:
            return pick, aim
        off = aim[:2] + look.error_cm[:2]  # where the claw is, less where it should be
        if np.linalg.norm(off) < GOOD_ENOUGH_CM:
            return pick, aim
        step = np.array([-off[0], -off[1], 0.0])
        down = Route(obj.id, obj.class_name, "pick", pick.attempt,
                     shifted(pick.target, step))  # fmt: skip
        if not self.planner.plan(down, ex.q_now(), target=obj.id).planned:
            return pick, aim
        return down, aim + step

    def _aim_by_eye(
        self, obj: TrackedObject, above: Route | None, pick: Route, aim: np.ndarray
    ) -> tuple[Route, np.ndarray]:
        """With the open jaws round the object: look at the claw and correct the aim.

        :mod:`mearm.task.claw_loop`. Each correction goes back up to the point above the
        object and down again to the corrected pick, so that every look sees the claw
        after the same final move (the gears' play and dead band then leave the same
        error each time, and the correction takes it out), a few times at most. A
        correction that cannot be planned in full is not made: the arm stays where it is.

        Returns:
            The pick route the arm is on now and the aim's shift [cm], (3,).
        """
        assert self.eye is not None
        ex = self.executor
        for _ in range(MAX_LOOKS):
            look = self.eye.look(ex.q_now())
            if look is None:
                break
            off = aim[:2] + look.error_cm[:2]  # where the claw is, less where it should be
            if np.linalg.norm(off) < GOOD_ENOUGH_CM or above is None:
                break
            step = np.array([-off[0], -off[1], 0.0])
            up = Route(obj.id, obj.class_name, "approach", pick.attempt,
                       shifted(above.target, step))  # fmt: skip
            down = Route(obj.id, obj.class_name, "pick", pick.attempt,
                         shifted(pick.target, step))  # fmt: skip
            if not self.planner.plan(up, ex.q_now(), target=obj.id).planned:
                break
            if obj.yaw_deg is not None:  # the jaws stay across a cube's faces
                self.planner.turn_jaws(up, obj.yaw_deg, SHAPES["cube"].symmetry_deg)
            assert up.plan is not None
            if not self.planner.plan(down, up.plan.q, target=obj.id).planned:
                break
            ex.stream(up, "travel", False)
            ex.stream(down, "travel", False)
            above, pick, aim = up, down, aim + step
        return pick, aim

    def _recorded_pick(self, obj: TrackedObject) -> None:
        """:meth:`_pick_and_place` as an episode of the recording, if there is one."""
        recorder = self.recorder
        if recorder is None:
            self._pick_and_place(obj)
            return
        recorder.begin(obj.class_name)
        try:
            self._pick_and_place(obj)
        except BaseException:
            recorder.abandon()
            raise
        recorder.end()

    def _approach(self, obj: TrackedObject, pick: Route) -> Route | None:
        """The route to above the object (``task.approach_height_cm``), planned.

        ``None`` when the config asks for the paper's direct routes.
        """
        h = self.config.task.approach_height_cm
        if h is None:
            return None
        q = self.executor.q_now()
        z = float(pick.target.position_cm[2])
        # Where it is higher, the travel height: the jaws, and the object they lift back
        # to here, pass every bin wall and object top by the clearance and a margin for
        # the arm's lag in the transits to and from here (Planner.travel_heights_cm);
        # where that is out of reach, lower down to the approach height.
        heights = [max(h, t - z) for t in self.planner.travel_heights_cm(q)] + [h]
        above = None
        for height in dict.fromkeys(heights):
            target = self.planner.above_target(pick.target, height)
            above = Route(obj.id, obj.class_name, "approach", pick.attempt, target)
            if self.planner.plan(above, q).planned:
                break
        return above

    def _home(self, *, keep_grip: bool = False) -> None:
        """Go home along a straight line in joint space (no solve, inside the limits).

        Args:
            keep_grip: Keep the gripper as it is (parking while holding an object: it
                is not dropped on the way); otherwise it opens at home.
        """
        ex = self.executor
        state = self.bus.state
        closed = bool(state is not None and state.gripper_closed)
        if not keep_grip:
            self._world()
        if self.collision.first_contact(ex.joint_path(self.model.home)) is not None:
            # up to the safe height first, where the straight way home is clear
            x, y, z = (float(v) for v in ex.ee_now_cm())
            safe = self.planner.safe_height_cm(ex.q_now())
            up = Route("", "", "home", 1, IKTarget((x, y, max(z, safe))))
            if self.planner.plan(up, ex.q_now()).planned:
                ex.stream(up, "travel", closed)
            contact = self.collision.first_contact(ex.joint_path(self.model.home))
            if contact is not None:
                chain = self.model.chain
                raise CollisionError(
                    "not parked: the way home "
                    + contact.describe(chain.names, chain.scale)
                    + "; the arm stays where it is"
                )
        ex.move_joints(self.model.home, "travel", closed)
        ex.home_pose(closed=closed and keep_grip)

    # ----------------------------------------------------------------- run

    def run(self) -> SortReport:
        """Sort until the table is clear (or only skipped objects remain), then go home.

        Raises:
            SortAborted: camera or servo failure, or Ctrl-C; the reason is logged first.
        """
        try:
            if not self.bus.is_connected:
                self.bus.connect()
            self.executor.home_pose()
            for _ in range(self.max_rounds):
                obj = self._choose(self._look())
                if obj is None and self._unaccounted():
                    # the arm over a bin may hide an object seen before: look from home
                    self._home()
                    obj = self._choose(self._look(), final=True)
                    if obj is None:
                        self._gone()
                if obj is None:
                    break
                self._recorded_pick(obj)
            else:  # a table that never clears (flickering detections?): stop, say so
                for obj in self._objects:
                    if obj.skipped is None and not obj.sorted:
                        self._skip(
                            obj, f"still on the table after {self.max_rounds} pick rounds",
                            kind="never_cleared",
                        )  # fmt: skip
            self._home()
            if self.recorder is not None:
                self.recorder.end_run()
        except (CameraError, ServoError, CollisionError) as exc:
            self._abort(str(exc), park=isinstance(exc, CameraError))
        except KeyboardInterrupt:
            self._abort("interrupted (Ctrl-C)", park=True, interrupted=True)
        self.reporter.summary(ok=True, outcome=self.outcome(), motion=self.executor.motion)
        return self.report

    def outcome(self, stopped: str | None = None) -> Outcome:
        """Objects seen, sorted (confirmed) and left, per class and per reason.

        A place counts when the bus reported the release into the right bin and, in
        simulation, the world holds that many objects of the class in its bin; an object
        left for no recorded reason is put down to ``stopped`` (a fault or Ctrl-C) or,
        after a complete run, to ``not_confirmed``. Each object counts once, wherever the
        arm pushed it (:meth:`_track`): an object seen only in part, at the image border,
        is one of them too.
        """
        out = Outcome()
        for cls in self.config.task.classes:
            out.seen[cls.name] = 0
            out.sorted[cls.name] = 0
        in_bin = None if self.in_bins is None else dict(self.in_bins())
        self.executor.show_world()  # the twin's objects, settled, in the view

        def leave(kind: str) -> None:
            out.left[kind] = out.left.get(kind, 0) + 1

        for o in self._objects:
            out.seen[o.class_name] = out.seen.get(o.class_name, 0) + 1
            if o.sorted and (
                in_bin is None or out.sorted.get(o.class_name, 0) < in_bin[o.class_name]
            ):
                out.sorted[o.class_name] = out.sorted.get(o.class_name, 0) + 1
            elif o.skip_kind is not None:
                leave(o.skip_kind)
            elif stopped is not None and not o.sorted:
                leave(stopped)
            else:
                leave("not_confirmed")
        return out

    def _gone(self) -> None:
        """Leave each object seen before but not on the table from home, and say so.

        Knocked off the table, or out of the camera's view: the camera cannot tell which.
        """
        for o in self._objects:
            if not o.sorted and o.skipped is None:
                self._skip(
                    o,
                    f"no longer on the table: last seen at ({o.x_cm:.1f}, {o.y_cm:.1f}) cm, "
                    "not seen from home (knocked off the table, or out of the camera's view)",
                    kind="off_table",
                )

    def _unaccounted(self) -> bool:
        """Whether an object seen before is neither sorted nor left for a reason."""
        return any(not o.sorted and o.skipped is None for o in self._objects)

    def _last_joints(self) -> dict[str, float] | None:
        state = self.bus.state
        return None if state is None else self.model.chain.named(self.executor.q_now())

    def _abort(self, reason: str, *, park: bool, interrupted: bool = False) -> None:
        bus = self.bus
        # The view is for the eye; safety comes first: an interrupt may have cut a request
        # to the view's server in half, so parking goes on without it.
        self.view = self.executor.view = None
        if self.recorder is not None:
            self.recorder.abandon()  # the episode cut short is not written
        if park and bus.is_connected and bus.fault is None and bus.state:
            try:
                self._home(keep_grip=True)
                parked = "; arm parked at home"
            except (MearmError, KeyboardInterrupt) as exc:
                parked = f"; parking failed ({exc})"
                bus.stop()
        else:
            parked = "; nothing more sent to the servos"
        full = reason + parked
        self.reporter.fault(full, self._last_joints())
        outcome = self.outcome("interrupted" if interrupted else "fault")
        self.reporter.summary(ok=False, outcome=outcome, motion=self.executor.motion)
        raise SortAborted(
            full, interrupted=interrupted, last_joints=self._last_joints(), outcome=outcome
        )


def _check_view(shifts: list[tuple[TrackedObject, np.ndarray]], source: str) -> None:
    """Refuse one shift of every object the arm left alone: the view moved (:meth:`_track`)."""
    if len(shifts) < 2:
        return
    moves = np.array([d for _, d in shifts])  # (n, 2) [cm]
    mean = moves.mean(axis=0)
    if np.all(np.linalg.norm(moves, axis=1) > VIEW_SHIFT_CM) and np.all(
        np.linalg.norm(moves - mean, axis=1) <= SAME_SHIFT_CM
    ):
        names = ", ".join(o.id for o, _ in shifts)
        raise CameraError(
            source,
            f"the view moved: {names}, which the arm did not go near, all appear "
            f"{float(np.linalg.norm(mean)):.2f} cm from where they lay (by ({mean[0]:.2f}, "
            f"{mean[1]:.2f}) cm); was the camera knocked? Fix its mount and recalibrate "
            "(tools/calibrate_camera.py)",
        )


def _table_cm(d: Detection) -> np.ndarray:
    """Where the detector located a detection on the table [cm] (it has the calibration)."""
    assert d.table_cm is not None
    return d.table_cm


def _cut(det: Detection, width_px: int, height_px: int) -> bool:
    """Whether a detection's region touches the image border (only part of it is seen)."""
    x, y, w, h = det.bbox_px
    return x <= 0 or y <= 0 or x + w >= width_px or y + h >= height_px


def _seen_cut(obj: TrackedObject, seen: Seen, width_px: int, height_px: int) -> bool:
    """Whether the look saw ``obj`` (a detection of its class where it is) cut by the border."""
    return any(
        d.color == obj.class_name
        and np.hypot(x - obj.x_cm, y - obj.y_cm) <= SAME_OBJECT_CM
        and _cut(d, width_px, height_px)
        for d, (x, y) in seen
    )


def _come_apart(seen: Seen, taken: Mapping[int, TrackedObject], config: Config) -> set[int]:
    """The detections that are the other object of a region of touching objects come apart.

    A known object last seen as such a region (``merged``, and larger than it is seen
    now by more than :data:`SAME_AREA_RATIO`: not one the arm hid in part) and seen whole
    now: the detection of its class nearest where it was, not taken by a known object,
    within the open jaws' reach and an object across (the jaws parted them), is the
    other object the region stood for.
    """
    g, camera = config.arm.tool.gripper, config.camera
    apart: set[int] = set()
    for k, obj in taken.items():
        det = seen[k][0]
        if not obj.merged or det.merged or _cut(det, camera.width_px, camera.height_px):
            continue
        if obj.area_px <= (1 + SAME_AREA_RATIO) * det.area_px:
            continue  # as large as one object now: part of it was hidden
        r = config.task.class_named(obj.class_name).footprint_radius_cm
        reach = g.open_cm / 2 + g.jaw_thickness_cm + 2 * r
        near = {
            float(np.hypot(x - obj.x_cm, y - obj.y_cm)): j
            for j, (d, (x, y)) in enumerate(seen)
            if j not in taken and j not in apart and d.color == obj.class_name
        }
        nearest = min(near, default=np.inf)
        if nearest <= reach:
            apart.add(near[nearest])
    return apart


def _failure_kind(route: Route) -> str:
    """The typed reason a route's plan failed (``unreachable`` when it gives none)."""
    kind = getattr(route, "failure_kind", None)
    return str(kind) if kind else "unreachable"


def _hex(rgb: tuple[int, int, int]) -> str:
    return "#{:02x}{:02x}{:02x}".format(*rgb)


def _stuck(beside: tuple[float, str, str], clearance_cm: float, failure: str | None) -> str:
    """Why a held object stays where the pick ended, for the skip.

    Args:
        beside: :meth:`CollisionModel.gap` where the pick ended (within the clearance).
        clearance_cm: ``task.clearance_cm``.
        failure: Why the place was refused.
    """
    gap_m, part, obstacle = beside
    name = obstacle.removeprefix("obj_")
    if obstacle == "table":  # (the table keeps no clearance: its gap is the height)
        where = f"{part} {gap_m / M_PER_CM:.2f} cm above it"
    else:
        where = f"{part} {gap_m / M_PER_CM + clearance_cm:.2f} cm from it"
    return (
        f"the pick ended beside {name} ({where}, within task.clearance_cm) and no route "
        f"leaves without coming closer: {failure}"
    )
