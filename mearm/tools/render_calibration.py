r"""Render calibration pictures from the physical twin's camera: ChArUco views and a marker sheet.

    mearm render-calibration --config configs/sim_mujoco_perspective.yaml \\
        --out calib/ [--views 15] [--seed 0] [--noise-std 0]

Writes ``OUT/board_00.png`` … (the default ChArUco board, 7 × 5 squares of 3 cm,
DICT_5X5_100, held at ``--views`` seeded poses), ``OUT/sheet.png`` (4 cm DICT_4X4_50
markers lying on the empty table, :func:`~mearm.sim.twin.calibration_scenes.default_sheet_layout`)
and ``OUT/sheet_markers.txt`` (the ``--marker ID:X,Y`` arguments and ``--marker-side-cm``
for the calibration tool). The frames go through the twin camera's lens
(``twin.camera``; unset, the default straight-down camera).

``--raised-height-cm H`` also writes ``OUT/raised.png``: six of the markers lying on a
box H cm tall standing on the table
(:func:`~mearm.sim.twin.calibration_scenes.raised_sheet_layout`), and
``OUT/raised_markers.txt`` (their ``--raised-marker ID:X,Y`` arguments and
``--raised-height-cm``), for a pose fitted at two heights.

``--truth`` also writes ``OUT/truth_intrinsics.yaml`` and ``OUT/truth_pose.yaml``: the
twin's own camera, as a perfect calibration would find it. A config pointed at them
(``calibration.intrinsics_file``, ``calibration.extrinsics_file``) tells what the camera's
calibration costs a measurement from what the rest costs.

A folder that is not empty is refused unless ``--force``, which first removes the files
of the kinds named above (an earlier run's; other files are kept), so no view or truth
file of another camera stays beside the new ones.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from mearm.cli import (
    PLAIN_DECIMAL,
    PLAIN_INTEGER,
    ArgumentParser,
    add_config_argument,
    check_plain_number,
    config_from_args,
    run,
    seed_value,
)
from mearm.config import Config
from mearm.errors import MearmError
from mearm.fileio import write_atomic

if TYPE_CHECKING:
    from mearm.sim.twin.calibration_scenes import Support

#: Most board views one run renders.
MAX_VIEWS = 200


def _views(text: str) -> int:
    import argparse

    check_plain_number(text, f"--views is a plain integer ({PLAIN_INTEGER})")
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--views is an integer, got {text[:40]!r}") from None
    if not 1 <= value <= MAX_VIEWS:
        raise argparse.ArgumentTypeError(f"--views must be in [1, {MAX_VIEWS}], got {value}")
    return value


def _noise(text: str) -> float:
    import argparse

    check_plain_number(text, f"--noise-std must be a plain decimal number ({PLAIN_DECIMAL})")
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 <= value <= 255:
        raise argparse.ArgumentTypeError(
            f"--noise-std must be a number in [0, 255] (8-bit levels), got {text[:40]!r}"
        )
    return value


def _write_png(path: Path, image: np.ndarray) -> None:
    ok, buf = cv2.imencode(".png", image)
    if not ok:
        raise MearmError(f"PNG encoding of {path.name} failed")
    try:
        write_atomic(path, buf.tobytes())
    except OSError as exc:
        raise MearmError(f"cannot write {path}: {exc.strerror or exc}") from None


#: The names this command writes: an earlier run's are removed before a new one (--force),
#: so no view, truth file or raised view of another camera stays beside the new ones.
_OWN_NAMES = re.compile(
    r"board_\d+\.png|sheet\.png|sheet_markers\.txt|raised\.png|raised_markers\.txt"
    r"|truth_(intrinsics|pose)\.yaml(\.bak)?"
)


def _remove_earlier_run(out: Path) -> None:
    """Remove the files of the kinds this command writes from ``out`` (others are kept)."""
    for path in sorted(out.iterdir()):
        if _OWN_NAMES.fullmatch(path.name) and (path.is_file() or path.is_symlink()):
            try:
                path.unlink()
            except OSError as exc:
                raise MearmError(f"cannot remove {path}: {exc.strerror or exc}") from None


def main(argv: Sequence[str] | None = None) -> int:
    """Render the views and the sheet; 0 on success, 2 on bad input."""
    parser = ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    add_config_argument(parser)
    parser.add_argument("--out", type=Path, required=True, help="directory to write into")
    parser.add_argument("--views", type=_views, default=15, help="ChArUco board views (15)")
    parser.add_argument("--seed", type=seed_value, default=0, help="seed of poses and noise (0)")
    parser.add_argument(
        "--noise-std", type=_noise, default=0.0, help="Gaussian noise, 8-bit levels (0)"
    )
    parser.add_argument(
        "--raised-height-cm", type=_height, default=None,
        help="also render markers on a box this tall [cm]: raised.png, raised_markers.txt",
    )  # fmt: skip
    parser.add_argument(
        "--truth",
        action="store_true",
        help="also write the twin's own camera as truth_intrinsics.yaml and truth_pose.yaml",
    )
    parser.add_argument(
        "--force",
        action="store_true",
        help="write into a folder that is not empty, removing the files of an earlier run",
    )
    args = parser.parse_args(argv)
    if args.out.exists() and not args.out.is_dir():
        parser.error(f"--out {args.out}: exists and is not a directory")
    if args.out.is_dir() and not args.force and any(args.out.iterdir()):
        parser.error(
            f"--out {args.out}: the folder is not empty; give a new folder, or pass --force "
            "to replace an earlier run's files there"
        )
    config = config_from_args(args)
    if config.simulator != "mujoco":
        raise MearmError(
            f"{args.config or 'the default config'}: simulator is {config.simulator!r}; the "
            "calibration pictures are the MuJoCo twin's (simulator: mujoco)"
        )
    try:
        args.out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MearmError(f"cannot make --out {args.out}: {exc.strerror or exc}") from None
    probe = args.out / ".render_calibration_probe"
    try:
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise MearmError(f"cannot write into --out {args.out}: {exc.strerror or exc}") from None

    from mearm.sim.twin.calibration_scenes import (
        SHEET_SIDE_CM,
        default_sheet_layout,
        raised_sheet_layout,
        render_board_views,
        render_sheet,
    )

    layout = default_sheet_layout(config)
    raised = None
    if args.raised_height_cm is not None:  # refused (exit 2) before anything is rendered
        raised = raised_sheet_layout(config, args.raised_height_cm)
    sheet = render_sheet(config, layout, SHEET_SIDE_CM, noise_std=args.noise_std, seed=args.seed)
    frames = render_board_views(config, args.views, args.seed, noise_std=args.noise_std)
    _remove_earlier_run(args.out)
    written = []
    for i, frame in enumerate(frames):
        path = args.out / f"board_{i:02d}.png"
        _write_png(path, frame)
        written.append(path)
    _write_png(args.out / "sheet.png", sheet)
    written.append(args.out / "sheet.png")
    lines = [f"--marker {i}:{x:g},{y:g}" for i, (x, y) in layout.items()]
    lines.append(f"--marker-side-cm {SHEET_SIDE_CM:g}")
    markers_txt = _write_arguments(args.out / "sheet_markers.txt", lines)
    written.append(markers_txt)
    if raised is not None:
        written += _write_raised(config, args, *raised)
    if args.truth:
        written += _write_truth(config, args.out)
    print(
        f"wrote {len(frames)} board views ({args.out / 'board_00.png'} …), "
        f"{args.out / 'sheet.png'} ({len(layout)} markers of {SHEET_SIDE_CM:g} cm) "
        f"and {markers_txt}"
        + (
            f"; markers on a box {args.raised_height_cm:g} cm tall in {args.out / 'raised.png'}"
            if raised is not None
            else ""
        )
        + (f"; the twin's own camera in {written[-2]} and {written[-1]}" if args.truth else "")
    )
    return 0


def _height(text: str) -> float:
    import argparse
    import math

    from mearm.sim.twin.calibration_scenes import MAX_SUPPORT_CM

    check_plain_number(text, f"--raised-height-cm must be a plain decimal number ({PLAIN_DECIMAL})")
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (math.isfinite(value) and 0 < value <= MAX_SUPPORT_CM):
        raise argparse.ArgumentTypeError(
            f"--raised-height-cm must be a number in (0, {MAX_SUPPORT_CM:g}] cm, got {text[:40]!r}"
        )
    return value


def _write_raised(
    config: Config,
    args: argparse.Namespace,
    layout: dict[int, tuple[float, float]],
    support: Support,
) -> list[Path]:
    """The raised view and its arguments: markers on a box ``--raised-height-cm`` tall."""
    from mearm.sim.twin.calibration_scenes import SHEET_SIDE_CM, render_sheet

    h = args.raised_height_cm
    frame = render_sheet(
        config, layout, SHEET_SIDE_CM, noise_std=args.noise_std, seed=args.seed, support=support
    )
    image = args.out / "raised.png"
    _write_png(image, frame)
    lines = [f"--raised-marker {i}:{x:g},{y:g}" for i, (x, y) in layout.items()]
    lines.append(f"--raised-height-cm {h:g}")
    return [image, _write_arguments(args.out / "raised_markers.txt", lines)]


def _write_arguments(path: Path, lines: list[str]) -> Path:
    """Write ``calibrate-camera``'s arguments for a picture, one a line; returns ``path``."""
    try:
        write_atomic(path, "\n".join(lines) + "\n")
    except OSError as exc:
        raise MearmError(f"cannot write {path}: {exc.strerror or exc}") from None
    return path


def _write_truth(config: Config, out: Path) -> list[Path]:
    """The twin's camera as calibration files: intrinsics and pose, each with rms 0."""
    from mearm.sim.twin.twin_optics import twin_camera_model
    from mearm.vision.calibration_file import Extrinsics, Intrinsics, save_calibration

    truth = twin_camera_model(config)
    size = (config.camera.width_px, config.camera.height_px)
    files = (
        (out / "truth_intrinsics.yaml", Intrinsics(truth.K, truth.dist, size, 0.0, 0, "twin")),
        (
            out / "truth_pose.yaml",
            Extrinsics(truth.R_base_cam, truth.camera_centre_cm, 0.0, 0, "twin", size),
        ),
    )
    written = []
    for path, cal in files:
        try:
            written.append(save_calibration(path, cal, force=True))
        except OSError as exc:
            raise MearmError(f"cannot write {path}: {exc.strerror or exc}") from None
    return written


if __name__ == "__main__":
    run(main)
