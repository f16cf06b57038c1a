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
spot; a place whose jaws came to the bin without the object counts as such a try. A
camera or servo failure, or Ctrl-C, parks the arm where it is safe to (home, if the
servo link still answers; otherwise nothing more is sent), writes the reason to the run
log and raises :class:`SortAborted`. A black frame, a frozen stream
(:mod:`mearm.vision.frame_check`) and objects that moved between two looks though the
arm went near none of them (the camera was knocked: its calibration no longer holds) are
camera failures.

The loop is here; its parts each have a module: following the objects from look to look
(:mod:`mearm.task.table_tracking`), one object's pick-and-place
(:mod:`mearm.task.pick_place`) and the picks that look at the claw
(:mod:`mearm.task.looking_picks`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from functools import partial
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from mearm import interrupts
from mearm.config import Config
from mearm.config.files import config_source
from mearm.data import doc_page
from mearm.errors import ConfigError, MearmError
from mearm.hardware.bus import ReportsWhere, ServoBus
from mearm.hardware.errors import ServoError
from mearm.kinematics import ArmModel
from mearm.sim.table_collision import collision_model
from mearm.task.claw_loop import claw_eye
from mearm.task.execute import CollisionError, Executor, View
from mearm.task.homing import go_home
from mearm.task.pick_place import (  # noqa: F401  (re-exported)
    EpisodeRecorder,
    PickAndPlace,
    failure_kind,
    hex_rgb,
    stuck_reason,
    where_they_are,
)
from mearm.task.pick_place import failure_kind as _failure_kind  # noqa: F401
from mearm.task.pick_place import hex_rgb as _hex  # noqa: F401
from mearm.task.pick_place import stuck_reason as _stuck  # noqa: F401
from mearm.task.plan import Planner
from mearm.task.report import Outcome, Reporter, SortReport
from mearm.task.table_tracking import (  # noqa: F401  (re-exported)
    SAME_AREA_RATIO,
    SAME_OBJECT_CM,
    SAME_SHIFT_CM,
    VIEW_SHIFT_CM,
    Seen,
    TrackedObject,
    check_view,
    come_apart,
    is_cut,
    seen_cut,
    table_cm,
)
from mearm.task.table_tracking import check_view as _check_view  # noqa: F401
from mearm.task.table_tracking import come_apart as _come_apart  # noqa: F401
from mearm.task.table_tracking import is_cut as _cut  # noqa: F401
from mearm.task.table_tracking import seen_cut as _seen_cut  # noqa: F401
from mearm.task.table_tracking import table_cm as _table_cm  # noqa: F401
from mearm.vision import Camera, ColorDetector
from mearm.vision.arm_mask import arm_view
from mearm.vision.calibration import camera_geometry
from mearm.vision.errors import CameraError
from mearm.vision.frame_check import FrameCheck

if TYPE_CHECKING:
    from mearm.runlog.writer import RunLog  # a log is written only when asked for


class SortAborted(MearmError):
    """The sort stopped before the table was clear.

    Attributes:
        reason: One line: what failed.
        interrupted: Whether it was Ctrl-C.
        last_joints: The last confirmed joints by name [deg or cm], or ``None``.
        outcome: What was sorted before it stopped (the summary's counts), or ``None``.
        servo_fault: Whether a fault of the servos stopped it (the bus sends nothing
            more, the arm where the fault left it: an experiment on a real board starts
            no trial after it).
    """

    def __init__(
        self,
        reason: str,
        *,
        interrupted: bool = False,
        last_joints: dict[str, float] | None = None,
        outcome: Outcome | None = None,
        servo_fault: bool = False,
    ):
        self.reason = reason
        self.interrupted = interrupted
        self.last_joints = last_joints
        self.outcome = outcome
        self.servo_fault = servo_fault
        super().__init__(reason)


class StartCalibrationFailed(MearmError):
    """The servos' calibration at the start of a sort gave none; nothing was picked."""


class CalibrateFirst(Protocol):
    """Calibrates servos never calibrated, the arm at home, before the first pick.

    ``servo.calibrate_at_start`` (:mod:`mearm.maker.camera_calibration.at_start`, a layer
    above the sort's: the commands that sort hand it over). Called with the sort's config,
    camera, bus and arm model; returns the config with the calibration, which the bus then
    sends, and the lines to print.

    Raises:
        StartCalibrationFailed: the fit did not converge or was refused (the arm parked).
        ServoError: a fault while moving (the arm held where it is).
    """

    def __call__(  # noqa: D102
        self, config: Config, camera: Camera, bus: ServoBus, model: ArmModel, *, simulated: bool
    ) -> tuple[Config, list[str]]: ...


def calibrates_at_start(config: Config) -> bool:
    """Whether a sort on ``config`` calibrates its servos by the camera first."""
    servo = config.servo
    return servo.calibrate_at_start == "when_uncalibrated" and servo.calibration_file is None


def check_calibrate_at_start(config: Config) -> None:
    """Refuse a calibration at the start the rig cannot run, before anything moves.

    Raises:
        ConfigError: ``servo.calibrate_at_start`` asks for it, and the claw has no marker
            or the camera no perspective calibration.
    """
    if not calibrates_at_start(config):
        return
    field, problems = "servo.calibrate_at_start", []
    if config.arm.tool.marker is None:
        problems.append(
            f"{field}: when_uncalibrated needs a marker on the claw (arm.tool.marker), the "
            f"arm {config.arm.name!r} has none: add one, or set {field} to never"
        )
    if config.calibration.model != "perspective":
        problems.append(
            f"{field}: when_uncalibrated needs a perspective calibration of the camera "
            f"(calibration.model: perspective), not {config.calibration.model!r}: set "
            f"{field} to never, or calibrate the camera as {doc_page('calibration.md')}'s "
            "walkthrough does"
        )
    if problems:  # named by the config's file, as a bad key's line is
        raise ConfigError(config_source(config), problems)


class Sorter(PickAndPlace):
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
        placed: In simulation, how many objects of each class lay on the table at the
            start: those the camera never saw are counted as left (``unseen``), not
            forgotten; ``None`` on a real rig, where only what the camera sees is known.
        max_rounds: Pick attempts before the run gives up on a table that never clears
            (default: four per expected object and retry, at least 80 × (retries + 1)).
        recorder: Records each pick-and-place as an episode (``--record``), or ``None``.
        calibrate_first: Calibrates servos never calibrated by the camera before the first
            pick, where ``servo.calibrate_at_start`` asks for it; ``None``: the command
            cannot (the sort says so and uses the nominal calibration).

    Raises:
        ConfigError: ``servo.calibrate_at_start`` on a rig without what it needs.
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
        placed: Mapping[str, int] | None = None,
        max_rounds: int | None = None,
        recorder: EpisodeRecorder | None = None,
        calibrate_first: CalibrateFirst | None = None,
    ):
        check_calibrate_at_start(config)  # before anything moves
        self.config = config
        self.recorder = recorder
        self.camera = camera
        self.bus = bus
        #: What calibrates servos never calibrated before the first pick, where the config
        #: asks for it (``servo.calibrate_at_start``); ``None``: this command cannot.
        self.calibrate_first = calibrate_first
        self.model = model if model is not None else ArmModel(config.arm)
        #: Every frame the sort acts on, the claw's looks' too, passes this one check.
        self.frame_check = FrameCheck(camera.source)
        self._calibrated_parts(config, view)
        self.reporter = Reporter(
            config, self.model.chain, log, echo, trial, simulated=in_bins is not None,
            twin_faults=_twin_faults(bus),
        )  # fmt: skip
        #: The object the arm last went for (the only one it may have moved since).
        self._active: TrackedObject | None = None
        self._active_from_cm = (0.0, 0.0)
        self._seen_px = None
        self.view = view
        self.in_bins = in_bins
        self.placed = dict(placed or {})
        retries = config.task.pick_retries + 1
        self.max_rounds = max_rounds or 4 * (len(config.task.scene) + 20) * retries
        self._objects: list[TrackedObject] = []

    def _calibrated_parts(self, config: Config, view: View | None) -> None:
        """What depends on the servos' calibration: the checks, the planner, the moves, the eyes.

        Built again once the camera has calibrated the servos at the start.
        """
        self.config = config
        self.collision = collision_model(config, self.model, clearance_cm=config.task.clearance_cm)
        self.planner = Planner(config, self.model, self.collision)
        self.executor = Executor(config, self.bus, self.model, view, collision=self.collision)
        self.calibration = camera_geometry(config.calibration, config.camera)
        self.detector = ColorDetector.from_config(
            config.vision, config.calibration, config.camera, config.task.classes,
            geometry=self.calibration,
        )  # fmt: skip
        read = partial(self.frame_check.read, self.camera)
        #: The camera watching the claw's marker (picks that look), where the tool carries
        #: one, the camera is calibrated as a perspective one and the config asks for it.
        #: Its frames pass the table's looks' check (black, frozen: :attr:`frame_check`).
        self.eye = claw_eye(config, self.model, self.calibration, read, self.bus.hold)
        #: The arm's body where the calibrated camera sees it (a perspective camera only:
        #: a homography knows only the table's plane); no object is looked for there.
        self.arm_view = arm_view(
            self.calibration, self.model, self.collision.bodies,
            opening_cm=config.arm.tool.gripper.open_cm,
        )  # fmt: skip
        self.arm_in_view = None if self.arm_view is None else self._arm_now

    def _calibrate_by_camera(self) -> None:
        """Servos never calibrated: calibrate them by the camera, the arm at home, and use it.

        ``servo.calibrate_at_start`` (:class:`CalibrateFirst`); a line says what it gave.
        A command that cannot (no :attr:`calibrate_first`) says so and sorts as it is.

        Raises:
            StartCalibrationFailed: the fit did not converge or was refused.
            ServoError: a fault while moving.
        """
        if self.calibrate_first is None:
            self.reporter.echo(
                "note: servo.calibrate_at_start: this command does not calibrate the servos "
                "first; the sort uses the arm's nominal calibration"
            )
            return
        simulated = self.in_bins is not None
        config, lines = self.calibrate_first(
            self.config, self.camera, self.bus, self.model, simulated=simulated
        )
        self.frame_check.after(self.camera.frame_time_s)  # its last frame: the next is newer
        # a recording keeps the calibration: its replay runs the servos as this sort does
        keep = getattr(self.recorder, "servos_calibrated", None)
        if keep is not None:
            keep(self.config, config)
        self.model = ArmModel(config.arm)  # its limits, narrowed where the fit says so
        self._calibrated_parts(config, self.view)
        for line in lines:
            self.reporter.echo(line)
        # home as the fit has it (a degree or two from where the calibration parked): the
        # checked way, against the bins and the table (no object is known yet)
        self._home()

    @property
    def report(self) -> SortReport:
        """What the run did so far."""
        return self.reporter.report

    def _choose(self, seen: Seen, *, final: bool = False) -> TrackedObject | None:
        """The object to pick next, or ``None``.

        ``final``: the look is the last before the run ends (from home, and where the
        camera sees the arm, from beside home too: at home the arm may hide part of an
        object); only then are the objects seen as touching others, or cut by the image
        border, with nothing else left to pick, left as merged or cut (from elsewhere
        the arm may hide part of one), and those whose picks each wait for another
        object left as ``collision`` (from elsewhere the arm may hide the one in the way).
        """
        candidates = [
            o
            for o in self._objects
            if o.skipped is None and not o.sorted and self._on_table(o, seen)
        ]
        whole = [o for o in candidates if not o.merged]
        free = [o for o in whole if o.blocked is None]
        if not free and not final:
            # every whole one waits for another, or none is whole: look again from home,
            # where the arm hides nothing (from over a bin it may hide the object in the
            # way: the MeArm v1's twin, seed 871011 of 6, left blue1 blocked by blue2,
            # then sorted blue2)
            return None
        if not free:  # nothing left to pick: say why not these
            for o in whole:  # every one waits for another: none can
                self._skip(o, o.blocked or "collision", kind="collision")
            camera = self.config.camera
            for o in (o for o in candidates if o.merged):
                if seen_cut(o, seen, camera.width_px, camera.height_px):
                    self._skip(o, "cut by the image border: only part of it is seen", kind="cut")
                else:
                    why = "touching objects of one class: no single centroid to pick"
                    self._skip(o, why, kind="merged")
            return None
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

    # ----------------------------------------------------------------- run

    def _home(self, *, keep_grip: bool = False) -> None:
        """Go home the checked way (:func:`~mearm.task.homing.go_home`).

        The way the camera's check goes home too: the straight line in joint space where
        it is clear, else up to the safe height first, or over to above home; refused
        (:class:`CollisionError`) where nothing is clear.

        Args:
            keep_grip: Keep the gripper as it is (parking while holding an object: it
                is not dropped on the way, in the world as it is); otherwise the world is
                the table seen and the gripper opens at home.
        """
        state = self.bus.state
        closed = bool(state is not None and state.gripper_closed)
        if not keep_grip:
            self._world()
        go_home(self.executor, self.planner, closed=closed, keep_grip=keep_grip)

    def run(self) -> SortReport:
        """Sort until the table is clear (or only skipped objects remain), then go home.

        Raises:
            SortAborted: camera or servo failure, or Ctrl-C; the reason is logged first.
        """
        try:
            # before each motion the loop starts: a Ctrl-C C code swallowed stops it too
            interrupts.raise_swallowed_ctrl_c()
            if not self.bus.is_connected:
                self.bus.connect()
            self.executor.home_pose()
            if calibrates_at_start(self.config):
                self._calibrate_by_camera()
            # since the last pick, from beside home (_look_aside: a camera that sees the arm)
            looked_aside = self.arm_view is None
            for _ in range(self.max_rounds):
                obj = self._choose(self._look_at_rest(self.executor.rest))
                if obj is None and (self._unaccounted() or not looked_aside):
                    # the arm over a bin may hide an object seen before: look from home
                    self._home()
                    seen = self._look_at_rest(self.executor.rest)
                    # the arm at home may hide part of an object (seen as a half disc,
                    # flagged merged): nothing is left so before the look aside
                    obj = self._choose(seen, final=looked_aside)
                    if obj is None and not looked_aside:
                        obj, looked_aside = self._look_aside(), True
                        if obj is None:  # what the look aside did not settle, home does
                            obj = self._choose(seen, final=True)
                    if obj is None and self._unaccounted():
                        self._gone()
                if obj is None:
                    break
                looked_aside = self.arm_view is None
                interrupts.raise_swallowed_ctrl_c()
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
        except StartCalibrationFailed as exc:  # the arm parked where it could be
            self._abort(f"{exc}; nothing sorted", park=False, parked_already=self._at_home())
        except MearmError as exc:
            self._stop_on_fault(exc)
        except KeyboardInterrupt as exc:
            interrupts.answered()
            self._abort(f"interrupted ({interrupts.named(exc)})", park=True, interrupted=True)
        self.reporter.summary(ok=True, outcome=self.outcome(), motion=self.executor.motion)
        return self.report

    def outcome(self, stopped: str | None = None) -> Outcome:
        """Objects seen, sorted (confirmed) and left, per class and per reason.

        A place counts when the bus reported the release into the right bin and, in
        simulation, the world holds that many objects of the class in its bin; an object
        left for no recorded reason is put down to ``stopped`` (a fault or Ctrl-C) or,
        after a complete run, to ``not_confirmed``. Each object counts once, wherever the
        arm pushed it (:mod:`mearm.task.table_tracking`): an object seen only in part, at
        the image border, is one of them too. In simulation an object the camera never
        saw is left too (``unseen``): the world knows it is there. A run that stopped
        (``stopped``) leaves it to the stop instead, as a belt's run does: the run ended
        before its last looks (from home, and beside it where the arm hides part of the
        table), so the camera was not yet done looking, and the last line names the stop.
        An object the stop left that the world has in its bin all the same (a place cut
        short once the jaws were down in the bin) is sorted: in simulation the world
        counts (:func:`_count_stopped_yet_binned`).
        """
        out = Outcome()
        for cls in self.config.task.classes:
            out.seen[cls.name] = 0
            out.sorted[cls.name] = 0
        in_bin = None if self.in_bins is None else dict(self.in_bins())
        out.in_bins = dict(in_bin or {})
        self.executor.show_world()  # the twin's objects, settled, in the view

        short: set[str] = set()  # classes with an object not confirmed in its bin
        cut_short: dict[str, int] = {}  # per class: objects seen, left to the stop

        kinds: dict[str, list[str]] = {}  # per class: why each object seen was left

        def leave(o: TrackedObject, kind: str) -> None:
            out.left[kind] = out.left.get(kind, 0) + 1
            kinds.setdefault(o.class_name, []).append(kind)

        for o in self._objects:
            out.seen[o.class_name] = out.seen.get(o.class_name, 0) + 1
            if o.sorted and (
                in_bin is None or out.sorted.get(o.class_name, 0) < in_bin[o.class_name]
            ):
                out.sorted[o.class_name] = out.sorted.get(o.class_name, 0) + 1
            elif o.skip_kind is not None:
                leave(o, o.skip_kind)
            elif stopped is not None and not o.sorted:
                leave(o, stopped)
                cut_short[o.class_name] = cut_short.get(o.class_name, 0) + 1
            else:
                leave(o, "not_confirmed")
                short.add(o.class_name)
        if in_bin is not None:
            self._count_placed_again(out, in_bin)
            if stopped is not None:
                before = dict(out.sorted)
                _count_stopped_yet_binned(out, in_bin, stopped, cut_short)
                for name, n in out.sorted.items():  # (those the world has in their bin)
                    for _ in range(n - before.get(name, 0)):
                        kinds[name].remove(stopped)
        if self.placed:
            _count_no_more_than_placed(out, self.placed, kinds)
            short = {name for name in short if "not_confirmed" in kinds.get(name, ())}
        astray = getattr(self.bus, "astray", None)  # the twin says where they are
        if callable(astray) and out.left.get("not_confirmed"):
            out.astray = {name: astray(name) for name in sorted(short)}
        for name, n in self.placed.items():  # in simulation: never seen, still there
            missing = n - out.seen.get(name, 0)
            if missing > 0:
                out.unseen[name] = missing
                why = stopped or "unseen"
                out.left[why] = out.left.get(why, 0) + missing
        return out

    def _count_placed_again(self, out: Outcome, in_bin: Mapping[str, int]) -> None:
        """In simulation, count the objects the camera took for one carried off before.

        An object first seen where the arm hid the table, near the way another of its
        class was carried to its bin with no simulator confirming the release (the twin
        before it confirmed the places it counts,
        :func:`~mearm.task.pick_place.place_confirmed`; a real rig), is taken for that
        one dropped on the way (:meth:`TableTracking._dropped`): the
        camera cannot tell them apart. Picked and placed, it is the same object placed
        twice. Where the world has more of the class in its bin than the sort counted,
        each such place was another object, seen and sorted: not one left "never seen"
        (the MeArm v1's twin, scene 979006: both reds in their bin, the sort said 5 of 6).
        So is an object the jaws held and let go over its bin while a look took one the
        arm had hidden for it pushed aside (:meth:`PickAndPlace._let_go_and_look
        <mearm.task.pick_place.PickAndPlace._let_go_and_look>`). Each place of a followed
        object counts but the one its own count of sorted holds: one followed on and left
        on the table (its picks of the hidden one failed past ``task.pick_retries``) has
        its earlier place uncounted (the two reds of ``sim_5dof_mujoco --random 18 --seed
        48598`` with no retry: one in its bin, and the sort said ``sorted 0 of 2``).
        """
        for name in out.sorted:
            again = sum(o.places - int(o.sorted) for o in self._objects if o.class_name == name)
            extra = min(again, in_bin.get(name, 0) - out.sorted[name])
            if extra > 0:
                out.seen[name] += extra
                out.sorted[name] += extra

    def _gone(self) -> None:
        """Leave each object seen before but not in the work area from home, and say so.

        Knocked off the table, or onto the table beyond the work area (the twin's table
        reaches past it, as a real one may), or out of the camera's view: the camera
        cannot tell which, so the reason names all three. A simulator that knows its
        objects (:class:`ReportsWhere`) says instead where one lost from the jaws on the
        way to its bin went (:attr:`TrackedObject.lost_ids`).
        """
        for o in self._objects:
            if not o.sorted and o.skipped is None:
                why = (
                    f"no longer in the work area: last seen at ({o.x_cm:.1f}, {o.y_cm:.1f}) "
                    "cm, not seen from home"
                )
                if isinstance(self.bus, ReportsWhere) and o.lost_ids:
                    where = where_they_are(self.bus, o.lost_ids)
                    why += f"; lost from the jaws on the way to its bin, it {where}"
                else:
                    why += " (knocked off the table, or out of the work area or the camera's view)"
                self._skip(o, why, kind="off_table")

    def _arm_now(self, frame_shape: tuple[int, ...]) -> np.ndarray:
        """The arm's body in a frame of that shape at the last confirmed joints (0/255)."""
        assert self.arm_view is not None  # set only with it
        return self.arm_view.mask(self.executor.q_now(), frame_shape)

    def _look_aside(self) -> TrackedObject | None:
        """From home, look again with the base turned aside where the arm hides the table.

        Over a small table the arm at home stands between the camera and the objects
        near its claw (the MeArm's, 17 cm out in front), and an object there may never
        have been seen, or seen only while the arm was elsewhere. Of the base turned to
        either limit or halfway there, the pose that uncovers most of what the arm at
        home hides of the work area is taken, along a straight joint path checked against
        collisions like the way home. ``None``: no camera that sees the arm, nothing
        hidden, no such pose, or nothing to pick there.
        """
        if self.arm_view is None:
            return None
        ex, chain = self.executor, self.model.chain
        shape = (self.config.camera.height_px, self.config.camera.width_px)
        home = np.asarray(self.model.home, dtype=float)
        hidden = self.arm_view.mask(home, shape) > 0
        area = self.detector.work_area(shape)
        if area is not None:
            hidden &= area > 0
        best: tuple[int, float, np.ndarray] | None = None
        for end in (chain.lower[0], chain.upper[0]):
            for share in (0.5, 1.0):
                q = home.copy()
                q[0] = home[0] + share * (end - home[0])
                if not chain.within_limits(q):
                    continue
                uncovered = int(np.count_nonzero(hidden & (self.arm_view.mask(q, shape) == 0)))
                if uncovered and (best is None or (-uncovered, share) < (-best[0], best[1])):
                    best = (uncovered, share, q)
        if best is None or self.collision.first_contact(ex.joint_path(best[2])) is not None:
            return None
        ex.move_joints(best[2], "travel", closed=False)
        return self._choose(self._look(), final=True)

    def _unaccounted(self) -> bool:
        """Whether an object seen before is neither sorted nor left for a reason."""
        return any(not o.sorted and o.skipped is None for o in self._objects)

    def _last_joints(self) -> dict[str, float] | None:
        state = self.bus.state
        return None if state is None else self.model.chain.named(self.executor.q_now())

    def _stop_on_fault(self, exc: MearmError) -> None:
        """Stop the sort on a fault, parked where the servos can still be trusted; else re-raise.

        A camera's fault, or a recording or run log that failed (a full disk), parks the
        arm; a servo's fault or a collision sends nothing more. Any other error is not a
        fault of the run and goes on up unchanged. A run log that cannot be written is
        written no more (its last whole record stays the file's end): the sort stops,
        says why and parks, where it ended in a traceback with the arm left holding an
        object at its pick.
        """
        from mearm.runlog.errors import RunLogError  # noqa: PLC0415  (a fault's path only)

        recording = self.recorder is not None and exc is getattr(self.recorder, "failure", None)
        logging = isinstance(exc, RunLogError) and self.reporter.log is not None
        if logging:
            self.reporter.log = None
        stops = (CameraError, ServoError, CollisionError)
        if not (recording or logging or isinstance(exc, stops)):
            raise exc
        reason = f"run log {exc}" if logging else str(exc)
        self._abort(
            reason,
            park=recording or logging or isinstance(exc, CameraError),
            servo_fault=isinstance(exc, ServoError) and not (recording or logging),
        )

    def _at_home(self) -> bool:
        """Whether the arm's last confirmed pose is home (within a hundredth of a degree)."""
        if not self.bus.is_connected or self.bus.fault is not None or self.bus.state is None:
            return False
        return bool(np.allclose(self.executor.q_now(), self.model.home, atol=np.radians(0.01)))

    def _abort(
        self,
        reason: str,
        *,
        park: bool,
        interrupted: bool = False,
        parked_already: bool = False,
        servo_fault: bool = False,
    ) -> None:
        """Stop the sort: park (``park``) or send nothing more, log the fault, raise.

        ``parked_already``: the arm is at home, parked by what failed (the calibration by
        the camera at the start), and the last line says so. ``servo_fault``: a fault of
        the servos stopped it (:attr:`SortAborted.servo_fault`), as does one that stopped
        the bus while parking.
        """
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
                interrupts.answered()  # a second Ctrl-C: parking stops here
                why = str(exc) if isinstance(exc, MearmError) else f"{interrupts.named(exc)} again"
                parked = f"; parking failed ({why})"
                bus.stop()
        elif parked_already:
            parked = "; arm parked at home"
        else:
            parked = "; nothing more sent to the servos"
        full = reason + parked
        servo_fault = servo_fault or bus.fault is not None
        self.reporter.fault(full, self._last_joints())
        outcome = self.outcome("interrupted" if interrupted else "fault")
        self.reporter.summary(ok=False, outcome=outcome, motion=self.executor.motion)
        raise SortAborted(
            full,
            interrupted=interrupted,
            last_joints=self._last_joints(),
            outcome=outcome,
            servo_fault=servo_fault,
        )


#: Which of a class's objects left, by why, are dropped first where the camera followed
#: more of the class than the world holds (:func:`_count_no_more_than_placed`): one no
#: longer seen from home, then one never confirmed, then the rest.
_NOT_AN_OBJECT_FIRST = ("off_table", "not_confirmed")


def _count_no_more_than_placed(
    out: Outcome, placed: Mapping[str, int], kinds: Mapping[str, list[str]]
) -> None:
    """In simulation, count no more objects of a class than the world laid on the table.

    The camera may follow more objects of a class than there are: a camera nearer the
    table than its calibration says sees each object larger than one can be, and the
    detector splits it into two (the twin's camera 15 cm below the calibrated one: ``2 of
    11`` for 8 objects, seed 22801 of ``sim_mujoco_perspective``), or an object pushed
    away is followed again as a new one. What the camera saw that was no object is not an
    object on the table: the world's count is the truth, as for every place in
    simulation. A class's excess is taken off its objects seen and off its objects left
    (``kinds``, per class, why each was left, in the order they were first seen): which
    followed object was none is not known, so those no longer seen from home go first,
    then those never confirmed, then the last seen.
    """
    for name, n in placed.items():
        excess = out.seen.get(name, 0) - n
        if excess <= 0:
            continue
        out.seen[name] = n
        out.not_objects[name] = excess
        why = kinds.get(name, [])
        rank = {kind: r for r, kind in enumerate(_NOT_AN_OBJECT_FIRST)}
        order = sorted(reversed(range(len(why))), key=lambda i: rank.get(why[i], len(rank)))
        for i in sorted(order[:excess], reverse=True):
            kind = why.pop(i)
            out.left[kind] -= 1
            if not out.left[kind]:
                del out.left[kind]


def _count_stopped_yet_binned(
    out: Outcome, in_bin: Mapping[str, int], stopped: str, cut_short: Mapping[str, int]
) -> None:
    """In simulation, count as sorted the objects a stop left that the world has in their bin.

    A fault or Ctrl-C that strikes while the jaws bring an object down into its bin, before
    the place is confirmed, may leave the object in that bin (the twin, a limp shoulder
    sinking the jaws into the red bin at 1.65 s: the sort said ``0 of 12 (12 stopped by a
    fault)``, the twin had 1 in its bin). The world's count is the truth, as for every
    place in simulation: up to that many of a class's objects left to the stop
    (``cut_short``, per class) are sorted, not ``stopped``.
    """
    for name, n in cut_short.items():
        extra = min(n, in_bin.get(name, 0) - out.sorted.get(name, 0))
        if extra <= 0:
            continue
        out.sorted[name] = out.sorted.get(name, 0) + extra
        out.left[stopped] -= extra
        if not out.left[stopped]:
            del out.left[stopped]


def _twin_faults(bus: ServoBus) -> Callable[[], list[dict[str, Any]]] | None:
    """The physical twin's injected faults struck so far, as ``twin.faults`` gives them.

    ``None`` for any other bus (no faults are injected there).
    """

    def struck() -> list[Any] | None:  # the twin's FaultSchedule keeps them
        return getattr(getattr(bus, "faults", None), "struck", None)

    if not isinstance(struck(), list):
        return None
    return lambda: [{"kind": f.kind, **f.model_dump(mode="json")} for f in struck() or ()]
