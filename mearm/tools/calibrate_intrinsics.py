"""Fit the camera's intrinsics (camera matrix, lens distortion) from ChArUco board views.

From saved images (files, or a folder: its *.png / *.jpg in name order)::

    mearm calibrate-intrinsics --images views/ --out calib/webcam_intrinsics.yaml

or live from a camera, keeping a frame every ``--interval-s`` in which the board shows
enough corners, until ``--frames`` are kept (move the board between frames: near each
corner of the view, tilted up to ~40° in different directions, 20–50 cm away)::

    mearm calibrate-intrinsics --device 0 --frames 20 --interval-s 1.0 --out intr.yaml

It prints the RMS error, each view's error, the camera matrix and distortion, and writes
the versioned calibration file (:func:`mearm.vision.pinhole.save_calibration`): an
existing file holding a better calibration of the same camera is kept unless
``--force`` (the replaced file is kept as ``<name>.bak``). Each file written is named on
stdout: ``wrote <name>.bak (the old <name>)``, then ``wrote <name>``. ``--dry-run`` writes
nothing.
Print the board with ``mearm charuco-board``.

With explicit image files every image must show the board; in a folder, images without
it are skipped with a note. ``--out`` may not name one of the images read, even
with ``--force``. Bad input of any kind is exit 2 with one line.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from mearm.cli import (
    PLAIN_INTEGER,
    ArgumentParser,
    backup_written,
    check_output_file,
    check_plain_number,
    positive_number,
    refuse_own_inputs,
    refuse_picture_name,
    run,
)
from mearm.config import CameraConfig
from mearm.config.errors import CalibrationError
from mearm.config.sections import MAX_DEVICE_INDEX
from mearm.errors import MearmError
from mearm.vision.camera import DeviceCamera
from mearm.vision.charuco import (
    DEFAULT_BOARD,
    MIN_CORNERS,
    MIN_VIEWS,
    BoardView,
    CalibrationReport,
    detect_board,
    fit_views,
    same_size,
)
from mearm.vision.image import read_image
from mearm.vision.pinhole import save_calibration

#: Image files a folder contributes (name order).
FOLDER_SUFFIXES = (".png", ".jpg", ".jpeg")
#: Most live frames to keep [-].
MAX_FRAMES = 500
#: Longest wait between live frames [s].
MAX_INTERVAL_S = 60.0
#: Live capture gives up after this many frames per frame wanted without the board.
ATTEMPTS_PER_FRAME = 10


def _device(text: str) -> int | str:
    if text.isascii() and text.isdigit() and len(text) <= 3:
        index = int(text)
        if index <= MAX_DEVICE_INDEX:
            return index
    if text.startswith("/dev/"):
        return text
    raise argparse.ArgumentTypeError(
        f"--device must be a camera index 0 … {MAX_DEVICE_INDEX} or a /dev/ path, got {text[:40]!r}"
    )


def _frames(text: str) -> int:
    check_plain_number(text, f"--frames must be a plain integer ({PLAIN_INTEGER})")
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not MIN_VIEWS <= value <= MAX_FRAMES:
        raise argparse.ArgumentTypeError(
            f"--frames must be an integer in [{MIN_VIEWS}, {MAX_FRAMES}] (a calibration "
            f"needs at least {MIN_VIEWS} views), got {text[:40]!r}"
        )
    return value


def image_files(paths: Sequence[Path]) -> list[tuple[Path, bool]]:
    """The image files to read, each with whether it must show the board.

    A folder contributes its *.png / *.jpg / *.jpeg in name order (these may lack the
    board); a file is taken as given (it must show the board).

    Raises:
        MearmError: a path does not exist, or a folder holds no images.
    """
    out: list[tuple[Path, bool]] = []
    for p in paths:
        if p.is_dir():
            found = sorted(
                q for q in p.iterdir() if q.suffix.lower() in FOLDER_SUFFIXES and q.is_file()
            )
            if not found:
                raise MearmError(f"--images {p}: the folder holds no *.png, *.jpg or *.jpeg images")
            out += [(q, False) for q in found]
        elif p.exists():
            out.append((p, True))
        else:
            raise MearmError(f"--images {p}: no such file or folder")
    return out


def views_from_images(paths: Sequence[Path]) -> tuple[list[BoardView], tuple[int, int]]:
    """The board's corners in each image, and the images' size (width, height) [px].

    Raises:
        ImageError: an image cannot be read.
        CalibrationError: an image of another size than the first, or a file given by
            name that does not show the board with enough corners.
    """
    views: list[BoardView] = []
    size: tuple[int, int] | None = None
    first = ""
    for path, required in image_files(paths):
        frame = read_image(path)
        h, w = frame.shape[:2]
        first = first or str(path)
        size = same_size(str(path), (w, h), size, first)
        corners, ids = detect_board(frame, DEFAULT_BOARD)
        if len(ids) < MIN_CORNERS:
            what = f"only {len(ids)} board corners" if len(ids) else "no ChArUco board"
            if required:
                raise CalibrationError(
                    f"{path}: {what} found, at least {MIN_CORNERS} are needed: show the whole "
                    "board (mearm charuco-board), sharp and evenly lit"
                )
            print(f"note: {path}: {what} found, skipped")
        views.append(BoardView(str(path), corners, ids))
    assert size is not None
    return views, size


def views_from_device(
    device: int | str, frames: int, interval_s: float
) -> tuple[list[BoardView], tuple[int, int]]:
    """Capture frames until ``frames`` show the board with enough corners.

    Raises:
        CameraError: the camera cannot be opened or stops delivering frames.
    """
    config = CameraConfig(
        kind="device",
        device_index=device if isinstance(device, int) else 0,
        path=device if isinstance(device, str) else None,
    )
    views: list[BoardView] = []
    with DeviceCamera(config) as camera:
        for attempt in range(frames * ATTEMPTS_PER_FRAME):
            frame = camera.read()
            corners, ids = detect_board(frame, DEFAULT_BOARD)
            if len(ids) >= MIN_CORNERS:
                views.append(BoardView(f"frame {attempt}", corners, ids))
                print(f"kept {len(views)}/{frames}: {len(ids)} corners", file=sys.stderr)
                if len(views) == frames:
                    break
            else:
                print(f"frame {attempt}: {len(ids)} corners, not kept", file=sys.stderr)
            time.sleep(interval_s)
        size = camera.size_px
    return views, size


def main(argv: Sequence[str] | None = None) -> int:
    """Fit the intrinsics and write them; 0 on success, 1 if it fails, 2 on bad input."""
    parser = ArgumentParser(
        description="Fit camera matrix and lens distortion from ChArUco board views.",
    )
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--images", type=Path, nargs="+", help="image files or folders")
    source.add_argument("--device", type=_device, help="camera index or /dev/ path (live)")
    parser.add_argument("--frames", type=_frames, default=20, help="live views to keep (20)")
    parser.add_argument(
        "--interval-s", type=positive_number(0.001, MAX_INTERVAL_S, "s"), default=1.0,
        help="wait between live frames [s] (1.0)",
    )  # fmt: skip
    parser.add_argument("--out", type=Path, required=True, help="intrinsics file to write")
    parser.add_argument("--camera-id", help="camera id to record (default: device or 'images')")
    parser.add_argument("--force", action="store_true", help="replace even a better file")
    parser.add_argument("--dry-run", action="store_true", help="fit and print; write nothing")
    args = parser.parse_args(argv)
    if not args.dry_run:
        check_output_file(args.out, "--out")  # before the views are read and fitted
        if args.images:
            # an image the fit reads is no place for its YAML, even with --force
            refuse_own_inputs(
                [("--out", args.out)],
                [("--images", path) for path, _ in image_files(args.images)],
            )
        refuse_picture_name(args.out, "--out")
    if args.camera_id is not None and not (0 < len(args.camera_id) <= 200):
        parser.error("--camera-id must be 1 … 200 characters")

    if args.images:
        views, size = views_from_images(args.images)
        camera_id = args.camera_id or "images"
    else:
        views, size = views_from_device(args.device, args.frames, args.interval_s)
        camera_id = args.camera_id or str(args.device)
    report: CalibrationReport = fit_views(views, size, DEFAULT_BOARD, camera_id)
    print("\n".join(report.lines()))
    if args.dry_run:
        print(f"dry run: {args.out} not written")
        return 0
    try:
        save_calibration(
            args.out, report.intrinsics, force=args.force,
            on_backup=lambda backup: print(backup_written(args.out, backup)),
        )  # fmt: skip
    except OSError as exc:
        raise MearmError(f"cannot write {args.out}: {exc.strerror or exc}") from None
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    run(main)
