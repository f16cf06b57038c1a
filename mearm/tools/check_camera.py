"""Check the camera's calibration with the arm: set an object down, see where the camera sees it.

    mearm check-camera --config configs/sim_mujoco.yaml [--points 4] [--class red]
    mearm check-camera --config my_rig.yaml --refine calib/extrinsics_refined.yaml

The arm takes one object lying on the table (the first detected, or one of ``--class``)
and sets it down at ``--points`` check points spread over the part of the camera's view
it reaches, clear of the bins and the other objects, each with room around it for where
a set-down leaves the object; after each it goes home and the camera locates the object
(every move planned and checked against the bins and the objects first). It prints each
point's residual (seen − commanded, [cm]), their RMS and the largest, and puts the object
back where it lay (:mod:`mearm.task.armcheck`).

With ``servo.calibrate_at_start: when_uncalibrated`` (and no ``servo.calibration_file``)
it first calibrates the servos by the camera, the arm at home, as ``mearm sort`` does
(:mod:`mearm.maker.camera_calibration.at_start`), and checks with that calibration.

With ``--refine OUT`` (a perspective calibration only) it fits the rotation about the
vertical and the shift on the table that best map the seen points onto the commanded
ones, moves the camera's pose by them and writes it to OUT (marked ``refined_by_arm``,
its ``rms_px`` its own reprojection error over the check points), and prints the
residuals the refined pose gives on the same frames. An existing OUT is replaced only by
a pose no worse, compared like with like (:func:`write_refined`), and kept first as
``OUT.bak`` (beside an earlier backup, ``OUT.bak.1``, …: no backup replaces another, so
the marker-fitted pose a first refine displaced outlives a second). Each file written is
named on stdout, the backup first (``wrote OUT.bak (the old OUT)``), then ``wrote OUT``.

Exit 0: the check ran and printed its figures; 1: it could not complete (no object seen,
no room for as many points as asked, a point that failed, a camera or servo fault during
the check, a calibration of the servos at the start that gave none: one line on stderr
says which, and OUT is not written); 2: bad input, one line on stderr (OUT is checked
before the arm moves), a camera that cannot be opened, a servo port that cannot be opened
and a board that does not answer its handshake included (found as the rig opens, before
anything moves, as ``mearm sort`` says them), and an OUT kept after the check (a better
pose in it). 130 on Ctrl-C (143 on SIGTERM, 129 on SIGHUP): nothing more is sent, the arm
stays where it is (as ``mearm jog`` leaves it), and the one line names its last
acknowledged pose.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mearm import interrupts
from mearm.cli import (
    PLAIN_INTEGER,
    ArgumentParser,
    add_config_argument,
    backup_written,
    check_plain_number,
    check_yaml_output,
    config_from_args,
    refuse_own_inputs,
    run,
)
from mearm.config import Config
from mearm.config.errors import CalibrationError
from mearm.config.files import resolve_config_path
from mearm.errors import MearmError
from mearm.hardware.errors import ServoError
from mearm.task.armcheck import (
    MAX_POINTS,
    MIN_POINTS,
    ArmCheck,
    CheckInterrupted,
    NothingToCheck,
    max_cm,
    rms_cm,
    run_check,
)
from mearm.task.execute import CollisionError
from mearm.task.sorter import StartCalibrationFailed
from mearm.vision.calibration import camera_geometry
from mearm.vision.errors import CameraError
from mearm.vision.pinhole import Extrinsics, PerspectiveCamera, load_calibration, save_calibration


def _points(text: str) -> int:
    check_plain_number(text, f"must be a plain whole number ({PLAIN_INTEGER})")
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number, got {text[:40]!r}") from None
    if not MIN_POINTS <= n <= MAX_POINTS:
        raise argparse.ArgumentTypeError(f"must be in {MIN_POINTS} … {MAX_POINTS}, got {n}")
    return n


def _xy(v: np.ndarray) -> str:
    return f"({v[0]:+7.2f}, {v[1]:+7.2f})"


def report_lines(check: ArmCheck) -> list[str]:
    """The check's figures, one line each: every point, then the RMS and the largest.

    The lines of the servos' calibration at the start come first; with a refined pose,
    its points and figures, and both poses' residuals over the points [px] follow.
    """
    lines = [*check.notes, f"object: {check.class_name}, lay at {_xy(check.start_cm)} cm"]
    for k, p in enumerate(check.points, 1):
        r = p.residual_cm
        if r is None:
            lines.append(f"point {k}: commanded {_xy(p.commanded_cm)} cm: failed: {p.failure}")
            continue
        assert p.seen_cm is not None
        lines.append(
            f"point {k}: commanded {_xy(p.commanded_cm)} seen {_xy(p.seen_cm)} "
            f"residual {_xy(r)} |r| {float(np.hypot(*r)):.3f} cm"
        )
    res = check.residuals_cm
    lines.append(
        f"residual: rms {rms_cm(res):.3f} cm, max {max_cm(res):.3f} cm over {len(res)} points"
    )
    refined = check.refined_residuals_cm
    if refined is not None:
        for k, r in enumerate(refined, 1):
            lines.append(f"refined point {k}: residual {_xy(r)} |r| {float(np.hypot(*r)):.3f} cm")
        lines.append(
            f"refined residual: rms {rms_cm(refined):.3f} cm, max {max_cm(refined):.3f} cm"
        )
    if check.refined is not None and check.checked_rms_px is not None:
        lines.append(
            f"pose residual over the points: rms {check.checked_rms_px:.3f} px checked, "
            f"{check.refined.rms_px:.3f} px refined"
        )
    return lines


#: How the command names itself on stderr.
PROG = "mearm check-camera"


def _intrinsics_file(config: Config) -> Path | None:
    """The intrinsics file a perspective calibration reads, else ``None``."""
    name = config.calibration.intrinsics_file
    return Path(name) if name else None


def _pose_in(path: Path) -> Extrinsics | None:
    """The camera pose a regular file holds, or ``None`` (none there, or not a pose)."""
    if not path.is_file():
        return None
    try:
        cal = load_calibration(path)
    except CalibrationError:
        return None
    return cal if isinstance(cal, Extrinsics) else None


def _same_pose(a: Extrinsics, b: Extrinsics) -> bool:
    """Whether two calibrations hold the same camera's same pose."""
    return (
        a.camera_id == b.camera_id
        and a.size_px == b.size_px
        and np.array_equal(a.rotation, b.rotation)
        and np.array_equal(a.position_cm, b.position_cm)
    )


def _refinable(out: Path, checked: Extrinsics) -> None:
    """Refuse an existing OUT that no refined pose of ``checked``'s camera may replace.

    Not a readable calibration (a config, notes), or another camera's, kind or frame
    size: refused before the arm moves, as writing it would be (not after the check).

    Raises:
        CalibrationError: which, and what to do.
    """
    try:
        held = load_calibration(out)
    except CalibrationError as exc:
        raise CalibrationError(
            f"--refine {out}: exists and is not a readable camera calibration "
            f"({exc.reason}): write elsewhere, or pass --force to replace it"
        ) from None
    if (held.kind, held.camera_id, held.size_px) != (
        checked.kind, checked.camera_id, checked.size_px
    ):  # fmt: skip
        w, h = held.size_px
        raise CalibrationError(
            f"--refine {out}: holds the {held.kind} of camera {held.camera_id!r} at {w}x{h} "
            f"px, not a pose of {checked.camera_id!r} at "
            f"{checked.size_px[0]}x{checked.size_px[1]} px: write elsewhere, or pass --force "
            "to replace it"
        )


def check_refine_output(out: Path, checked: Extrinsics, *, force: bool) -> None:
    """Refuse an OUT whose pose a refine cannot weigh.

    Called before the arm moves, and again just before the write. An OUT that is no pose
    of the camera checked is refused (:func:`_refinable`); a marker-fitted pose in OUT
    other than the one checked is not replaced without ``force``: its ``rms_px`` is over
    its markers, a refined pose's over the arm's points, and this check did not measure
    it.

    Raises:
        CalibrationError: either, and what to do.
    """
    if not force and out.exists():
        _refinable(out, checked)
    old = _pose_in(out)
    if not force and old is not None and not old.refined_by_arm and not _same_pose(old, checked):
        raise CalibrationError(
            f"--refine {out}: holds a marker-fitted pose this check does not measure (its "
            "rms_px is over markers, a refined one's over the arm's points): write "
            "elsewhere, check that pose, or pass --force"
        )


def write_refined(out: Path, check: ArmCheck, checked: Extrinsics, *, force: bool) -> None:
    """Write the refined pose to ``out``, unless that would lose a better or unweighed pose.

    Like with like: where ``out`` holds the pose checked, the refined pose's residual
    over the check points is compared with that pose's over the same points
    (:attr:`ArmCheck.checked_rms_px`; not with its ``rms_px``, which may be over its
    markers); where it holds another pose refined by the arm, the two ``rms_px`` (each
    over its own check's points) are compared by
    :func:`~mearm.vision.pinhole.save_calibration`'s rule. The worse is not written
    without ``force``. The pose ``out`` held is kept first (``out.bak``, or ``out.bak.N``
    beside an earlier backup: none is replaced) and named on stdout once written
    (``wrote PATH (the old OUT)``), so a user sees every file the refine changed. The
    caller names ``out``.

    Raises:
        CalibrationError: the pose in ``out`` is better, or not to be weighed.
        MearmError: a file cannot be written.
    """
    refined = check.refined
    assert refined is not None and check.checked_rms_px is not None
    check_refine_output(out, checked, force=force)
    old = _pose_in(out)
    holds_checked = old is not None and _same_pose(old, checked)
    if holds_checked and not force and refined.rms_px > check.checked_rms_px:
        raise CalibrationError(
            f"{out} holds the pose checked, which fits the check's points better (rms "
            f"{check.checked_rms_px:.3f} px) than the refined one (rms {refined.rms_px:.3f} "
            "px): kept; pass --force to replace it"
        )
    try:
        # the pose checked is weighed above; any other by the file's own rule
        save_calibration(
            out, refined, force=force or holds_checked,
            on_backup=lambda backup: print(backup_written(out, backup)),
        )  # fmt: skip
    except OSError as exc:
        raise MearmError(f"cannot write {out}: {exc.strerror or exc}") from None


def main(argv: Sequence[str] | None = None) -> int:
    """Run the check (and the refinement); the exit codes are the module's."""
    parser = ArgumentParser(
        description="Check the camera calibration with the arm: residuals seen − commanded.",
    )
    add_config_argument(parser)
    parser.add_argument(
        "--points", type=_points, default=4,
        help=f"check points ({MIN_POINTS} … {MAX_POINTS}; default 4)",
    )  # fmt: skip
    parser.add_argument("--class", dest="class_name", help="take an object of this class")
    parser.add_argument(
        "--refine", type=Path, metavar="OUT",
        help="fit the camera pose to the points and write the extrinsics to OUT",
    )  # fmt: skip
    parser.add_argument("--force", action="store_true", help="with --refine: replace any file")
    args = parser.parse_args(argv)
    if args.refine is not None:
        check_yaml_output(args.refine, "--refine")
    config = config_from_args(args)
    if args.refine is not None:
        # the pose file it refines may be replaced (kept as .bak); the config and the
        # intrinsics it reads may not, even with --force
        refuse_own_inputs(
            [("--refine", args.refine)],
            [
                ("--config", resolve_config_path(args.config) if args.config else None),
                ("intrinsics", _intrinsics_file(config)),
            ],
        )
    if args.class_name is not None and args.class_name not in config.task.class_names:
        parser.error(
            f"--class {args.class_name!r}: no such class (classes: "
            f"{', '.join(config.task.class_names)})"
        )
    checked = None
    if args.refine is not None:
        geometry = camera_geometry(config.calibration, config.camera)
        if not isinstance(geometry, PerspectiveCamera):
            parser.error(
                "--refine needs a perspective calibration (calibration.model: perspective "
                "with intrinsics_file and extrinsics_file); this config has the homography"
            )
        checked = geometry.extrinsics
        check_refine_output(args.refine, checked, force=args.force)
    from mearm.maker.camera_calibration.at_start import for_config  # noqa: PLC0415  (the sort's)

    try:
        # a rig that does not open raises RigNotOpened: bad input, said by run() (exit 2)
        check = run_check(
            config, points=args.points, class_name=args.class_name,
            refine=args.refine is not None, echo=None, calibrate_first=for_config(config),
        )  # fmt: skip
    except NothingToCheck as exc:
        print(f"{PROG}: check not run: {exc}", file=sys.stderr)
        return 1
    except CheckInterrupted as exc:
        print(f"{PROG}: stopped: {exc}", file=sys.stderr)
        return interrupts.exit_status()
    except (CameraError, ServoError, CollisionError, StartCalibrationFailed) as exc:
        print(f"{PROG}: check stopped: {exc}", file=sys.stderr)
        return 1
    print("\n".join(report_lines(check)))
    if not check.complete:
        # a check that did not finish refines nothing: the pose file stays as it was
        failed = sum(1 for p in check.points if p.seen_cm is None)
        why = check.failure or f"{failed} of {len(check.points)} points failed"
        kept = f"; {args.refine} not written" if args.refine is not None else ""
        print(f"{PROG}: check incomplete: {why}{kept}", file=sys.stderr)
        return 1
    if check.refined is not None:
        assert checked is not None
        write_refined(args.refine, check, checked, force=args.force)
        print(f"wrote {args.refine}")
    return 0


if __name__ == "__main__":
    run(main, sys.argv[1:])
