"""The camera's procedure on an open rig: the points visited, the looks, the fits."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TextIO

import numpy as np

from mearm.config import Config
from mearm.config.servo_file import (
    ServoCalibrationError,
    apply_servo_calibration,
    check_fit,
    servo_of,
)
from mearm.config.servo_models import servo_named
from mearm.errors import ConfigError
from mearm.hardware import ArmCommand, ServoMap
from mearm.kinematics.bodies import marker_in_tcp
from mearm.maker.camera_calibration.errors import CameraCalibrationFailed
from mearm.maker.camera_calibration.fit_file import CameraFit, actuator_fits, midway
from mearm.maker.camera_calibration.points import (
    Point,
    grid_points,
    in_frame,
    objects_seen,
    pick_height_cm,
    tops_cm,
    view_centre_cm,
)
from mearm.maker.camera_calibration.safe_moves import SafeMoves, limits_of
from mearm.maker.camera_calibration.settings import (
    APPROACH_FROM,
    FIRST_FEW,
    HEIGHTS_ABOVE_PICK_CM,
    MAX_RMS_PX,
    MAX_SQUARE_RMS_PX,
    MAX_ZEROS_RMS_PX,
    MIN_SCALE_SIGHTINGS,
    MIN_SPREAD_US,
    MOTION_BUDGET_S,
    POINTS,
    SETTLE_S,
    VIEW_MARGIN_PX,
)
from mearm.task.claw_fit import ClawCamera, ServoFit, Sighting
from mearm.task.rig import Rig
from mearm.task.table_tracking import check_bins
from mearm.vision.bin_edges import BinFeet
from mearm.vision.claw_marker import find_claw_marker
from mearm.vision.frame_check import FrameCheck
from mearm.vision.pinhole import PerspectiveCamera


@dataclass(frozen=True)
class _Used:
    """Whether a fit is used for the moves: falsy with ``why`` it is not."""

    why: str = ""

    def __bool__(self) -> bool:
        return not self.why


class CameraSession(SafeMoves):
    """The procedure on an open rig, its bus connected: the points, the looks, the fits.

    The moves and their checks are :class:`SafeMoves`'.

    Args:
        config: The whole configuration (the present calibration; the scene as opened).
        rig: The rig, its bus connected.
        camera: The calibrated camera.
        out: Where the progress goes.
        floor_cm: The tool's lowest point stays this high above the table, within the
            doubt (:class:`SafeMoves`; at least its table margin) [cm].

    Attributes:
        home: The marker seen with the arm at home (``None``: not seen), fitted alone
            until a point's is seen: the arm came home by no final move.
        above: The marker seen at each point (where), the arm come down from above: every
            joint arrived turning against :attr:`raises`.
        below: The same, the arm come back up from below.
        fit: The fit the bus sends (``None``: the present calibration).
        fits: How many fits the bus has sent so far.
        held_s: The time the arm was held still for the looks [s].
        result: The calibration :meth:`run` returned (``None``: not yet, or none).
        frame_check: Refuses a black frame and a frozen stream
            (:class:`~mearm.vision.frame_check.FrameCheck`): a camera fault, not a marker
            out of view nor a fit that does not converge.
    """

    def __init__(
        self,
        config: Config,
        rig: Rig,
        camera: PerspectiveCamera,
        out: TextIO,
        *,
        floor_cm: float = 0.0,
    ):
        marker = config.arm.tool.marker
        assert marker is not None  # check_inputs
        face = marker_in_tcp(config.arm, servo_named(config.twin.gripper_servo))
        assert face is not None  # the tool has a marker
        claw = ClawCamera(rig.model, ServoMap.from_arm(config.arm), face, marker.size_cm, camera,
                          fit_side=True)  # fmt: skip
        super().__init__(config, rig, claw, floor_cm=floor_cm)
        self.marker = marker
        self.home: Sighting | None = None
        self.above: list[tuple[str, Sighting]] = []
        self.below: list[tuple[str, Sighting]] = []
        self.fit: ServoFit | None = None
        self.fits = 0
        self.params = self.claw.start()
        self.held_s = 0.0
        self.looks = 0
        self.visited: list[np.ndarray] = []
        self.out = out
        self.result: CameraFit | None = None
        self.frame_check = FrameCheck(rig.camera.source)

    def say(self, text: str) -> None:
        """Print a line of progress."""
        self.out.write(text + "\n")
        self.out.flush()

    def motion_s(self) -> float:
        """The arm's motion so far: streamed moves, waits for arrival, holds [s]."""
        m = self.executor.motion
        return m.arm_s + m.wait_s + m.tool_s + self.held_s

    # ----------------------------------------------------------------- the points

    def may_try(self, point: Point) -> bool:
        """Whether ``point`` and its final move's start pass the checks, its marker in view."""
        if not self.allows(point.q) or not self.allows(self.turned(point.q, 1.0)):
            return False
        return in_frame(self.claw, point.q, VIEW_MARGIN_PX + self.sway_px(point.q))

    def sway_px(self, q: np.ndarray) -> float:
        """How far the doubt could move the marker's corners in the frame at ``q`` [px].

        Each joint's worst turn within its doubt, added up over the joints.
        """
        px = self.claw.pixels(q)
        return sum(
            max(float(np.linalg.norm(self.claw.pixels(t) - px, axis=1).max()) for t in turned)
            for turned in self.doubt_turns(q)[1]
        )

    def next_point(self, points: Sequence[Point], tried: dict[int, float]) -> int | None:
        """The next point to visit, or ``None``: its index in ``points``.

        The first: the highest nearest the view's centre. Then the one farthest in the
        joints (each a share of its range) from those visited. Either only where it
        :meth:`may_try`, and not ``tried`` (index → the :attr:`fits` it was tried under:
        one whose moves were refused is tried again under a later fit).
        """
        left = [(k, p) for k, p in enumerate(points) if tried.get(k, -1) < self.fits]
        if len(self.visited) <= 1:  # home only
            top = max((p.target_cm[2] for _, p in left), default=0.0)
            centre = view_centre_cm(self.claw.camera, top)

            def score(p: Point) -> float:
                return -1e3 * abs(p.target_cm[2] - top) - math.dist(p.target_cm[:2], centre)
        else:
            seen = np.array(self.visited)

            def score(p: Point) -> float:
                return float(np.min(np.linalg.norm(seen - p.spread, axis=1)))

        for k, p in sorted(left, key=lambda kp: -score(kp[1])):
            if self.may_try(p):
                return k
        return None

    def rising_play_us(self, fit: CameraFit) -> dict[str, float]:
        """Each servo's play as the servo file keeps it: the pulse rising less falling.

        :attr:`CameraFit.play_us` is the zero from below less the zero from above; the
        arrivals from above came with every joint turning against :attr:`raises`, and each
        servo's pulse then moved the way its combination and direction say.
        """
        chain = self.chain
        step = [APPROACH_FROM[chain.unit(int(i))] for i in chain.actuated_index]
        down = -self.raises * np.array(step)  # the final move from above, config units
        comb = self.bus.servo_map.combination
        values = down if comb is None else comb[0] @ down
        out = {}
        for amap, dv in zip(fit.servos, values, strict=True):
            if amap.name in fit.play_us and dv != 0:
                rising_from_above = amap.direction * dv > 0
                play = fit.play_us[amap.name]  # zero from below − zero from above
                out[amap.name] = -play if rising_from_above else play
        return out

    # ----------------------------------------------------------------- the looks

    def look(self) -> Sighting | None:
        """Hold the arm :data:`SETTLE_S`, read a frame: the marker's sighting, if seen.

        A marker whose corners are not a square's image (:data:`MAX_SQUARE_RMS_PX`: cut by
        something in front of it) counts as not seen. The pulses are the ones the bus
        holds, to the µs.

        Raises:
            CameraError: the frame is black, or the stream froze (:attr:`frame_check`): a
                black frame shows no marker, a frozen one the marker where the arm was,
                which no fit matches.
        """
        self.bus.hold(SETTLE_S)
        self.held_s += SETTLE_S
        self.looks += 1
        frame = self.frame_check.read(self.rig.camera)
        seen = find_claw_marker(frame, self.marker, self.claw.camera)
        if seen is None or seen.rms_px > MAX_SQUARE_RMS_PX:
            return None
        state = self.bus.state
        assert state is not None  # the arm was sent home first
        smap = self.bus.servo_map
        values = smap.servo_values(state.joints)
        pulses = {j.name: float(j.command_us(values[j.name])) for j in smap.joints}
        return Sighting(pulses, seen.corners_px)

    def fitted(self) -> list[Sighting]:
        """The sightings the moves' fit is made of: the arrivals from above, or home's."""
        if self.above:
            return [s for _, s in self.above]
        return [] if self.home is None else [self.home]

    def spread_enough(self, sightings: Sequence[Sighting]) -> bool:
        """Whether the sightings are enough to fit the scales.

        :data:`MIN_SCALE_SIGHTINGS` of them, each servo's pulses over :data:`MIN_SPREAD_US`.
        """
        if len(sightings) < MIN_SCALE_SIGHTINGS:
            return False
        return all(
            np.ptp([s.pulses_us[n] for s in sightings]) >= MIN_SPREAD_US for n in self.claw.names
        )

    def refit(self) -> str:
        """Fit the sightings again and use the fit where it holds; what happened, in words."""
        sightings = self.fitted()
        if not sightings:
            return "nothing fitted yet"
        scales = self.spread_enough(sightings)
        fit = self.claw.fit(sightings, scales=scales, start=self.params)
        used = self.use(fit, sightings)
        if used and scales and self.below:  # the play, from below to above
            below = self.claw.fit([s for _, s in self.below], scales=False, start=self.params)
            if below.rms_px <= MAX_RMS_PX:
                zb, za = self.claw.params_of(below.servos)[0::2], self.params[0::2]
                self.doubt.play_us = dict(
                    zip(self.claw.names, np.abs(zb - za).tolist(), strict=True)
                )
        return (
            f"{len(sightings)} fitted, {'zeros and scales' if scales else 'zeros'}: rms "
            f"{fit.rms_px:.2f} px" + ("" if used else f" (not used: {used.why})")
        )

    def use(self, fit: ServoFit, sightings: Sequence[Sighting]) -> _Used:
        """Send the fit's pulses from now on, where it holds (:class:`_Used`: why not).

        It holds when its RMS is within its bound, the servo file's checks pass and the
        joints it says the arm is at now are inside their limits (narrowed where its
        servos reach less). The bus then holds the same pulses, read as those joints.
        """
        bound = MAX_RMS_PX if fit.scales else MAX_ZEROS_RMS_PX
        if fit.rms_px > bound:
            return _Used(f"rms above {bound:g} px")
        try:
            fits = actuator_fits(self.present, fit.servos, self.nominal_arm)
            for f in fits:
                nominal = servo_of(self.nominal_arm, f.name)
                check_fit(self.present.arm, f, nominal, zero=fit.scales)
            config = apply_servo_calibration(self.present, fits, source="the camera's fit")
        except (ServoCalibrationError, ConfigError) as exc:
            return _Used(str(exc))
        smap, state = ServoMap.from_arm(config.arm), self.bus.state
        assert state is not None
        held = {
            j.name: j.command_us(j.servo_value(state.joints)) for j in self.bus.servo_map.joints
        }
        q = self.chain.from_named(
            smap.joints_of({j.name: j.value_of(held[j.name]) for j in smap.joints})
        )
        lower, upper = limits_of(self.chain, config)
        a = self.chain.actuated_of(q)
        outside = np.any(a < lower - 1e-6) or np.any(a > upper + 1e-6)
        if outside or not self.chain.within_limits(q, tol=1e-6):
            return _Used("it puts the arm outside its limits")
        self.bus.servo_map = smap
        # the same pulses (to the µs): the arm stays, now where the fit says it is
        self.bus.move(
            ArmCommand(self.chain.named_actuated(q), dict(state.tool), state.gripper_closed)
        )
        self.config, self._planner = config, {}
        self.fit, self.params = fit, self.claw.params_of(fit.servos)
        self.claw.use_side(fit)
        self.fits += 1
        self.doubt.learn(fit, sightings, self.claw.servo_map)
        return _Used()

    def look_at_point(self, label: str, where: str) -> None:
        """At a point: look (come down from above), fit; from below, look again."""
        seen = self.look()
        if seen is None:
            self.say(f"{label}: {where}: the marker is not in view")
            return
        self.above.append((where, seen))
        u, v = seen.corners_px.mean(axis=0)
        text = f"{label}: {where}: marker at ({u:.0f}, {v:.0f}) px; " + self.refit()
        why = self.from_below()
        if why is not None:
            self.say(text + f"; not from below: {why}")
            return
        below = self.look()
        if below is None:
            self.say(text + "; from below: the marker is not in view")
            return
        self.below.append((where, below))
        self.say(text)

    # ----------------------------------------------------------------- the run

    def run(self) -> CameraFit:
        """Look at home, visit the points, fit: the calibration (the arm not yet parked).

        Raises:
            CameraCalibrationFailed: the marker not seen in the first :data:`FIRST_FEW`
                looks, or :meth:`final_fit` refuses.
            CameraError: a frame is black, or the stream froze (:attr:`frame_check`).
            ServoError: a fault while moving (the caller holds the arm).
        """
        ex = self.executor
        points = self.begin()
        tried: dict[int, float] = {}
        refused = ""
        k = 0
        while k < POINTS and self.motion_s() < MOTION_BUDGET_S:
            index = self.next_point(points, tried)
            if index is None:
                self.say(f"no point left that the moves' checks allow ({k} visited)")
                break
            point = points[index]
            where = "TCP ({:.1f}, {:.1f}, {:.1f}) cm".format(*point.target_cm)
            visit = self.plan_visit(point)
            if isinstance(visit, str):
                tried[index] = self.fits  # again once another fit is used
                self.say(f"  {where}: left out for now: {visit}")
                refused = visit
                continue
            tried[index] = math.inf  # visited: not again
            self.go(visit)
            k += 1
            self.visited.append(self._share(ex.q_now()))
            self.look_at_point(f"point {k} of {POINTS}", where)
            if self.home is None and not self.above and self.looks >= FIRST_FEW:
                raise self.not_in_view(f"not seen at home nor at the first {k} points")
        if k == 0:
            raise CameraCalibrationFailed(
                "no point over the view passes the moves' checks while the servos' errors "
                f"are unknown (the last: {refused or 'none left'}); clear the table around "
                "the bins, or check the arm's limits and calibration"
            )
        if self.home is None and not self.above:
            raise self.not_in_view(
                f"not seen at home nor at the {k} point{'s' if k != 1 else ''} the moves' "
                "checks allow before it is seen"
            )
        return self.final_fit()

    def check_view(self, frame: np.ndarray) -> None:
        """Refuse a view that moved since the camera's calibration, before the arm moves.

        The bins stand still: their feet seen away from where the calibration puts them
        (:func:`~mearm.task.table_tracking.check_bins`) mean the camera moved, and a fit
        to it would be the servos' calibration to a wrong view: ``sim_mujoco_kits --random
        7 --seed 35113 --set twin.camera.height_cm=49.3`` (the camera 5.7 cm lower than
        calibrated; simulated) fitted the kit's servos to it, and the arm sent home by that
        fit pressed its jaws on the red bin's wall and stalled.

        Raises:
            CameraError: the view moved; the bins and the farthest foot are named.
        """
        camera = self.present.camera
        size = (camera.width_px, camera.height_px)
        feet = BinFeet(self.claw.camera, list(self.present.task.classes), size)
        check_bins(feet.measure(frame), {}, self.frame_check.source)

    def begin(self) -> list[Point]:
        """Home; what is on the table, the points over the view; the look at home.

        Raises:
            CameraCalibrationFailed: no point over the view would show the marker.
            CameraError: a frame is black, the stream froze (:attr:`frame_check`), or the
                view moved since the camera's calibration (:meth:`check_view`).
        """
        self.executor.home_pose()
        frame = self.frame_check.read(self.rig.camera)
        self.check_view(frame)
        self.objects = objects_seen(self.present, self.claw.camera, frame)
        self._collision, self._planner = {}, {}  # with the objects seen
        self.tops_cm = tops_cm(self.present, self.objects)
        if self.objects:
            seen = ", ".join(f"{o[0]} at ({o[2]:.1f}, {o[3]:.1f})" for o in self.objects)
            self.say(f"on the table: {seen} cm; the moves keep clear of them")
        points = grid_points(self.present, self.planner(self.present.task.clearance_cm), self.claw)
        if not points:
            raise self.not_in_view(
                "at no point over the view would it face the camera inside the frame, "
                f"as configured (arm.tool.marker.faces: {self.marker.faces})"
            )
        heights = ", ".join(
            f"{pick_height_cm(self.present) + h:.1f}" for h in HEIGHTS_ABOVE_PICK_CM
        )
        self.say(f"{len(points)} points over the view, TCP {heights} cm high; visiting {POINTS}")
        self.visited.append(self._share(self.executor.q_now()))
        self.home = self.look()
        self.say("home: " + ("the marker is not in view" if self.home is None else self.refit()))
        return points

    def not_in_view(self, why: str) -> CameraCalibrationFailed:
        """The run's end when the camera does not see the marker."""
        m = self.marker
        return CameraCalibrationFailed(
            f"the marker on the claw is not in view: {why} (marker {m.id} of "
            f"{m.dictionary}, {m.size_cm:g} cm); check that it faces the camera "
            "(arm.tool.marker.faces), is lit and flat, that its id is the one printed, and "
            "that the camera has not moved since its calibration"
        )

    def _share(self, q: np.ndarray) -> np.ndarray:
        """The actuated joints of ``q``, each as a share of its range."""
        lo, hi = self.chain.actuated_lower, self.chain.actuated_upper
        return (self.chain.actuated_of(q) - lo) / (hi - lo)

    def final_fit(self) -> CameraFit:
        """The calibration, midway between the arrivals from above and from below.

        The arrivals from above fit the zeros and scales, those from below their zeros.

        Raises:
            CameraCalibrationFailed: the arrivals from above too few, or not spread over
                a servo's pulse; or a fit above :data:`MAX_RMS_PX`.
        """
        above = [s for _, s in self.above]
        if not self.spread_enough(above):
            spreads = ", ".join(
                f"{n} {np.ptp([s.pulses_us[n] for s in above]) if above else 0:.0f} µs"
                for n in self.claw.names
            )
            raise CameraCalibrationFailed(
                f"{len(above)} sightings at points, over {spreads}: the scales need "
                f"{MIN_SCALE_SIGHTINGS} over {MIN_SPREAD_US:g} µs of each servo; clear the "
                "table under the view and light the marker"
            )
        first = self.claw.fit(above, scales=True, start=self.params)
        self.claw.use_side(first)  # the arrivals from below, and each servo's points
        second = None
        if self.below:
            below = [s for _, s in self.below]
            second = self.claw.fit(below, scales=False, start=self.claw.params_of(first.servos))
        for name, fit in (("from above", first), ("from below", second)):
            if fit is not None and fit.rms_px > MAX_RMS_PX:
                raise CameraCalibrationFailed(
                    f"the fit does not converge: the marker's corners seen {name} are "
                    f"{fit.rms_px:.2f} px off (rms; bound {MAX_RMS_PX:g} px): the marker is "
                    "not where the arm puts it (a loose horn or plate, the camera moved "
                    "since its calibration?)"
                )
        self.result = midway(self.claw, first, second)
        return self.result
