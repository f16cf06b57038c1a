r"""``mearm calibrate-servos --camera``: each joint servo's pulse map, measured by the camera.

    mearm calibrate-servos --camera --config my.yaml [--output my.servos.yaml] [--force]
    mearm calibrate-servos --camera --simulate --config configs/sim_mujoco_perspective.yaml

The calibrated camera watches the ArUco marker on the claw (``arm.tool.marker``) while
the arm visits points over the table, and each joint servo's zero, µs per unit and
direction are fitted to where it sees the marker's corners
(:class:`~mearm.task.claw_fit.ClawCamera`: least squares in pixels). The result is the
keyboard procedure's servo calibration file (:mod:`mearm.config.servo_file`), written by
the same writer after the same checks
(:func:`~mearm.maker.servo_output.write_calibration`).

**What it needs** (else exit 2, before anything opens): an arm with a claw marker whose
id is in its dictionary, a perspective calibration of the camera (a table homography
maps pixels to the table's plane only; the marker rides 10–30 cm above it), and for
``--simulate`` a config whose simulator is the MuJoCo twin, which then stands on an
empty table.

**How the arm moves.** The servos' errors are unknown at first, and large: a hobby
servo's zero is off by up to 2° of shaft and its µs per degree by −19…+15 %
(:data:`~mearm.sim.twin.servo_kit.KIT_RANGES`), up to 15° at the ends of a joint's
range. So the procedure keeps a bound of how far each servo may be from where it is
sent (:class:`ServoDoubt`: the datasheets' spread at first, what the fit leaves later),
and every move is planned in full and checked against it before anything is sent: no
joint may come, within its doubt, nearer than :data:`JOINT_MARGIN` to its limits; the
tool's lowest point stays :data:`TABLE_MARGIN_CM` above the table however far the doubt
could lower it; and the planner (:class:`~mearm.task.plan.Planner`, collision-checked
against the bins and whatever the camera saw on the table at home) keeps
``task.clearance_cm`` plus how far the doubt could move the tool, wherever the tool,
lowered by the doubt, could come below a bin wall's or an object's top. A move that
fails a check is not made. (A path may leave a pose that is already short of a margin,
the arm being there, as long as it comes no nearer.)

The points lie on a grid over the part of the table the camera sees, at
:data:`HEIGHTS_ABOVE_PICK_CM` above the objects' pick height. The first is the highest
nearest the view's centre; each next one, among those whose marker would be in view and
whose moves pass the checks, the one farthest (in the joints, each as a share of its
range) from those visited: as the fit tightens, the doubt shrinks and the points spread
over each joint's range and come lower.

**The gears' play.** A servo stops short of its command by up to half its backlash and
its dead band, on the side it came from (the twin's kits: 0.5–2° and up to 10 µs). So
each point is reached by the same final move, a straight line in the joints from
:data:`APPROACH_FROM` the way that raises the tool ("from above"), and the marker is
seen; then every joint goes as far the other way and comes back ("from below"), and it
is seen again. The arrivals from above fit each servo's zero and scale; those from
below, their zeros with the same scales; the calibration is midway between the two (as
the keyboard procedure records the pulse midway between its two approaches), and the
difference, each servo's play, is printed. The arm is held :data:`SETTLE_S` before
each frame. (Where a point's way from below would not pass the checks, it is seen from
above only.)

**The fit.** While the sightings are few, only the zeros; the scales too from
:data:`MIN_SCALE_SIGHTINGS` sightings over at least :data:`MIN_SPREAD_US` of each servo's
pulse. A fit within its bound (:data:`MAX_RMS_PX`; :data:`MAX_ZEROS_RMS_PX` for the
zeros alone) that the servo file's checks accept is used for the moves from then on (the
bus sends its pulses), which is what lets the doubt shrink. The last fits must be within
:data:`MAX_RMS_PX` and pass :func:`~mearm.config.servo_file.check_fit` (a µs per unit more
than 30 % off the arm's, or limits outside the pulse range, are refused).

**Objects on the table**: the camera looks once with the arm at home, and the moves keep
clear of what it sees there, as the sort's do (``--simulate``: the table is empty).

**Exits**: 0 written; 1 a fault while moving (the arm holds where it is), the marker not
seen at home nor at the first points (:data:`FIRST_FEW` looks), a fit that does not
converge or is refused, or no way home (nothing written in each case; the arm parked
where it can be); 130 on Ctrl-C (the arm parked first, nothing written). The arm's
motion (streamed moves, waits for arrival, holds) stops taking points at
:data:`MOTION_BUDGET_S` and is printed.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np
from scipy.optimize import least_squares

from mearm.cli import EXIT_FAILURE, check_output_file
from mearm.config import Config
from mearm.config.arm import ArmDescription
from mearm.config.errors import CalibrationError
from mearm.config.servo_file import (
    ActuatorFit,
    CalibrationPoint,
    ServoCalibrationError,
    apply_servo_calibration,
    check_fit,
    fitted_servo,
    replaced_calibration,
    servo_of,
)
from mearm.config.servo_models import servo_named
from mearm.errors import ConfigError, MearmError
from mearm.hardware import ActuatorMap, ArmCommand, ServoMap
from mearm.hardware.errors import ServoError
from mearm.ik import IKTarget
from mearm.kinematics.bodies import bin_origin_m, bin_shapes, marker_in_tcp
from mearm.kinematics.chain import Chain
from mearm.kinematics.collision import CollisionModel
from mearm.maker.servo_output import board_identity, check_output, hold_arm, write_calibration
from mearm.task.claw_fit import ClawCamera, ServoFit, Sighting
from mearm.task.execute import JOINT_STEP, Executor
from mearm.task.plan import Planner
from mearm.task.rig import Rig, open_rig
from mearm.task.route import Route
from mearm.vision.calibration import camera_geometry
from mearm.vision.claw_marker import check_marker, find_claw_marker
from mearm.vision.detector import ColorDetector
from mearm.vision.errors import CameraError
from mearm.vision.pinhole import PerspectiveCamera

PROG = "mearm calibrate-servos"

# --- the doubt: how far a servo may be from where it is sent [µs of pulse] ---------------
#: The gears' play: half a unit's backlash (up to 2° of shaft) and its dead band (up to
#: 10 µs), 1° each at 10 µs per degree (the twin's kits, servo_kit's sourced ranges).
PLAY_US = 20.0
#: A unit's zero before any fit: up to 2° of shaft at the neutral pulse.
ZERO_PRIOR_US = 20.0
#: A unit's µs per degree before the scales are fitted: −19…+15 % of the datasheet's.
SCALE_PRIOR = 0.2
#: A fitted zero [µs], and the least error of a fitted scale beyond the pulses it was
#: fitted over [-].
FIT_ZERO_US = 5.0
FIT_SCALE = 0.05

# --- the moves ---------------------------------------------------------------------------
#: The tool's lowest point stays this far above the table, within the doubt [cm].
TABLE_MARGIN_CM = 1.0
#: Each joint stays this far inside its limits, within the doubt [deg or cm].
JOINT_MARGIN = 1.0
#: The collision clearance is ``task.clearance_cm`` plus the doubt's reach of the tool,
#: rounded up to this step [cm] (a planner per step, kept).
CLEARANCE_STEP_CM = 0.5
#: The points' TCP heights above the objects' pick height, highest first [cm].
HEIGHTS_ABOVE_PICK_CM = (9.0, 6.0, 3.0)
#: The grid of points about the view's centre: its pitch, and how far it reaches across
#: and along the table [cm].
GRID_STEP_CM = 4.0
GRID_HALF_CM = (16.0, 12.0)
#: Every look's final move: each joint turning from this far below (or above) [deg or
#: cm]: more than a unit's backlash and dead band together (2° and 1° of shaft at most),
#: so each arrives with its gears' play taken up the same way.
APPROACH_FROM = {"deg": 4.0, "cm": 0.4}
#: A path's doubt is checked at poses this many degrees (cm) of its largest joint turn apart.
PATH_CHECK_STEP = 1.0
#: How long the arm is held still before a frame is read [s].
SETTLE_S = 0.3
#: A predicted marker keeps this far inside the frame, besides the doubt's reach [px].
VIEW_MARGIN_PX = 25.0

# --- the sightings and the fit -----------------------------------------------------------
#: Points visited at most (after the look at home).
POINTS = 16
#: Looks (home and the first points) after which a marker never seen ends the run.
FIRST_FEW = 4
#: The scales are fitted from this many sightings on, spread over this much of each
#: servo's pulse [µs] (10° at 10 µs per degree; how well they are known follows from the
#: spread, ServoDoubt).
MIN_SCALE_SIGHTINGS = 6
MIN_SPREAD_US = 100.0
#: A fit whose RMS corner residual is above this does not converge [px]: the twin's kits
#: (spread 1, seeds 1-6) fit to 0.4-0.8 px, with the gears' play taken up alike; a few
#: pixels more mean that the marker is not where the arm puts it.
MAX_RMS_PX = 3.0
#: A fit of the zeros alone leaves the scales' errors over the pulses sighted: up to
#: 15 px over the first points on those kits; above this it is not used for the moves.
MAX_ZEROS_RMS_PX = 20.0
#: A sighting whose corners fit a square's image worse than this is not used [px].
MAX_SQUARE_RMS_PX = 1.5
#: The arm's motion (moves, waits and holds) stops taking points past this [s], so that
#: parking keeps the whole within 3 minutes.
MOTION_BUDGET_S = 150.0


class CameraCalibrationFailed(MearmError):
    """The procedure ended without a calibration (exit 1); the message says why."""


def check_inputs(config: Config, args: argparse.Namespace, output: Path) -> PerspectiveCamera:
    """Refuse what the procedure cannot run with, before anything opens; the camera.

    Raises:
        MearmError: no claw marker, its id not in its dictionary, a camera without a
            perspective calibration, ``--simulate`` on a config that is not the twin's,
            ``--actuators`` (the joint servos are fitted together), or an output that
            exists without ``--force`` or is not a servo calibration.
    """
    arm = config.arm
    if arm.tool.marker is None:
        raise MearmError(
            f"--camera: the arm {arm.name!r} has no marker on its claw (arm.tool.marker): "
            "add one, e.g. marker: {id: 42, size_cm: 3.0} under arm.tool, printed with "
            "mearm aruco-sheet --output claw.png --ids 42 --side-cm 3"
        )
    check_marker(arm.tool.marker)
    if config.calibration.model != "perspective":
        raise MearmError(
            "--camera needs a perspective calibration of the camera (calibration.model: "
            f"perspective), not {config.calibration.model!r}: a table homography maps "
            "pixels to the table's plane only and cannot measure the marker 10-30 cm above "
            "it; calibrate the camera as docs/calibration.md's walkthrough does"
        )
    if args.simulate and config.simulator != "mujoco":
        raise MearmError(
            f"--simulate runs against the MuJoCo twin: the config's simulator is "
            f"{config.simulator!r}; use one with simulator: mujoco and a perspective "
            "camera (configs/sim_mujoco_perspective.yaml)"
        )
    if args.actuators is not None:
        raise MearmError(
            "--camera fits every joint servo together (the marker's place depends on all "
            "of them): leave out --actuators, or calibrate single actuators by keyboard"
        )
    check_output_file(output, "--output")
    check_output(output, force=bool(args.force))
    camera = camera_geometry(config)
    assert isinstance(camera, PerspectiveCamera)  # calibration.model: perspective
    return camera


@dataclass
class ServoDoubt:
    r"""How far each joint servo may turn from where its pulse is meant to put it.

    Before any fit: the gears' play, a unit's zero, and its scale's error about the
    middle of its pulse range. After a fit of the zeros: the play, the fitted zero and
    the scale's error about the mean pulse sighted (the zero absorbed it there). After a
    fit of the scales too: the play and the fitted zero within the pulses sighted, and
    beyond them the fitted scale's error, which the play at the two ends of the pulses
    sighted bounds (:math:`2 \cdot` :data:`PLAY_US` over their spread), or the prior
    where that is less.

    The play is :data:`PLAY_US` until it is measured (:attr:`play_us`): the fit is made
    of arrivals from one side, and a move may end on the other, by the play.

    Attributes:
        scales: Whether the scales are fitted (``None``: nothing is).
        sighted: Each servo's pulses at the sightings the fit used [µs].
        scale_doubt: Each fitted scale's possible error, a share of it [-].
        play_us: Each servo's play as measured: how far its zero from below lies from
            its zero from above [µs].
    """

    scales: bool | None = None
    sighted: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    scale_doubt: dict[str, float] = dataclasses.field(default_factory=dict)
    play_us: dict[str, float] = dataclasses.field(default_factory=dict)

    def learn(self, fit: ServoFit, sightings: Sequence[Sighting], nominal: ServoMap) -> None:
        """Take the doubt a fit leaves (the fit is now the one the bus sends).

        Args:
            fit: The fit.
            sightings: The sightings it fitted.
            nominal: The calibration the prior's scale error is about.
        """
        self.scales = fit.scales
        self.sighted = {
            j.name: np.array([s.pulses_us[j.name] for s in sightings]) for j in fit.servos
        }
        for j in fit.servos:
            off = abs(j.us_per_unit / nominal[j.name].us_per_unit - 1.0)
            spread = float(np.ptp(self.sighted[j.name]))
            bound = 2.0 * PLAY_US / spread if spread > 0 else math.inf
            self.scale_doubt[j.name] = max(FIT_SCALE, min(bound, SCALE_PRIOR + off))

    def pulse_us(self, amap: ActuatorMap, pulse: float) -> float:
        """How far servo ``amap`` may be from where ``pulse`` is meant to put it [µs]."""
        if self.scales is None:
            middle = (amap.min_us + amap.max_us) / 2.0
            return PLAY_US + ZERO_PRIOR_US + SCALE_PRIOR * abs(pulse - middle)
        seen, play = self.sighted[amap.name], self.play_us.get(amap.name, PLAY_US)
        if not self.scales:
            return play + FIT_ZERO_US + SCALE_PRIOR * abs(pulse - float(seen.mean()))
        beyond = max(float(seen.min()) - pulse, pulse - float(seen.max()), 0.0)
        return play + FIT_ZERO_US + self.scale_doubt[amap.name] * beyond

    def servos(self, smap: ServoMap, named: dict[str, float]) -> np.ndarray:
        """Each joint servo's doubt at the joints ``named`` [deg or cm], chain order."""
        values = smap.servo_values(named)
        return np.array(
            [self.pulse_us(j, j.pulse_us(values[j.name])) / j.us_per_unit for j in smap.joints]
        )

    def joints(self, smap: ServoMap, named: dict[str, float]) -> np.ndarray:
        """Each actuated joint's doubt at the joints ``named`` [deg or cm], chain order.

        A servo that turns a combination of joints moves each joint of it by its share
        (:math:`|A^{-1}|` times the servos' doubts).
        """
        doubt = self.servos(smap, named)
        combo = smap.combination
        return doubt if combo is None else np.abs(np.linalg.inv(combo[0])) @ doubt


@dataclass(frozen=True)
class Slack:
    """How far a pose keeps inside the moves' checks within the doubt (below 0: outside).

    Attributes:
        joints: Each actuated joint's room to :data:`JOINT_MARGIN` inside its limits,
            model units, (m,).
        travel: Each joint servo's room to :data:`JOINT_MARGIN` inside its travel (the
            values the arm's own calibration puts at its ``min_us`` and ``max_us``: where
            its shaft stops) [deg or cm], (m,).
        table_cm: The tool's lowest point's room to :data:`TABLE_MARGIN_CM` [cm].
        reach_cm: How far the doubt may move a point of the tool, where that may bring
            it near a bin or an object; 0 where the tool, lowered by the doubt, stays
            above every bin wall and object by ``task.clearance_cm`` [cm].
        low_cm: The tool's lowest point above the table, as planned [cm].
        drop_cm: How far the doubt may lower it [cm].
        doubt: Each actuated joint's doubt, model units, (m,).
    """

    joints: np.ndarray
    travel: np.ndarray
    table_cm: float
    reach_cm: float
    low_cm: float
    drop_cm: float
    doubt: np.ndarray


@dataclass(frozen=True)
class Point:
    """A point the marker is looked at from.

    Attributes:
        target_cm: The TCP there (x, y, z) [cm].
        q: The joints the solver puts it at from home (model units), (n,).
        spread: The actuated joints, each as a share of its range, (m,).
    """

    target_cm: tuple[float, float, float]
    q: np.ndarray
    spread: np.ndarray


@dataclass(frozen=True)
class Visit:
    """The moves to a point, planned and checked in full.

    Attributes:
        route: A planned route first, or ``None``.
        lines: Then straight lines in the joints, each from where the last ends, (k, n)
            model units each; the last one the final move to the point.
    """

    route: Route | None
    lines: tuple[np.ndarray, ...]

    def path(self) -> np.ndarray:
        """Every pose the visit passes, in order, (k, n) model units."""
        parts = [] if self.route is None or self.route.plan is None else [self.route.plan.q_path]
        return np.vstack([*parts, *self.lines])


@dataclass(frozen=True)
class CameraFit:
    """The calibration: the arrivals from above and from below, and midway between.

    Attributes:
        servos: Each joint servo's map, midway between the two arrivals' zeros.
        above: The fit of the arrivals from above (zeros and scales).
        below: The fit of the arrivals from below (zeros, the same scales), or ``None``
            when the marker was not seen from below.
        play_us: Each servo's zero from below less its zero from above [µs].
    """

    servos: tuple[ActuatorMap, ...]
    above: ServoFit
    below: ServoFit | None
    play_us: dict[str, float]


@dataclass(frozen=True)
class _Used:
    """Whether a fit is used for the moves: falsy with ``why`` it is not."""

    why: str = ""

    def __bool__(self) -> bool:
        return not self.why


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
    the frame.
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
                if q is not None and in_frame(claw, q, VIEW_MARGIN_PX):
                    points.append(Point(target, q, (chain.actuated_of(q) - lo) / (hi - lo)))
    return points


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
    for name in config.task.class_names:
        z0 = float(bin_origin_m(config, name)[2])
        tops += [
            (z0 + float(s.pose[2, 3]) + float(s.size[-1])) * 100.0 for s in bin_shapes(config, name)
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


class CameraSession:
    """The procedure on an open rig, its bus connected: the moves, the looks, the fits.

    Args:
        config: The whole configuration (the present calibration; the scene as opened).
        rig: The rig, its bus connected.
        camera: The calibrated camera.
        out: Where the progress goes.

    Attributes:
        home: The marker seen with the arm at home (``None``: not seen), fitted alone
            until a point's is seen: the arm came home by no final move.
        raises: Each actuated joint's way (±1) that raises the tool at home.
        above: The marker seen at each point (where), the arm come down from above: every
            joint arrived turning against :attr:`raises`.
        below: The same, the arm come back up from below.
        fit: The fit the bus sends (``None``: the present calibration).
        fits: How many fits the bus has sent so far.
        held_s: The time the arm was held still for the looks [s].
    """

    def __init__(self, config: Config, rig: Rig, camera: PerspectiveCamera, out: TextIO):
        marker = config.arm.tool.marker
        assert marker is not None  # check_inputs
        self.present = config
        self.config = config  # with the fit the bus sends, once one is used
        own = replaced_calibration(config) or config  # the arm's calibration, before any file
        self.nominal_arm = own.arm
        self.shaft = ServoMap.from_config(own)  # where each servo's shaft stops: its pulse range
        self.rig, self.bus, self.model = rig, rig.bus, rig.model
        self.bus.servo_map = self.bus.servo_map.without_play()  # the play is measured
        self.chain = rig.model.chain
        self.marker = marker
        face = marker_in_tcp(config, servo_named(config.twin.gripper_servo))
        assert face is not None  # the tool has a marker
        self.claw = ClawCamera(
            rig.model, ServoMap.from_config(config), face, marker.size_cm, camera
        )
        self.executor = Executor(config, rig.bus, rig.model, None)
        self.doubt = ServoDoubt()
        self.home: Sighting | None = None
        self.above: list[tuple[str, Sighting]] = []
        self.below: list[tuple[str, Sighting]] = []
        self.fit: ServoFit | None = None
        self.fits = 0
        self.params = self.claw.start()
        self.held_s = 0.0
        self.looks = 0
        self.visited: list[np.ndarray] = []
        self.objects: list[tuple[str, str, float, float]] = []
        self.out = out
        self._collision: dict[float, CollisionModel] = {}
        self._planner: dict[float, Planner] = {}
        self.raises = self._raising()
        self.tops_cm = tops_cm(config, [])

    def say(self, text: str) -> None:
        """Print a line of progress."""
        self.out.write(text + "\n")
        self.out.flush()

    def motion_s(self) -> float:
        """The arm's motion so far: streamed moves, waits for arrival, holds [s]."""
        m = self.executor.motion
        return m.arm_s + m.wait_s + m.tool_s + self.held_s

    # ----------------------------------------------------------------- planners

    def planner(self, clearance_cm: float) -> Planner:
        """A planner keeping ``clearance_cm`` from the bins and the objects seen (kept)."""
        key = round(clearance_cm, 3)
        if key not in self._collision:
            col = CollisionModel(self.present, self.model, clearance_cm=key)
            col.set_world(self.objects, opening_cm=self.present.arm.tool.gripper.open_cm)
            self._collision[key] = col
        if key not in self._planner:  # with the calibration the bus sends
            self._planner[key] = Planner(self.config, self.model, self._collision[key])
        return self._planner[key]

    def collision(self, clearance_cm: float) -> CollisionModel:
        """:meth:`planner`'s collision model."""
        col = self.planner(clearance_cm).collision
        assert col is not None
        return col

    def clearance_cm(self, reach_cm: float) -> float:
        """``task.clearance_cm`` plus ``reach_cm``, rounded up to :data:`CLEARANCE_STEP_CM`."""
        steps = math.ceil(max(0.0, reach_cm) / CLEARANCE_STEP_CM - 1e-9)
        return self.present.task.clearance_cm + steps * CLEARANCE_STEP_CM

    # ----------------------------------------------------------------- the doubt

    def tool_points(self, q: np.ndarray) -> np.ndarray:
        """The TCP, the jaws' tips and the marker's centre at joints ``q`` [cm], (3, 3)."""
        p, R = self.model.tcp_pose(q)
        tool = self.present.arm.tool
        hang = tool.tcp_above_grip_cm + tool.gripper.jaw_length_cm / 2.0
        return np.array([p, p + (R @ self.model.approach_axis) * hang, self.claw.centre_cm(q)])

    def doubt_turns(self, q: np.ndarray) -> tuple[np.ndarray, list[tuple[np.ndarray, ...]]]:
        """Each actuated joint's doubt at ``q``, and the poses with it turned by it.

        Returns:
            The doubts (model units, (m,)), and per joint the two poses with it turned by
            its doubt either way.
        """
        chain = self.chain
        doubt = self.doubt.joints(self.bus.servo_map, chain.named_actuated(q))
        doubt = doubt * chain.scale[chain.actuated_index]
        a = chain.actuated_of(q)
        return doubt, [
            tuple(chain.full(a + sign * d * np.eye(len(a))[i]) for sign in (-1.0, 1.0))
            for i, d in enumerate(doubt)
        ]

    def slack(self, q: np.ndarray) -> Slack:
        """How far the pose ``q`` keeps inside the checks, within the doubt.

        Each joint's worst turn within its doubt, the table's and the tool's reach added
        up over the joints.
        """
        chain = self.chain
        margin = JOINT_MARGIN * chain.scale[chain.actuated_index]
        a = chain.actuated_of(q)
        doubt, turns = self.doubt_turns(q)
        joints = np.minimum(
            a - doubt - (chain.actuated_lower + margin), chain.actuated_upper - margin - a - doubt
        )
        col = self.collision(self.present.task.clearance_cm)
        low, points = col.tool_lowest_cm(q)[0], self.tool_points(q)
        drop = reach = 0.0
        for turned in turns:
            drop += max(0.0, *(low - col.tool_lowest_cm(t)[0] for t in turned))
            reach += max(
                float(np.linalg.norm(self.tool_points(t) - points, axis=1).max()) for t in turned
            )
        if low - drop >= self.tops_cm + self.present.task.clearance_cm:
            reach = 0.0  # above everything, however far it strays sideways
        travel = self.travel(q)
        return Slack(joints, travel, low - drop - TABLE_MARGIN_CM, reach, low, drop, doubt)

    def travel(self, q: np.ndarray) -> np.ndarray:
        """Each joint servo's room inside its travel at ``q``, within the doubt (:class:`Slack`).

        A servo that turns a combination of joints (the MeArm v1's elbow) can reach the
        end of its shaft's travel inside the joints' limits.
        """
        named = self.chain.named_actuated(q)
        smap = self.bus.servo_map
        values = smap.servo_values(named)
        doubt = self.doubt.servos(smap, named)
        room = []
        for j, d in zip(smap.joints, doubt, strict=True):
            lo, hi = self.shaft[j.name].pulse_limits
            v = values[j.name]
            room.append(min(v - d - lo, hi - v - d) - JOINT_MARGIN)
        return np.array(room)

    def refusal(self, q: np.ndarray, floor: Slack | None = None) -> tuple[str | None, float]:
        """Why the pose ``q`` is not safe within the doubt (``None``: it is), and its reach.

        The reach: how far the doubt could move the tool there [cm]. With ``floor`` (the
        slack where a path starts), a pose may keep as little slack as the start where
        that has less than none: the arm may leave where it is.
        """
        s = self.slack(q)
        chain = self.chain
        scale = chain.scale[chain.actuated_index]
        least = np.zeros_like(s.joints) if floor is None else np.minimum(0.0, floor.joints)
        for i, name in enumerate(chain.actuated):
            if s.joints[i] < least[i] - 1e-9:
                unit = chain.unit(int(chain.actuated_index[i]))
                a = chain.actuated_of(q)[i] / scale[i]
                return (
                    f"{name} at {a:.1f} {unit} could come within {JOINT_MARGIN:g} {unit} of "
                    f"its limits (it may be {s.doubt[i] / scale[i]:.1f} {unit} off)",
                    s.reach_cm,
                )
        least = np.zeros_like(s.travel) if floor is None else np.minimum(0.0, floor.travel)
        for i, servo in enumerate(self.bus.servo_map.joints):
            if s.travel[i] < least[i] - 1e-9:
                return (
                    f"{servo.servo_text} could come within {JOINT_MARGIN:g} {servo.unit} of the "
                    "end of its travel",
                    s.reach_cm,
                )
        if s.table_cm < (0.0 if floor is None else min(0.0, floor.table_cm)) - 1e-6:
            return (
                f"the tool, {s.low_cm:.1f} cm above the table, could come down {s.drop_cm:.1f} "
                f"cm (to within {TABLE_MARGIN_CM:g} cm of it)",
                s.reach_cm,
            )
        return None, s.reach_cm

    def path_refusal(self, q_path: np.ndarray) -> tuple[str | None, float]:
        """:meth:`refusal` along a path from its first pose: the first, and the largest reach.

        Checked every :data:`PATH_CHECK_STEP` of the joints' largest turn and at the end:
        the doubt changes little in between (the collisions are checked whole by the
        planner).
        """
        floor = self.slack(q_path[0])
        worst = floor.reach_cm
        for q in thinned(self.chain, q_path)[1:]:
            why, reach = self.refusal(q, floor)
            if why is not None:
                return why, reach
            worst = max(worst, reach)
        return None, worst

    # ----------------------------------------------------------------- the points

    def may_try(self, point: Point) -> bool:
        """Whether ``point`` and its final move's start pass the checks, its marker in view."""
        if self.refusal(point.q)[0] is not None:
            return False
        if self.refusal(self.turned(point.q, 1.0))[0] is not None:
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

    def _raising(self) -> np.ndarray:
        """Each actuated joint's way (±1) that raises the tool's lowest point at home."""
        col = self.collision(self.present.task.clearance_cm)
        home, chain = self.model.home, self.chain
        low = col.tool_lowest_cm(home)[0]
        ways = []
        for i in range(chain.m):
            a = chain.actuated_of(home)
            a[i] += 1e-3
            ways.append(-1.0 if col.tool_lowest_cm(chain.full(a))[0] < low - 1e-9 else 1.0)
        return np.array(ways)

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

    def turned(self, q: np.ndarray, way: float) -> np.ndarray:
        """``q``, each joint :data:`APPROACH_FROM` the way that raises the tool (-1: lowers)."""
        chain = self.chain
        step = [APPROACH_FROM[chain.unit(int(i))] for i in chain.actuated_index]
        shift = way * self.raises * np.array(step) * chain.scale[chain.actuated_index]
        return chain.full(chain.actuated_of(q) + shift)

    def plan_visit(self, point: Point) -> Visit | str:
        """The moves to ``point``, planned in full and checked, or why not.

        To where the final move starts (every joint :data:`APPROACH_FROM` from the
        point's, the way that raises the tool: :meth:`way_to`), then the final move, a
        straight line in the joints, down to the point. The checks keep the doubt's reach
        of the tool at the start and at the point as clearance; moves that reach farther
        are planned again with their reach.
        """
        q0 = self.executor.q_now()
        target = IKTarget(point.target_cm, self.present.arm.tool.pick_approach)
        q_end = solved(self.planner(self.present.task.clearance_cm), target, q0)
        if q_end is None:
            return "no solution inside the limits"
        start = self.turned(q_end, 1.0)
        need = max(self.refusal(q0)[1], self.refusal(q_end)[1])
        for _ in range(3):
            clearance = self.clearance_cm(need)
            visit = self.way_to(q0, start, clearance)
            if isinstance(visit, str):
                return visit
            final = joint_line(self.chain, visit.path()[-1], q_end)
            why = self.line_refusal(final, clearance)
            if why is not None:
                return "the final move: " + why
            visit = dataclasses.replace(visit, lines=(*visit.lines, final))
            why, reach = self.path_refusal(visit.path())
            if why is not None:
                return why
            if self.clearance_cm(reach) <= clearance:
                return visit
            need = reach
        return f"the doubt's reach grew to {need:.1f} cm with each plan"

    def way_to(self, q0: np.ndarray, start: np.ndarray, clearance_cm: float) -> Visit | str:
        """The way from ``q0`` to ``start``, or why there is none.

        A straight line in the joints where that is clear; else a planned route to its TCP
        (which may go up, over and down), and a line from where that ends where that is
        not ``start`` (an arm with joints to spare).
        """
        line = joint_line(self.chain, q0, start)
        if self.line_refusal(line, clearance_cm) is None:
            return Visit(None, (line,))
        approach = None  # the approach axis as it is there, where picks keep one
        if self.present.arm.tool.pick_approach is not None:
            ax, ay, az = (float(v) for v in self.model.approach(start))
            approach = (ax, ay, az)
        x, y, z = (float(v) for v in self.model.fk_cm(start))
        route = Route("", "", "approach", 1, IKTarget((x, y, z), approach))
        if not self.planner(clearance_cm).plan(route, q0).planned or route.plan is None:
            return route.failure or "no plan"
        turn = np.abs(self.chain.actuated_of(self.turned(start, -1.0) - start))
        off = np.abs(self.chain.actuated_of(route.plan.q - start))
        if np.all(off <= 0.1 * turn):  # there, to the solver's tolerance
            return Visit(route, ())
        line = joint_line(self.chain, route.plan.q, start)
        why = self.line_refusal(line, clearance_cm)
        if why is not None:
            return "the way to where its final move starts: " + why
        return Visit(route, (line,))

    def line_refusal(self, path: np.ndarray, clearance_cm: float) -> str | None:
        """Why a straight line in the joints may not be sent: the limits or a collision."""
        planner = self.planner(clearance_cm)
        if not planner.pose_allowed(path):
            return "it leaves the limits"
        contact = self.collision(clearance_cm).first_contact(path)
        if contact is not None:
            return contact.describe(self.chain.names, self.chain.scale)
        return None

    def go(self, visit: Visit) -> None:
        """Stream a visit's route, if any, then its lines (as checked)."""
        if visit.route is not None:
            self.executor.stream(visit.route, "travel", False)
        for line in visit.lines:
            self.line(line)

    def line(self, path: np.ndarray) -> None:
        """Move along a checked straight line in the joints, from where the arm is.

        Raises:
            CameraCalibrationFailed: the executor's line is not the one checked (a bug).
        """
        ex = self.executor
        if not np.allclose(ex.joint_path(path[-1]), path, atol=1e-9):
            raise CameraCalibrationFailed("the move is not the one checked (a bug); stopped")
        ex.move_joints(path[-1], "travel", False)

    def from_below(self) -> str | None:
        """Each joint :data:`APPROACH_FROM` the way that lowers the tool and back; or why not."""
        q = self.executor.q_now()
        over = self.turned(q, -1.0)
        there, back = joint_line(self.chain, q, over), joint_line(self.chain, over, q)
        path = np.vstack([there, back[1:]])
        why, reach = self.path_refusal(path)
        if why is None:
            why = self.line_refusal(path, self.clearance_cm(reach))
        if why is not None:
            return why
        self.line(there)
        self.line(back)
        return None

    # ----------------------------------------------------------------- the looks

    def look(self) -> Sighting | None:
        """Hold the arm :data:`SETTLE_S`, read a frame: the marker's sighting, if seen.

        A marker whose corners are not a square's image (:data:`MAX_SQUARE_RMS_PX`: cut by
        something in front of it) counts as not seen. The pulses are the ones the bus
        holds, to the µs.
        """
        self.bus.hold(SETTLE_S)
        self.held_s += SETTLE_S
        self.looks += 1
        seen = find_claw_marker(self.rig.camera.read(), self.marker, self.claw.camera)
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
        joints it says the arm is at now are inside their limits. The bus then holds the
        same pulses, read as those joints.
        """
        bound = MAX_RMS_PX if fit.scales else MAX_ZEROS_RMS_PX
        if fit.rms_px > bound:
            return _Used(f"rms above {bound:g} px")
        try:
            fits = actuator_fits(self.present, fit.servos, self.nominal_arm)
            for f in fits:
                check_fit(self.present.arm, f, servo_of(self.nominal_arm, f.name))
            config = apply_servo_calibration(self.present, fits, source="the camera's fit")
        except (ServoCalibrationError, ConfigError) as exc:
            return _Used(str(exc))
        smap, state = ServoMap.from_config(config), self.bus.state
        assert state is not None
        held = {
            j.name: j.command_us(j.servo_value(state.joints)) for j in self.bus.servo_map.joints
        }
        q = self.chain.from_named(
            smap.joints_of({j.name: j.value_of(held[j.name]) for j in smap.joints})
        )
        if not self.chain.within_limits(q, tol=1e-6):
            return _Used("it puts the arm outside its limits")
        self.bus.servo_map = smap
        # the same pulses (to the µs): the arm stays, now where the fit says it is
        self.bus.move(
            ArmCommand(self.chain.named_actuated(q), dict(state.tool), state.gripper_closed)
        )
        self.config, self._planner = config, {}
        self.fit, self.params = fit, self.claw.params_of(fit.servos)
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

    def begin(self) -> list[Point]:
        """Home; what is on the table, the points over the view; the look at home.

        Raises:
            CameraCalibrationFailed: no point over the view would show the marker.
        """
        self.executor.home_pose()
        self.objects = objects_seen(self.present, self.claw.camera, self.rig.camera.read())
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
        return midway(self.claw, first, second)

    def park(self) -> None:
        """Home along a straight line in the joints, first straight up if that is not clear.

        The line keeps ``task.clearance_cm`` and the doubt's reach from the bins and
        objects, as far as home itself does (the arm started there).

        Raises:
            CameraCalibrationFailed: no way home is clear; the arm stays where it is.
        """
        ex, home = self.executor, self.model.home
        room_cm = self.collision(self.present.task.clearance_cm).gap(home)[0] * 100.0
        reach = max(self.slack(q).reach_cm for q in ex.joint_path(home)[::5])
        clearance = self.clearance_cm(min(reach, room_cm - CLEARANCE_STEP_CM))
        planner, collision = self.planner(clearance), self.collision(clearance)
        contact = collision.first_contact(ex.joint_path(home))
        if contact is not None:  # up first, to where the line home is clear
            x, y, z = (float(v) for v in ex.ee_now_cm())
            safe = planner.safe_height_cm(ex.q_now())
            approach = self.present.arm.tool.pick_approach
            up = Route("", "", "home", 1, IKTarget((x, y, max(z, safe)), approach))
            if planner.plan(up, ex.q_now()).planned:
                ex.stream(up, "travel", False)
                contact = collision.first_contact(ex.joint_path(home))
        if contact is not None:
            raise CameraCalibrationFailed(
                "not parked: the way home "
                + contact.describe(self.chain.names, self.chain.scale)
                + "; the arm stays where it is"
            )
        ex.move_joints(home, "travel", False)
        ex.home_pose()


def midway(claw: ClawCamera, above: ServoFit, below: ServoFit | None) -> CameraFit:
    """The calibration midway between the arrivals from above and from below.

    Their scales are the same (``below`` fitted only its zeros): the zeros are averaged.
    """
    if below is None:
        return CameraFit(above.servos, above, None, {})
    za, zb = claw.params_of(above.servos)[0::2], claw.params_of(below.servos)[0::2]
    params = claw.params_of(above.servos)
    params[0::2] = (za + zb) / 2.0
    play = {n: float(b - a) for n, a, b in zip(claw.names, za, zb, strict=True)}
    return CameraFit(claw.servo_maps(params), above, below, play)


def actuator_fits(
    config: Config,
    servos: Sequence[ActuatorMap],
    replaces_arm: ArmDescription,
    points: dict[str, tuple[CalibrationPoint, ...]] | None = None,
    play_us: Mapping[str, float] | None = None,
) -> list[ActuatorFit]:
    """Joint servo maps as the servo file's entries.

    Args:
        config: The whole config (each servo's present calibration: its channel, pulse
            range, speed and combination are kept).
        servos: The fitted maps.
        replaces_arm: The arm whose calibration each entry records it replaces.
        points: Each servo's points (the value the camera saw it at, its pulse).
        play_us: Each servo's measured play, the pulse rising less falling [µs]
            (:meth:`CameraSession.rising_play_us`); none where not given.

    Raises:
        ServoCalibrationError: a fitted value the servo's calibration refuses.
    """
    out = []
    for amap in servos:
        template = servo_of(config.arm, amap.name)
        slope = amap.direction * amap.us_per_unit
        play = (play_us or {}).get(amap.name, 0.0)
        servo = fitted_servo(template, amap.name, amap.zero_us, slope, play_us=play)
        seen = (points or {}).get(amap.name, ())
        residual = max((abs(servo.pulse_us(p.value) - p.pulse_us) for p in seen), default=0.0)
        replaces = servo_of(replaces_arm, amap.name)
        out.append(ActuatorFit(amap.name, amap.unit, servo, tuple(seen), residual, replaces))
    return out


def seen_values(claw: ClawCamera, sighting: Sighting, params: np.ndarray) -> np.ndarray:
    """Each joint servo's value the camera saw at one sighting [unit], chain order.

    The values whose marker best explains that sighting's corners alone, from the
    fit's; how far they lie from the fitted lines is the file's ``residual_us``.
    """
    names = claw.names
    as_values = np.tile([0.0, 1.0], len(names))  # zero 0, 1 µs per unit: pulses are values
    p = np.array([sighting.pulses_us[n] for n in names])
    start = (p - params[0::2]) / params[1::2]

    def residual(v: np.ndarray) -> np.ndarray:
        q = claw.joints(dict(zip(names, v, strict=True)), as_values)
        return (claw.pixels(q) - sighting.corners_px).ravel()

    return least_squares(residual, start, method="lm").x


def seen_points(
    claw: ClawCamera, sightings: Sequence[Sighting], servos: Sequence[ActuatorMap]
) -> dict[str, tuple[CalibrationPoint, ...]]:
    """Each servo's points: per sighting, the value the camera saw and the pulse held."""
    params = claw.params_of(servos)
    values = np.array([seen_values(claw, s, params) for s in sightings])
    return {
        name: tuple(
            CalibrationPoint(round(float(values[i, k]), 3), int(round(s.pulses_us[name])))
            for i, s in enumerate(sightings)
        )
        for k, name in enumerate(claw.names)
    }


def board_text(config: Config, rig: Rig, simulate: bool) -> tuple[str, str]:
    """The board and port the file records."""
    if not simulate:
        board, port = board_identity(rig.bus)
        return f"{board}; fitted by the camera", port
    kit = config.twin.kit
    if kit is None:
        return "simulated: the MuJoCo twin, nominal servos; fitted by the camera", ""
    trial = f" trial {config.servo.error_model.seed}" if kit.per_trial else ""
    return (
        f"simulated: the MuJoCo twin, kit seed {kit.seed} spread {kit.spread:g}{trial}; "
        "fitted by the camera",
        "",
    )


def report(session: CameraSession, fit: CameraFit, out: TextIO) -> None:
    """Print each servo's calibration and play, and each sighting's residual."""
    for amap in fit.servos:
        play = fit.play_us.get(amap.name)
        extra = "" if play is None else (
            f"; play {play:+.1f} µs ({play / amap.us_per_unit:+.2f} {amap.unit}) from above "
            "to below"
        )  # fmt: skip
        out.write(
            f"{amap.servo_text}: zero {amap.zero_us:.1f} µs, {amap.us_per_unit:.3f} "
            f"µs/{amap.unit}, direction {amap.direction:+d}{extra}\n"
        )
    for name, seen, part in (
        ("from above", session.above, fit.above),
        ("from below", session.below, fit.below),
    ):
        if part is None:
            continue
        out.write(f"residual per pose {name} (rms over its corners; all {part.rms_px:.2f} px):\n")
        for (where, _), r in zip(seen, part.residuals_px, strict=True):
            out.write(f"  {where}: {r:.2f} px\n")


def calibrate_by_camera(config: Config, output: Path, args: argparse.Namespace) -> int:
    """``--camera``: the procedure (module docstring); the exit status.

    Raises:
        MearmError: bad input (:func:`check_inputs`), before anything opens.
        KeyboardInterrupt: Ctrl-C, once the arm is parked (nothing written).
    """
    camera = check_inputs(config, args, output)
    if args.simulate:  # the twin on an empty table
        config = config.model_copy(update={"task": config.task.model_copy(update={"scene": []})})
    out = sys.stdout
    try:
        with open_rig(config) as rig:
            rig.bus.connect()
            board, port = board_text(config, rig, args.simulate)
            out.write(f"connected: {board}{' on ' + port if port else ''}\n")
            session = CameraSession(config, rig, camera, out)
            fits = measure(session, args.simulate)
    except ServoError as exc:
        print(f"{PROG}: servo fault: {exc}; nothing written", file=sys.stderr)
        return EXIT_FAILURE
    except CameraError as exc:  # the camera did not open
        print(f"{PROG}: camera: {exc}; nothing written", file=sys.stderr)
        return EXIT_FAILURE
    except CameraCalibrationFailed as exc:
        print(f"{PROG}: {exc}; nothing written", file=sys.stderr)
        return EXIT_FAILURE
    return write_calibration(config, fits, board, port, output, bool(args.force))


def measure(session: CameraSession, simulate: bool) -> list[ActuatorFit]:
    """Run the session and park: the file's entries.

    A fault holds the arm where it is; Ctrl-C and a run that fails park it first (a way
    home that is not clear then leaves it where it is, and is said).

    Raises:
        ServoError: a fault while moving.
        CameraCalibrationFailed: the run failed (a camera that failed, a second print of
            the marker in view, too), or the arm could not be parked after it.
        KeyboardInterrupt: Ctrl-C.
    """
    try:
        fit = session.run()
    except ServoError:
        hold_arm(session.bus)
        raise
    except (KeyboardInterrupt, CameraCalibrationFailed, CameraError, CalibrationError) as exc:
        stop = "interrupted" if isinstance(exc, KeyboardInterrupt) else "stopped"
        session.say(f"{stop}: nothing written; parking the arm")
        try:
            _park(session)
        except CameraCalibrationFailed as why:  # the first reason stands
            session.say(str(why))
        if isinstance(exc, CameraError | CalibrationError):  # a frame lost, two markers
            raise CameraCalibrationFailed(f"camera: {exc}") from None
        raise
    report(session, fit, session.out)
    _park(session)
    session.say(f"arm motion {session.motion_s():.1f} s (moves, waits for arrival, holds)")
    config = session.present
    nominal = replaced_calibration(config)
    # the twin's units stay relative to what a file replaced (as calibrate-servos --simulate)
    replaces = nominal.arm if simulate and nominal is not None else config.arm
    sightings = [s for _, s in session.above + session.below]
    points = seen_points(session.claw, sightings, fit.servos)
    try:
        return actuator_fits(config, fit.servos, replaces, points, session.rising_play_us(fit))
    except ServoCalibrationError as exc:
        raise CameraCalibrationFailed(f"refused: {exc}") from None


def _park(session: CameraSession) -> None:
    """Park; a fault on the way holds the arm where it is, one that is not clear too."""
    try:
        session.park()
    except (ServoError, CameraCalibrationFailed):
        hold_arm(session.bus)
        raise
