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

With ``--refine OUT`` (a perspective calibration only) it fits the rotation about the
vertical and the shift on the table that best map the seen points onto the commanded
ones, moves the camera's pose by them and writes it to OUT (marked ``refined_by_arm``;
an existing file holding a better calibration is kept unless ``--force``), and prints
the residuals the refined pose gives on the same frames.

Exit 0: the check ran and printed its figures; 1: it could not complete (no object seen,
no room for as many points as asked, a point that failed, a camera or servo fault during
the check: one line on stderr says which, and OUT is not written); 2: bad input, one line
on stderr (OUT is checked before the arm moves), a camera that cannot be opened included
(as ``mearm sort`` and ``mearm detect`` say it).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mearm.cli import (
    PLAIN_INTEGER,
    ArgumentParser,
    add_config_argument,
    check_output_file,
    check_plain_number,
    config_from_args,
    refuse_own_inputs,
    run,
)
from mearm.config import Config
from mearm.config.files import resolve_config_path
from mearm.errors import MearmError
from mearm.hardware.errors import ServoError
from mearm.task.armcheck import (
    MAX_POINTS,
    MIN_POINTS,
    ArmCheck,
    NothingToCheck,
    max_cm,
    rms_cm,
    run_check,
)
from mearm.vision.calibration import camera_geometry
from mearm.vision.errors import CameraError
from mearm.vision.pinhole import PerspectiveCamera, save_calibration


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
    """The check's figures, one line each: every point, then the RMS and the largest."""
    lines = [f"object: {check.class_name}, lay at {_xy(check.start_cm)} cm"]
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
    return lines


#: How the command names itself on stderr.
PROG = "mearm check-camera"


def _intrinsics_file(config: Config) -> Path | None:
    """The intrinsics file a perspective calibration reads, else ``None``."""
    name = config.calibration.intrinsics_file
    return Path(name) if name else None


def _check_camera_opens(config: Config) -> None:
    """Open the config's camera once and close it, before the arm moves.

    A camera that is not there is bad input (exit 2), as for ``mearm sort`` and ``mearm
    detect``; inside the check a camera fault stops it (exit 1). The simulated camera
    (``camera.kind: sim``) is always there: it is opened with the rig's table.

    Raises:
        CameraError: it cannot be opened, and why.
    """
    if config.camera.kind == "sim":
        return
    from mearm.backends import open_camera  # noqa: PLC0415  (a real camera only)

    with open_camera(config):
        pass


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
        check_output_file(args.refine, "--refine")
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
    if args.refine is not None and not isinstance(
        camera_geometry(config.calibration, config.camera), PerspectiveCamera
    ):
        parser.error(
            "--refine needs a perspective calibration (calibration.model: perspective with "
            "intrinsics_file and extrinsics_file); this config has the homography"
        )

    _check_camera_opens(config)
    try:
        check = run_check(
            config, points=args.points, class_name=args.class_name,
            refine=args.refine is not None, echo=None,
        )  # fmt: skip
    except NothingToCheck as exc:
        print(f"{PROG}: check not run: {exc}", file=sys.stderr)
        return 1
    except (CameraError, ServoError) as exc:
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
        try:
            save_calibration(args.refine, check.refined, force=args.force)
        except OSError as exc:
            raise MearmError(f"cannot write {args.refine}: {exc.strerror or exc}") from None
        print(f"wrote {args.refine}")
    return 0


if __name__ == "__main__":
    run(main, sys.argv[1:])
