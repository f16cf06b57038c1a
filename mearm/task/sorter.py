"""The sorting task: detect → project → choose → route → grip → route → release (SPEC §1).

The loop reads the table after every object, picks all of the first colour in
``task.color_order`` before the next, and starts each route where the last one ended
(the arm does not go home between objects). Every PD-PIJ iteration's joints are sent to
the servo bus, which paces them at ``servo.rate_hz``.

Objects out of reach or outside the Table 3 box are reported and skipped; a failed pick
(the object is still on the table in the next frame) is retried ``task.pick_retries``
times. A camera or servo failure, or Ctrl-C, parks the arm where it is safe to (home,
if the servo link still answers; otherwise nothing more is sent), writes the reason to
the run log and raises :class:`SortAborted`.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from mearm.config import Color, Config
from mearm.exceptions import CameraError, MearmError, ServoError, TargetError
from mearm.hardware import ArmCommand, ServoBus
from mearm.ik import IKResult, make_solver
from mearm.kinematics import ArmModel, couple
from mearm.runlog import RunLog
from mearm.vision import Calibration, Camera, ColorDetector, Detection

#: A detection within this distance of a known object is that object [cm].
SAME_OBJECT_CM = 1.5
#: After a missed grip the EE rises this much before the retry [cm].
RETRY_LIFT_CM = 5.0


class SortAborted(MearmError):
    """The sort stopped before the table was clear.

    Attributes:
        reason: One line: what failed.
        interrupted: Whether it was Ctrl-C.
        last_joints_deg: The last confirmed (θ1..θ4) [deg], or ``None``.
    """

    def __init__(self, reason: str, *, interrupted: bool = False, last_joints_deg: Any = None):
        self.reason = reason
        self.interrupted = interrupted
        self.last_joints_deg = last_joints_deg
        super().__init__(reason)


class View(Protocol):
    """What the loop calls on the meshcat view (:class:`mearm.view.ArmView`).

    :class:`~mearm.view.ArmView` satisfies it structurally: its methods take array-likes,
    and ``add_path`` returns the line's name, which the loop does not use (hence ``object``).
    """

    def show_joints(self, q_rad: npt.ArrayLike) -> None: ...  # noqa: D102
    def set_objects(self, objects: Iterable[tuple[str, str, float, float]]) -> None: ...  # noqa: D102
    def set_camera_frame(  # noqa: D102
        self, frame_bgr: npt.ArrayLike, pixel_to_table: Callable[[np.ndarray], npt.ArrayLike]
    ) -> None: ...
    def set_target(self, target_cm: npt.ArrayLike | None) -> None: ...  # noqa: D102
    def add_path(self, ee_path_cm: npt.ArrayLike, color: str) -> object: ...  # noqa: D102


@dataclass
class TrackedObject:
    """An object seen on the table, followed from frame to frame by its position."""

    id: str
    color: Color
    x_cm: float
    y_cm: float
    failed_picks: int = 0
    skipped: str | None = None
    sorted: bool = False


@dataclass
class SortReport:
    """What a sort run did.

    Attributes:
        routes: One dict per route (the run-log route fields).
        skipped: (object id, colour, reason) of every object left on the table.
        fault: Why the run stopped early, or ``None``.
    """

    routes: list[dict[str, Any]] = field(default_factory=list)
    skipped: list[tuple[str, Color, str]] = field(default_factory=list)
    fault: str | None = None

    def sorted_per_color(self) -> dict[str, int]:
        """Objects placed into their bin, per colour."""
        out: dict[str, int] = {}
        for r in self.routes:
            if r["step"] == "place" and r["success"]:
                out[r["color"]] = out.get(r["color"], 0) + 1
        return out

    @property
    def failed_picks(self) -> int:
        """Pick routes whose grip failed."""
        return sum(1 for r in self.routes if r["step"] == "pick" and not r["success"])


class Sorter:
    """Runs the sort on one table.

    Args:
        config: The whole configuration.
        camera: Frame source (``read()`` returns BGR).
        bus: A servo bus; :meth:`run` connects it if needed.
        model: Arm model (built from ``config.robot`` if omitted).
        log: Run log to write routes, skips, faults and the summary to.
        view: Meshcat view to update, or ``None``.
        echo: Called with one line per route and the summary (default: print).
        trial: Trial number for the run log.
        max_rounds: Pick attempts before the run gives up on a table that never clears
            (default: four per expected object and retry, at least 80 × (retries + 1)).
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
        max_rounds: int | None = None,
    ):
        self.config = config
        self.camera = camera
        self.bus = bus
        self.model = model if model is not None else ArmModel(config.robot)
        self.solver = make_solver(self.model, config.controller)
        self.calibration = Calibration.from_config(config.calibration)
        self.detector = ColorDetector(config.vision, self.calibration)
        self.log = log
        self.view = view
        self.echo = echo or (lambda _line: None)
        self.trial = trial
        retries = config.task.pick_retries + 1
        self.max_rounds = max_rounds or 4 * (len(config.task.scene) + 20) * retries
        self.report = SortReport()
        self._objects: list[TrackedObject] = []
        g = config.robot.gripper
        self._travel_deg, self._grip_deg = g.travel_angle_deg, g.grip_angle_deg

    # ----------------------------------------------------------------- pose helpers

    def _q_now_rad(self) -> np.ndarray:
        state = self.bus.state
        joints = self.config.robot.home_deg if state is None else state.joints_deg
        return np.radians(couple(joints))

    def _last_joints_deg(self) -> list[float] | None:
        state = self.bus.state
        return None if state is None else couple(state.joints_deg).tolist()

    def _ee_now_cm(self) -> np.ndarray:
        # the simulated arm knows where it really is; a real arm reports only commands
        actual = getattr(self.bus, "ee_cm", None)
        if actual is not None:
            return np.asarray(actual, dtype=float)
        return self.model.fk_cm(self._q_now_rad())

    def _send(self, joints_deg: Any, gripper_arm_deg: float, closed: bool) -> None:
        j1, j2, j3 = (float(v) for v in joints_deg)
        q3 = (j1, j2, j3)
        self.bus.move(ArmCommand(q3, gripper_arm_deg, closed))
        if self.view is not None:
            self.view.show_joints(np.radians(couple(q3)))

    def _gripper(self, gripper_arm_deg: float, closed: bool) -> None:
        state = self.bus.state
        assert state is not None
        self._send(state.joints_deg, gripper_arm_deg, closed)

    # ----------------------------------------------------------------- vision

    def _look(self) -> list[tuple[Detection, np.ndarray]]:
        frame = self.camera.read()
        detections = self.detector.detect(frame)
        if detections:
            px = np.array([d.centroid_px for d in detections])
            cm = self.calibration.pixel_to_table(px)
        else:
            cm = np.zeros((0, 2))
        seen = list(zip(detections, cm, strict=True))
        self._track(seen)
        if self.view is not None:
            self.view.set_camera_frame(frame, self.calibration.pixel_to_table)
            self.view.set_objects(
                [(o.id, o.color, o.x_cm, o.y_cm) for o in self._objects if self._on_table(o, seen)]
            )
        return seen

    def _track(self, seen: list[tuple[Detection, np.ndarray]]) -> None:
        for det, (x, y) in seen:
            known = self._match(det.color, x, y)
            if known is None:
                n = sum(1 for o in self._objects if o.color == det.color) + 1
                known = TrackedObject(f"{det.color}{n}", det.color, float(x), float(y))
                self._objects.append(known)
                if det.merged:
                    known.skipped = "touching objects of one colour: no single centroid to pick"
                    self._skip(known, None)
            else:
                known.x_cm, known.y_cm = float(x), float(y)

    def _match(self, color: str, x: float, y: float) -> TrackedObject | None:
        best, best_d = None, SAME_OBJECT_CM
        for o in self._objects:
            d = float(np.hypot(o.x_cm - x, o.y_cm - y))
            if o.color == color and not o.sorted and d <= best_d:
                best, best_d = o, d
        return best

    @staticmethod
    def _on_table(obj: TrackedObject, seen: list[tuple[Detection, np.ndarray]]) -> bool:
        return any(
            d.color == obj.color and np.hypot(x - obj.x_cm, y - obj.y_cm) <= SAME_OBJECT_CM
            for d, (x, y) in seen
        )

    def _choose(self, seen: list[tuple[Detection, np.ndarray]]) -> TrackedObject | None:
        candidates = [
            o
            for o in self._objects
            if o.skipped is None and not o.sorted and self._on_table(o, seen)
        ]
        ee = self._ee_now_cm()
        for color in self.config.task.color_order:
            of_color = [o for o in candidates if o.color == color]
            if of_color:
                return min(of_color, key=lambda o: (np.hypot(o.x_cm - ee[0], o.y_cm - ee[1]), o.id))
        return None

    # ----------------------------------------------------------------- motion

    def _route(
        self, target_cm: np.ndarray, gripper_arm_deg: float, closed: bool, color: str = "black"
    ) -> IKResult:
        """Solve from where the arm is and stream every iteration to the bus."""
        result = self.solver.solve(self._q_now_rad(), target_cm)
        if self.view is not None:
            self.view.set_target(target_cm)
        for q in result.q_path_rad[1:]:
            self._send(np.degrees(q[:3]), gripper_arm_deg, closed)
        if self.view is not None:
            self.view.add_path(result.ee_path_cm, color)
        return result

    def _record(
        self,
        obj: TrackedObject,
        step: str,
        attempt: int,
        target: np.ndarray,
        q_start_rad: np.ndarray,
        result: IKResult,
        success: bool,
        t0: float,
    ) -> None:
        ee = self._ee_now_cm()
        rec = {
            "object_id": obj.id,
            "color": obj.color,
            "step": step,
            "attempt": attempt,
            "target_cm": [float(v) for v in target],
            "start_joints_deg": np.degrees(q_start_rad).tolist(),
            "end_joints_deg": np.degrees(result.q_rad).tolist(),
            "iterations": int(result.iterations),
            "status": result.status,
            "initial_error_cm": float(result.initial_error_cm),
            "final_error_cm": float(result.final_error_cm),
            "ee_cm": ee.tolist(),
            "error_cm": (ee - target).tolist(),
            "success": bool(success),
            "elapsed_s": time.perf_counter() - t0,
            # commanded motion time: one command per iteration at the servo rate
            "motion_s": result.iterations / self.config.servo.rate_hz,
        }
        self.report.routes.append(rec)
        if self.log is not None:
            self.log.route(trial=self.trial, **rec)
        x, y, z = target
        mark = "ok" if success else "FAILED"
        self.echo(
            f"{step:<5} {obj.id:<7} {obj.color:<5} target ({x:6.2f}, {y:6.2f}, {z:6.2f}) cm  "
            f"{result.iterations:4d} it  solver {result.final_error_cm:.4f} cm  "
            f"arm {float(np.linalg.norm(ee - target)):.3f} cm  {mark:<6} "
            f"{rec['elapsed_s'] * 1e3:7.1f} ms"
        )

    def _skip(self, obj: TrackedObject, target: Any) -> None:
        reason = obj.skipped or "skipped"
        self.report.skipped.append((obj.id, obj.color, reason))
        if self.log is not None:
            t = [obj.x_cm, obj.y_cm, self.config.robot.gripper.pick_height_cm]
            self.log.skip(
                trial=self.trial,
                object_id=obj.id,
                color=obj.color,
                target_cm=t if target is None else [float(v) for v in target],
                reason=reason,
            )
        self.echo(f"skip  {obj.id:<7} {obj.color:<5} {reason}")

    def _pick_and_place(self, obj: TrackedObject) -> None:
        target = np.array([obj.x_cm, obj.y_cm, self.config.robot.gripper.pick_height_cm])
        attempt = obj.failed_picks + 1
        t0 = time.perf_counter()
        q0 = self._q_now_rad()
        try:
            result = self._route(target, self._travel_deg, False, obj.color)
        except TargetError as exc:
            obj.skipped = exc.reason
            self._skip(obj, target)
            return
        gripped = False
        if result.converged:
            self._gripper(self._grip_deg, False)
            self._gripper(self._grip_deg, True)
            self._gripper(self._travel_deg, True)
            # SPEC §1 step 6 re-reads the table; here it also tells whether the grip held
            gripped = not self._on_table(obj, self._look())
        self._record(obj, "pick", attempt, target, q0, result, gripped, t0)
        if not gripped:
            if self.bus.state is not None and self.bus.state.gripper_closed:
                self._gripper(self._travel_deg, False)
            # back off upwards so the retry approaches afresh (from the same pose the
            # servos would land where they just missed)
            with contextlib.suppress(TargetError):  # at the edge of reach: retry from here
                self._route(target + [0.0, 0.0, RETRY_LIFT_CM], self._travel_deg, False)
            obj.failed_picks += 1
            if obj.failed_picks > self.config.task.pick_retries:
                obj.skipped = f"pick failed {obj.failed_picks} times"
                self._skip(obj, target)
            return

        bin_cm = np.array(self.config.task.bins_cm[obj.color], dtype=float)
        t0 = time.perf_counter()
        q0 = self._q_now_rad()
        result = self._route(bin_cm, self._travel_deg, True, obj.color)
        self._gripper(self._travel_deg, False)
        release = getattr(self.bus, "last_release", None)
        placed = result.converged and (release is None or release.bin == obj.color)
        obj.sorted = placed
        self._record(obj, "place", 1, bin_cm, q0, result, placed, t0)

    def _home(self) -> None:
        home = self.model.fk_cm(np.radians(self.config.robot.home_joints_deg))
        if np.linalg.norm(self._ee_now_cm() - home) > 1e-9:
            self._route(home, self._travel_deg, False)
        self._send(self.config.robot.home_deg, self.config.robot.gripper.home_angle_deg, False)

    # ----------------------------------------------------------------- run

    def run(self) -> SortReport:
        """Sort until the table is clear (or only skipped objects remain), then go home.

        Raises:
            SortAborted: camera or servo failure, or Ctrl-C; the reason is logged first.
        """
        try:
            if not self.bus.is_connected:
                self.bus.connect()
            self._send(self.config.robot.home_deg, self.config.robot.gripper.home_angle_deg, False)
            max_rounds = self.max_rounds
            for _ in range(max_rounds):
                obj = self._choose(self._look())
                if obj is None:
                    break
                self._pick_and_place(obj)
            else:  # a table that never clears (flickering detections?): stop, say so
                for obj in self._objects:
                    if obj.skipped is None and not obj.sorted:
                        obj.skipped = f"still on the table after {max_rounds} pick rounds"
                        self._skip(obj, None)
            self._home()
        except (CameraError, ServoError) as exc:
            self._abort(str(exc), park=isinstance(exc, CameraError))
        except KeyboardInterrupt:
            self._abort("interrupted (Ctrl-C)", park=True, interrupted=True)
        if self.log is not None:
            self.log.summary(trial=self.trial, ok=True)
        self._print_summary()
        return self.report

    def _abort(self, reason: str, *, park: bool, interrupted: bool = False) -> None:
        self.report.fault = reason
        parked = ""
        if park and self.bus.is_connected and self.bus.fault is None and self.bus.state:
            try:
                self._home()
                parked = "; arm parked at home"
            except (MearmError, KeyboardInterrupt) as exc:
                parked = f"; parking failed ({exc})"
                self.bus.stop()
        else:
            parked = "; nothing more sent to the servos"
        full = reason + parked
        self.report.fault = full
        if self.log is not None:
            self.log.fault(full, self._last_joints_deg(), trial=self.trial)
            self.log.summary(trial=self.trial, ok=False)
        self._print_summary()
        raise SortAborted(full, interrupted=interrupted, last_joints_deg=self._last_joints_deg())

    def _print_summary(self) -> None:
        rep = self.report
        routes = rep.routes
        per_color = rep.sorted_per_color()
        self.echo("")
        self.echo("colour  sorted  skipped")
        for color in self.config.task.color_order:
            n_skip = sum(1 for s in rep.skipped if s[1] == color)
            self.echo(f"{color:<7} {per_color.get(color, 0):6d}  {n_skip:7d}")
        if routes:
            its = np.array([r["iterations"] for r in routes])
            solver_err = np.array([r["final_error_cm"] for r in routes])
            arm_err = np.array([np.linalg.norm(r["error_cm"]) for r in routes])
            motion = sum(r["motion_s"] for r in routes)
            self.echo(
                f"routes {len(routes)}, failed picks {rep.failed_picks}, "
                f"iterations mean {its.mean():.1f} ({its.min()}–{its.max()}), "
                f"solver error mean {solver_err.mean():.4f} cm, "
                f"arm error mean {arm_err.mean():.3f} cm, "
                f"motion {motion:.1f} s at {self.config.servo.rate_hz:g} Hz"
            )
        for oid, color, reason in rep.skipped:
            self.echo(f"not sorted: {oid} ({color}): {reason}")
        if rep.fault:
            self.echo(f"stopped: {rep.fault}")
