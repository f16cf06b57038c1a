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
pulse, and with them the marker's apparent side (:mod:`mearm.task.claw_fit`:
a print's scale or the detector's edges would otherwise pass for a shoulder error). A
fit within its bound (:data:`MAX_RMS_PX`; :data:`MAX_ZEROS_RMS_PX` for the zeros alone)
that the servo file's checks accept is used for the moves from then on (the bus sends
its pulses), which is what lets the doubt shrink. The last fits must be within
:data:`MAX_RMS_PX` and pass :func:`~mearm.config.servo_file.check_fit` (a µs per unit more
than 30 % off the arm's, or a shaft more than 12° off at the neutral pulse, is refused;
a fit of the zeros alone is not checked for its zero). Where a fitted servo cannot reach
its joint's whole limits inside its pulse range, the joint's limits are narrowed to what
it reaches, in the file and for the moves from then on, and said; by more than a quarter
of them, the fit is refused (:func:`~mearm.config.servo_reach.narrowed`).

**Joints the points leave free** — the 5-DOF arm's wrist roll turns the claw about the
tool's axis, so the TCP and its approach stay — still move the marker: each point is
also visited with them at :data:`FREE_SHARES` of their range, so their scales are fitted
too.

**Objects on the table**: the camera looks once with the arm at home, and the moves keep
clear of what it sees there, and the tool's lowest point, within the doubt,
:data:`TABLE_MARGIN_CM` above the tallest class's top, as a sort's calibration at its
start does (``--simulate``: the table is empty, and the tool may come lower).

**Exits**: 0 written; 2 a servo port that cannot be opened, a board that does not answer
its handshake or a camera that cannot be opened (found as the rig opens, before anything
moves: one line); 1 a fault while moving (the arm holds where it is), the marker not
seen at home nor at the first points (:data:`FIRST_FEW` looks), a fit that does not
converge or is refused, or no way home (nothing written in each case; the arm parked
where it can be); 130 on Ctrl-C (the arm parked first, nothing written). The arm's
motion (streamed moves, waits for arrival, holds) stops taking points at
:data:`MOTION_BUDGET_S` and is printed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TextIO

from mearm.cli import EXIT_FAILURE, check_output_file
from mearm.config import Config
from mearm.config.errors import CalibrationError
from mearm.config.servo_file import (
    ActuatorFit,
    ServoCalibrationError,
    narrowing_text,
    replaced_calibration,
)
from mearm.data import doc_page
from mearm.errors import MearmError
from mearm.hardware.errors import ServoError
from mearm.maker.camera_calibration.doubt import ServoDoubt
from mearm.maker.camera_calibration.errors import CameraCalibrationFailed
from mearm.maker.camera_calibration.fit_file import (
    CameraFit,
    actuator_fits,
    midway,
    seen_points,
    seen_values,
)
from mearm.maker.camera_calibration.points import (
    Point,
    Visit,
    grid_points,
    in_frame,
    joint_line,
    objects_seen,
    pick_height_cm,
    solved,
    thinned,
    tops_cm,
    view_centre_cm,
)
from mearm.maker.camera_calibration.safe_moves import SafeMoves, Slack
from mearm.maker.camera_calibration.session import CameraSession
from mearm.maker.camera_calibration.settings import (
    APPROACH_FROM,
    CLEARANCE_STEP_CM,
    FIRST_FEW,
    FIT_SCALE,
    FIT_ZERO_US,
    FREE_SHARES,
    GRID_HALF_CM,
    GRID_STEP_CM,
    HEIGHTS_ABOVE_PICK_CM,
    JOINT_MARGIN,
    MAX_RMS_PX,
    MAX_SQUARE_RMS_PX,
    MAX_ZEROS_RMS_PX,
    MIN_SCALE_SIGHTINGS,
    MIN_SPREAD_US,
    MOTION_BUDGET_S,
    PATH_CHECK_STEP,
    PLAY_US,
    POINTS,
    SCALE_PRIOR,
    SETTLE_S,
    TABLE_MARGIN_CM,
    VIEW_MARGIN_PX,
    ZERO_PRIOR_US,
    floor_cm,
)
from mearm.maker.servo_output import board_identity, check_output, hold_arm, write_calibration
from mearm.task.rig import Rig, open_rig
from mearm.vision.calibration import camera_geometry
from mearm.vision.claw_marker import check_marker
from mearm.vision.errors import CameraError
from mearm.vision.pinhole import PerspectiveCamera

__all__ = [
    "APPROACH_FROM",
    "CLEARANCE_STEP_CM",
    "CameraCalibrationFailed",
    "CameraFit",
    "CameraSession",
    "FIRST_FEW",
    "FREE_SHARES",
    "FIT_SCALE",
    "FIT_ZERO_US",
    "GRID_HALF_CM",
    "GRID_STEP_CM",
    "HEIGHTS_ABOVE_PICK_CM",
    "JOINT_MARGIN",
    "MAX_RMS_PX",
    "MAX_SQUARE_RMS_PX",
    "MAX_ZEROS_RMS_PX",
    "MIN_SCALE_SIGHTINGS",
    "MIN_SPREAD_US",
    "MOTION_BUDGET_S",
    "PATH_CHECK_STEP",
    "PLAY_US",
    "POINTS",
    "PROG",
    "Point",
    "SCALE_PRIOR",
    "SETTLE_S",
    "SafeMoves",
    "ServoDoubt",
    "Slack",
    "TABLE_MARGIN_CM",
    "VIEW_MARGIN_PX",
    "Visit",
    "ZERO_PRIOR_US",
    "actuator_fits",
    "board_text",
    "calibrate_by_camera",
    "check_inputs",
    "grid_points",
    "in_frame",
    "joint_line",
    "measure",
    "midway",
    "objects_seen",
    "pick_height_cm",
    "report",
    "seen_points",
    "seen_values",
    "solved",
    "thinned",
    "tops_cm",
    "view_centre_cm",
]

PROG = "mearm calibrate-servos"


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
            f"it; calibrate the camera as {doc_page('calibration.md')}'s walkthrough does"
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
    camera = camera_geometry(config.calibration, config.camera)
    assert isinstance(camera, PerspectiveCamera)  # calibration.model: perspective
    return camera


def board_text(config: Config, rig: Rig, *, simulate: bool) -> tuple[str, str]:
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
    marker = session.marker
    out.write(
        f"marker: seen at {session.claw.side:.2%} of its printed side ({marker.size_cm:g} cm; "
        "the print's scale and the detector's edges), fitted with the servos\n"
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
        RigNotOpened: the servo bus or the camera did not open (bad input, before
            anything moves).
        KeyboardInterrupt: Ctrl-C, once the arm is parked (nothing written).
    """
    camera = check_inputs(config, args, output)
    if args.simulate:  # the twin on an empty table
        config = config.with_scene([])
    out = sys.stdout
    opened = False
    try:
        with open_rig(config) as rig:  # its bus connected, with the camera
            opened = True
            board, port = board_text(config, rig, simulate=args.simulate)
            out.write(f"connected: {board}{' on ' + port if port else ''}\n")
            # objects may lie on the table (not on --simulate's): the tool stays above the
            # tallest class's top, as a sort's calibration at its start keeps it; with the
            # doubt's margin round every object seen, no point passed the checks otherwise
            floor = 0.0 if args.simulate else floor_cm(config)
            session = CameraSession(config, rig, camera, out, floor_cm=floor)
            fits = measure(session)
    except (ServoError, CameraError) as exc:
        if not opened:
            # a port that cannot be opened, a board that does not answer its handshake or
            # a camera that cannot be opened, found before anything moved: bad input, said
            # by run() in one line (exit 2), as mearm check-camera says it
            from mearm.task.armcheck import RigNotOpened  # noqa: PLC0415  (did not open)

            raise RigNotOpened(str(exc)) from exc
        what = "servo fault" if isinstance(exc, ServoError) else "camera"
        print(f"{PROG}: {what}: {exc}; nothing written", file=sys.stderr)
        return EXIT_FAILURE
    except CameraCalibrationFailed as exc:
        print(f"{PROG}: {exc}; nothing written", file=sys.stderr)
        return EXIT_FAILURE
    return write_calibration(config, fits, board, port, output, force=bool(args.force))


def measure(session: CameraSession) -> list[ActuatorFit]:
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
        if isinstance(exc, CameraError):  # a frame lost: its message names the camera
            raise CameraCalibrationFailed(str(exc)) from None
        if isinstance(exc, CalibrationError):  # two markers in view
            raise CameraCalibrationFailed(f"camera: {exc}") from None
        raise
    report(session, fit, session.out)
    _park(session)
    session.say(f"arm motion {session.motion_s():.1f} s (moves, waits for arrival, holds)")
    config = session.present
    # every fit replaces the arm's own calibration, on a real board too (as the keyboard's
    # do): not a file's fit it is made over, which a config using the new file never has
    replaces = (replaced_calibration(config) or config).arm
    sightings = [s for _, s in session.above + session.below]
    points = seen_points(session.claw, sightings, fit.servos)
    try:
        fits = actuator_fits(config, fit.servos, replaces, points, session.rising_play_us(fit))
    except ServoCalibrationError as exc:
        raise CameraCalibrationFailed(f"refused: {exc}") from None
    for f in fits:
        narrowing = narrowing_text(config.arm, f)
        if narrowing is not None:
            session.say(narrowing)
    return fits


def _park(session: CameraSession) -> None:
    """Park; a fault on the way holds the arm where it is, one that is not clear too."""
    try:
        session.park()
    except (ServoError, CameraCalibrationFailed):
        hold_arm(session.bus)
        raise
