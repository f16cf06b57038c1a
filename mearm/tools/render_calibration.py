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

One line on standard output names every file written (the board views by their number
and the first one's path).

A folder that is not empty is refused unless ``--force``, which replaces the files of the
kinds named above (an earlier run's; other files are kept), so no view or truth file of
another camera stays beside the new ones. The new files are written into a hidden folder
inside OUT first and put in place of the earlier run's only once all are written, so a
Ctrl-C, SIGTERM, SIGHUP or a failure at any moment leaves the earlier run or the new one,
whole (a SIGKILL can leave the hidden folder behind: the next run removes it).
"""

from __future__ import annotations

import argparse
import re
import shutil
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
from mearm.fileio import (
    is_staging,
    remove_staging_leftovers,
    replace_earlier_run,
    staging_folder,
    write_atomic,
)
from mearm.interrupts import signals_deferred, stop_signals_as_ctrl_c

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


#: The names this command writes: an earlier run's are replaced by a new one's (--force),
#: so no view, truth file or raised view of another camera stays beside the new ones.
_OWN_NAMES = re.compile(
    r"board_\d+\.png|sheet\.png|sheet_markers\.txt|raised\.png|raised_markers\.txt"
    r"|truth_(intrinsics|pose)\.yaml(\.bak(\.\d+)?)?"
)
#: The hidden folder inside --out that a run writes its files into before they replace the
#: earlier run's (:func:`~mearm.fileio.replace_earlier_run`); one a SIGKILL or a power cut
#: left behind is removed by the next run.
_COMMAND = "render_calibration"


def _is_own(path: Path) -> bool:
    """Whether ``path`` is a file of the kinds this command writes (an earlier run's)."""
    return bool(_OWN_NAMES.fullmatch(path.name)) and (path.is_file() or path.is_symlink())


def _is_staging(path: Path) -> bool:
    return is_staging(path, _COMMAND)


def _replace_earlier_run(staging: Path, out: Path, names: list[str]) -> None:
    """:func:`~mearm.fileio.replace_earlier_run`, a failure said as the command's error."""
    try:
        replace_earlier_run(staging, out, names, _is_own)
    except OSError as exc:
        name = Path(exc.filename2 or exc.filename or "?").name  # the same in out and aside
        raise MearmError(
            f"cannot replace {name} in --out {out}: {exc.strerror or exc}; the earlier "
            "run's files are kept as they were"
        ) from None


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
        help="write into a folder that is not empty, replacing the files of an earlier run",
    )
    args = parser.parse_args(argv)
    if args.out.exists() and not args.out.is_dir():
        parser.error(f"--out {args.out}: exists and is not a directory")
    if args.out.is_dir() and not args.force and not all(map(_is_staging, args.out.iterdir())):
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
        with signals_deferred():  # a Ctrl-C between the two does not leave the probe there
            probe.write_bytes(b"")
            probe.unlink()
    except OSError as exc:
        raise MearmError(f"cannot write into --out {args.out}: {exc.strerror or exc}") from None

    from mearm.sim.twin.calibration_scenes import (
        SHEET_SIDE_CM,
        default_sheet_layout,
        raised_sheet_layout,
    )

    layout = default_sheet_layout(config)
    raised = None
    if args.raised_height_cm is not None:  # refused (exit 2) before anything is rendered
        raised = raised_sheet_layout(config, args.raised_height_cm)
    with stop_signals_as_ctrl_c():  # a SIGTERM or SIGHUP, too, removes the hidden folder
        remove_staging_leftovers(args.out, _COMMAND)
        staging = staging_folder(args.out, _COMMAND)
        try:
            names = _write_run(staging, config, args, layout, raised)
            # (inside the try: a Ctrl-C between the writing and the renames, which take
            # signals only after their last, removes the folder too)
            _replace_earlier_run(staging, args.out, names)
        except BaseException:
            with signals_deferred():  # a second Ctrl-C does not leave the folder behind
                shutil.rmtree(staging, ignore_errors=True)
            raise
    print(
        f"wrote {args.views} board views ({args.out / 'board_00.png'} …), "
        f"{args.out / 'sheet.png'} ({len(layout)} markers of {SHEET_SIDE_CM:g} cm) "
        f"and {args.out / 'sheet_markers.txt'}"
        + (
            f"; markers on a box {args.raised_height_cm:g} cm tall in {args.out / 'raised.png'} "
            f"and {args.out / 'raised_markers.txt'}"
            if raised is not None
            else ""
        )
        + (
            f"; the twin's own camera in {args.out / names[-2]} and {args.out / names[-1]}"
            if args.truth
            else ""
        )
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


def _write_run(
    staging: Path,
    config: Config,
    args: argparse.Namespace,
    layout: dict[int, tuple[float, float]],
    raised: tuple[dict[int, tuple[float, float]], Support] | None,
) -> list[str]:
    """Render the run and write all its files into the new folder ``staging``.

    Returns:
        The names written, in the order the summary line names them.
    """
    from mearm.sim.twin.calibration_scenes import (
        SHEET_SIDE_CM,
        render_board_views,
        render_sheet,
    )

    try:
        staging.mkdir()
    except OSError as exc:
        raise MearmError(f"cannot write into --out {args.out}: {exc.strerror or exc}") from None
    sheet = render_sheet(config, layout, SHEET_SIDE_CM, noise_std=args.noise_std, seed=args.seed)
    frames = render_board_views(config, args.views, args.seed, noise_std=args.noise_std)
    names = [f"board_{i:02d}.png" for i in range(len(frames))]
    for name, frame in zip(names, frames, strict=True):
        _write_png(staging / name, frame)
    _write_png(staging / "sheet.png", sheet)
    lines = [f"--marker {i}:{x:g},{y:g}" for i, (x, y) in layout.items()]
    lines.append(f"--marker-side-cm {SHEET_SIDE_CM:g}")
    _write_arguments(staging / "sheet_markers.txt", lines)
    names += ["sheet.png", "sheet_markers.txt"]
    if raised is not None:
        names += _write_raised(config, args, staging, *raised)
    if args.truth:
        names += _write_truth(config, staging)
    return names


def _write_raised(
    config: Config,
    args: argparse.Namespace,
    folder: Path,
    layout: dict[int, tuple[float, float]],
    support: Support,
) -> list[str]:
    """The raised view and its arguments: markers on a box ``--raised-height-cm`` tall.

    Returns:
        The names written into ``folder``.
    """
    from mearm.sim.twin.calibration_scenes import SHEET_SIDE_CM, render_sheet

    h = args.raised_height_cm
    frame = render_sheet(
        config, layout, SHEET_SIDE_CM, noise_std=args.noise_std, seed=args.seed, support=support
    )
    _write_png(folder / "raised.png", frame)
    lines = [f"--raised-marker {i}:{x:g},{y:g}" for i, (x, y) in layout.items()]
    lines.append(f"--raised-height-cm {h:g}")
    _write_arguments(folder / "raised_markers.txt", lines)
    return ["raised.png", "raised_markers.txt"]


def _write_arguments(path: Path, lines: list[str]) -> None:
    """Write ``calibrate-camera``'s arguments for a picture, one a line."""
    try:
        write_atomic(path, "\n".join(lines) + "\n")
    except OSError as exc:
        raise MearmError(f"cannot write {path}: {exc.strerror or exc}") from None


def _write_truth(config: Config, folder: Path) -> list[str]:
    """The twin's camera as calibration files: intrinsics and pose, each with rms 0.

    Returns:
        The names written into ``folder``.
    """
    from mearm.sim.twin.twin_optics import twin_camera_model
    from mearm.vision.calibration_file import Extrinsics, Intrinsics, save_calibration

    truth = twin_camera_model(config)
    size = (config.camera.width_px, config.camera.height_px)
    files = (
        ("truth_intrinsics.yaml", Intrinsics(truth.K, truth.dist, size, 0.0, 0, "twin")),
        (
            "truth_pose.yaml",
            Extrinsics(truth.R_base_cam, truth.camera_centre_cm, 0.0, 0, "twin", size),
        ),
    )
    for name, cal in files:
        try:
            save_calibration(folder / name, cal, force=True)
        except OSError as exc:
            raise MearmError(f"cannot write {folder / name}: {exc.strerror or exc}") from None
    return [name for name, _ in files]


if __name__ == "__main__":
    run(main)
