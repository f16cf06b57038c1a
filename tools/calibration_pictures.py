r"""Regenerate the pictures of the camera calibration walkthrough (docs/calibration.md).

    python tools/calibration_pictures.py [--config configs/sim_mujoco_perspective.yaml] \\
        [--out docs/images]

Everything is the physical twin's (simulated; ``mearm.sim.twin.calibration_scenes``), seeded,
with the twin's sensor noise of 2 levels:

- ``calibration_board.png``: the printed ChArUco page (``mearm charuco-board``), downscaled;
- ``calibration_board_views.png``: six board views with the corners the detector found;
- ``calibration_sheet.png``: the markers on the table with the detected outlines and ids;
- ``calibration_objects.png``: the paper's scene with 2.5 cm tall objects, seen by the
  tilted camera and annotated by ``mearm detect``'s annotation with the perspective model;
- ``calibration_parallax.png``: a close-up of one object: where the paper's centroid +
  homography puts it, where the top-face fit puts it, and the truth.

The calibrations these pictures use are fitted here the way the tools fit them (same
board views and marker sheet as ``mearm render-calibration --noise-std 2``). Each PNG is
downscaled or palette-quantised to stay under 150 KB. Prints each file and its size.

The five PNGs in the output folder are replaced without asking (no ``--force``, as
``tools/screenshots.py``): this developer tool redraws the pictures committed under
``docs/images/`` (CONTRIBUTING.md: never by hand), and git keeps the ones it replaces;
give ``--out`` another folder to keep a folder's PNGs as they are. The run writes all five
into a hidden folder in ``--out`` first (``.calibration_pictures.<pid>.tmp``), then renames
them over the earlier run's (:func:`mearm.fileio.replace_earlier_run`): a failure, Ctrl-C
or SIGTERM leaves the earlier run's pictures, all five as they were, never a mix of two
runs. A hidden folder a SIGKILL left behind is removed by the next run.
"""

from __future__ import annotations

import io
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import cv2  # noqa: E402
import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

from mearm.cli import ArgumentParser, check_output_folder, run  # noqa: E402
from mearm.config import Config, load_config  # noqa: E402
from mearm.errors import MearmError  # noqa: E402
from mearm.fileio import (  # noqa: E402
    remove_staging_leftovers,
    replace_earlier_run,
    staging_folder,
    write_atomic,
)
from mearm.interrupts import signals_deferred, stop_signals_as_ctrl_c  # noqa: E402

#: Noise of the rendered frames [8-bit levels] (as ``render-calibration --noise-std 2``).
NOISE = 2.0
#: Board views rendered (as ``render-calibration``'s default) and those shown.
VIEWS, SHOWN = 15, (0, 4, 6, 9, 13, 11)
#: Object height of the object scene [cm].
OBJECT_HEIGHT_CM = 2.5
#: Largest PNG written [bytes].
MAX_BYTES = 150_000
#: The pictures a run writes, all or none (an earlier run's are replaced as a whole).
NAMES = (
    "calibration_board.png",
    "calibration_board_views.png",
    "calibration_sheet.png",
    "calibration_objects.png",
    "calibration_parallax.png",
)
#: Names the hidden folder in --out a run writes into first (:func:`mearm.fileio.staging_folder`).
_COMMAND = "calibration_pictures"


def _save(path: Path, bgr: np.ndarray, colors: int = 0) -> None:
    """Write ``bgr`` (or grey) as PNG; ``colors`` > 0: palette-quantised to that many."""
    if bgr.ndim == 2:
        img = Image.fromarray(bgr, "L")
    else:
        img = Image.fromarray(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), "RGB")
        if colors:
            img = img.quantize(colors=colors, method=Image.Quantize.MEDIANCUT, dither=0)
    buf = io.BytesIO()
    img.save(buf, format="PNG", optimize=True)
    data = buf.getvalue()
    if len(data) > MAX_BYTES:
        raise MearmError(f"{path.name}: {len(data)} bytes, more than {MAX_BYTES}")
    write_atomic(path, data)


def _text(img: np.ndarray, text: str, org: tuple[int, int], scale: float = 0.5) -> None:
    """White text with a dark outline (readable on any background)."""
    for colour, thick in (((0, 0, 0), 3), ((255, 255, 255), 1)):
        cv2.putText(img, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, colour, thick, cv2.LINE_AA)


def board_page_picture(out: Path) -> None:
    from mearm.vision.charuco import DEFAULT_BOARD

    page = _tool("charuco_board").board_page(DEFAULT_BOARD, 300)
    small = cv2.resize(page, (877, 620), interpolation=cv2.INTER_AREA)
    _save(out / "calibration_board.png", small)


def _tool(name: str):  # noqa: ANN202
    """The command module ``mearm.tools.<name>``."""
    import importlib

    return importlib.import_module(f"mearm.tools.{name}")


def board_views(config: Config, out: Path):  # noqa: ANN201
    """Render the views, draw the found corners on six, fit the intrinsics; return them."""
    from mearm.sim.twin.calibration_scenes import render_board_views
    from mearm.vision.charuco import DEFAULT_BOARD, MIN_CORNERS, BoardView, detect_board, fit_views

    frames = render_board_views(config, VIEWS, 0, noise_std=NOISE)
    views, tiles = [], {}
    for i, frame in enumerate(frames):
        corners, ids = detect_board(frame, DEFAULT_BOARD)
        views.append(BoardView(f"board_{i:02d}.png", corners, ids))
        if i in SHOWN:
            tile = cv2.resize(frame, (320, 240), interpolation=cv2.INTER_AREA)
            ok = len(ids) >= MIN_CORNERS
            colour = (0, 220, 0) if ok else (0, 0, 255)
            for u, v in corners / 2:
                cv2.circle(tile, (round(u), round(v)), 4, colour, 2, cv2.LINE_AA)
            verdict = "used" if ok else f"skipped (< {MIN_CORNERS})"
            cv2.rectangle(tile, (0, 0), (319, 20), (40, 40, 40), cv2.FILLED)
            cv2.putText(
                tile,
                f"board_{i:02d}.png: {len(ids)} corners, {verdict}",
                (5, 15),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.45,
                (255, 255, 255),
                1,
                cv2.LINE_AA,
            )
            tiles[i] = tile
    grid = [tiles[i] for i in SHOWN]
    sheet = np.vstack([np.hstack(grid[:3]), np.hstack(grid[3:])])
    _save(out / "calibration_board_views.png", sheet, colors=24)
    w, h = config.camera.width_px, config.camera.height_px
    return fit_views(views, (w, h), DEFAULT_BOARD, "twin").intrinsics


def sheet_picture(config: Config, intrinsics, out: Path):  # noqa: ANN001, ANN201
    """Render the marker sheet, draw the markers found, fit the pose; return the camera."""
    from mearm.sim.twin.calibration_scenes import SHEET_SIDE_CM, default_sheet_layout, render_sheet
    from mearm.vision.aruco import detect_markers, diagonal_center, table_corners_cm
    from mearm.vision.pinhole import PerspectiveCamera, solve_pose

    layout = default_sheet_layout(config)
    frame = render_sheet(config, layout, SHEET_SIDE_CM, noise_std=NOISE, seed=0)
    found = detect_markers(frame)
    pixels, points = [], []
    for marker_id, centre in sorted(layout.items()):
        pixels.extend(found[marker_id])
        points.extend(table_corners_cm(centre, SHEET_SIDE_CM))
    pts3 = np.column_stack([np.array(points), np.zeros(len(points))])
    pose = solve_pose(intrinsics, np.array(pixels), pts3, markers=len(layout))
    pic = frame.copy()
    for marker_id, quad in sorted(found.items()):
        cv2.polylines(
            pic,
            [np.round(quad).astype(np.int32)],
            isClosed=True,
            color=(0, 200, 0),
            thickness=2,
            lineType=cv2.LINE_AA,
        )
        cv2.circle(pic, tuple(np.round(quad[0]).astype(int)), 4, (0, 0, 255), -1)  # TL corner
        u, v = diagonal_center(quad)
        x, y = layout[marker_id]
        _text(pic, f"id {marker_id}", (round(u) - 18, round(v) - 32), 0.5)
        _text(pic, f"({x:g}, {y:g})", (round(u) - 36, round(v) + 44), 0.45)
    _save(out / "calibration_sheet.png", pic, colors=32)
    return PerspectiveCamera(intrinsics, pose), layout


def objects_pictures(config: Config, camera, layout, out: Path) -> None:  # noqa: ANN001
    """The object scene, annotated; and the close-up of the worst paper error."""
    from mearm.detect import annotate, to_records
    from mearm.sim.twin.calibration_scenes import SHEET_SIDE_CM, render_objects, render_sheet
    from mearm.sim.twin.mjcf import object_ids
    from mearm.vision.aruco import calibration_from_markers
    from mearm.vision.detector import ColorDetector

    # as tools/camera_accuracy.py: the bins raised clear of the taller objects
    raise_cm = (len(config.task.scene) + 1) * OBJECT_HEIGHT_CM
    classes = [
        c.model_copy(
            update={
                "height_cm": OBJECT_HEIGHT_CM,
                "bin_cm": (*c.bin_cm[:2], c.bin_cm[2] + raise_cm),
            }
        )
        for c in config.task.classes
    ]
    cfg = config.model_copy(update={"task": config.task.model_copy(update={"classes": classes})})
    frame, truth = render_objects(cfg, noise_std=NOISE, seed=0)
    detector = ColorDetector(cfg.vision, camera, classes)
    found = detector.detect(frame)
    records = to_records(found, frame.shape)
    _save(out / "calibration_objects.png", annotate(frame, detector, records, found), colors=48)

    # the paper's model on the same frame: centroid through a homography of the same markers
    sheet = render_sheet(config, layout, SHEET_SIDE_CM, noise_std=NOISE, seed=0)
    paper = ColorDetector(
        cfg.vision, calibration_from_markers(sheet, layout, side_cm=SHEET_SIDE_CM), classes
    )
    paper_found = paper.detect(frame)
    rows = []
    for oid, obj in zip(object_ids(cfg), cfg.task.scene, strict=True):
        t = truth[oid]
        near = min(
            (d for d in found if d.color == obj.color), key=lambda d: np.hypot(*(d.table_cm - t))
        )
        far = min(
            (d for d in paper_found if d.color == obj.color),
            key=lambda d: np.hypot(*(d.table_cm - t)),
        )
        rows.append((float(np.hypot(*(far.table_cm - t))), oid, t, near, far))
    paper_err, oid, t, det, pdet = max(rows, key=lambda r: r[0])
    top_err = float(np.hypot(*(det.table_cm - t)))
    print(f"close-up {oid}: paper model {paper_err:.3f} cm, top-face fit {top_err:.3f} cm off")
    _closeup(frame, camera, cfg.task.class_named(det.color), oid, t, det, pdet, out)


def _closeup(frame, camera, cls, oid, truth, det, pdet, out: Path) -> None:  # noqa: ANN001
    """Left: the frame around the object, ×6; right: the table plane around it [cm]."""
    zoom, half = 6, 22
    u, v = np.round(det.centroid_px).astype(int)
    crop = frame[v - half : v + half, u - half : u + half]
    big = cv2.resize(crop, None, fx=zoom, fy=zoom, interpolation=cv2.INTER_NEAREST)
    origin = np.array([u - half, v - half], float)

    def at(px: np.ndarray) -> tuple[int, int]:
        return tuple(np.round((px - origin + 0.5) * zoom - 0.5).astype(int))

    r, h = cls.diameter_cm / 2, cls.height_cm
    a = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    ring = np.column_stack([np.cos(a), np.sin(a)]) * r
    for centre, z, colour in (
        (truth, 0.0, (255, 255, 255)),  # true base
        (truth, h, (255, 255, 255)),  # true top
        (det.table_cm, h, (0, 220, 255)),  # fitted top
    ):
        px = camera.table_to_pixel(ring + centre, z)
        cv2.polylines(
            big,
            [np.array([at(p) for p in px], np.int32)],
            isClosed=True,
            color=colour,
            thickness=1,
            lineType=cv2.LINE_AA,
        )
    cv2.drawMarker(big, at(det.centroid_px), (0, 0, 255), cv2.MARKER_CROSS, 18, 2, cv2.LINE_AA)
    legend = np.full((64, big.shape[1], 3), 255, np.uint8)
    for k, (text, colour) in enumerate(
        (
            ("red +: the blob's centroid (what the paper maps)", (0, 0, 255)),
            ("white: true base and top rims, projected", (0, 0, 0)),
            ("yellow: top rim at the fitted centre", (0, 140, 210)),
        )
    ):
        cv2.putText(legend, text, (6, 16 + 19 * k), cv2.FONT_HERSHEY_SIMPLEX, 0.42, colour, 1,
                    cv2.LINE_AA)  # fmt: skip
    big = np.vstack([big, legend])

    # the table plane around the truth, the worst estimate in view
    side = big.shape[0]
    worst = max(np.hypot(*(pdet.table_cm - truth)), np.hypot(*(det.table_cm - truth)), 0.2)
    scale = 0.3 * side / worst  # px per cm
    plane = np.full((side, side, 3), 245, np.uint8)
    c0 = np.array([side / 2, side * 0.38])

    def cm(xy: np.ndarray) -> tuple[int, int]:
        d = (np.asarray(xy) - truth) * scale
        return tuple(np.round(c0 + [d[0], -d[1]]).astype(int))  # +y up

    for k in range(-40, 41):  # 0.1 cm grid
        g = round(c0[0] + k * 0.1 * scale)
        cv2.line(plane, (g, 0), (g, side), (225, 225, 225), 1)
        cv2.line(plane, (0, g), (side, g), (225, 225, 225), 1)
    cv2.circle(plane, cm(truth), 6, (0, 0, 0), -1, cv2.LINE_AA)
    cv2.drawMarker(plane, cm(pdet.table_cm), (0, 0, 255), cv2.MARKER_TILTED_CROSS, 16, 2)
    cv2.drawMarker(plane, cm(det.table_cm), (0, 160, 230), cv2.MARKER_DIAMOND, 16, 2)
    foot = camera.centre_cm[:2]
    d = (foot - truth) / np.linalg.norm(foot - truth)
    cv2.arrowedLine(
        plane,
        cm(truth + 0.5 * worst * d),
        cm(truth + 0.8 * worst * d),
        (120, 120, 120),
        2,
        tipLength=0.3,
    )
    pe, te = np.hypot(*(pdet.table_cm - truth)), np.hypot(*(det.table_cm - truth))
    lines = [
        (f"table plane around {oid} (grid 0.1 cm)", (0, 0, 0)),
        ("black dot: truth", (0, 0, 0)),
        (f"red x: centroid + homography, {pe:.2f} cm off", (0, 0, 255)),
        (f"yellow diamond: top-face fit, {te:.2f} cm off", (0, 140, 210)),
        ("grey arrow: towards the camera's foot", (90, 90, 90)),
        ("simulated (twin)", (90, 90, 90)),
    ]
    for k, (text, colour) in enumerate(lines):
        cv2.putText(
            plane,
            text,
            (8, side - 8 - 18 * (len(lines) - 1 - k)),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.45,
            colour,
            1,
            cv2.LINE_AA,
        )
    _save(out / "calibration_parallax.png", np.hstack([big, plane]), colors=48)


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(
        prog="python tools/calibration_pictures.py", description=__doc__.splitlines()[0]
    )
    parser.add_argument(
        "--config", type=Path, default=ROOT / "configs" / "sim_mujoco_perspective.yaml",
        help="the twin's config (configs/sim_mujoco_perspective.yaml)",
    )  # fmt: skip
    parser.add_argument(
        "--out",
        type=Path,
        default=ROOT / "docs" / "images",
        help="folder for the PNGs (default: docs/images); the five PNGs of an earlier run "
        "there are replaced, together, without a --force: the tool redraws the committed "
        "pictures, and git keeps the old ones",
    )
    args = parser.parse_args(argv)
    check_output_folder(args.out, "--out")  # a file there, or above it: exit 2, one line
    config = load_config(args.config)
    if config.simulator != "mujoco":
        raise MearmError(f"{args.config}: simulator is {config.simulator!r}; this needs the twin")
    try:
        args.out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MearmError(f"cannot make --out {args.out}: {exc.strerror or exc}") from None
    with stop_signals_as_ctrl_c():  # a SIGTERM or SIGHUP, too, removes the hidden folder
        remove_staging_leftovers(args.out, _COMMAND)
        staging = staging_folder(args.out, _COMMAND)
        try:
            staging.mkdir()
            board_page_picture(staging)
            intrinsics = board_views(config, staging)
            camera, layout = sheet_picture(config, intrinsics, staging)
            objects_pictures(config, camera, layout, staging)
            sizes = {name: (staging / name).stat().st_size for name in NAMES}
            _replace_earlier_run(staging, args.out)
        except BaseException:
            with signals_deferred():  # a second Ctrl-C does not leave the folder behind
                shutil.rmtree(staging, ignore_errors=True)
            raise
    for name in NAMES:
        print(f"wrote {args.out / name} ({sizes[name] // 1024} KB)")
    return 0


def _is_own(path: Path) -> bool:
    """Whether ``path`` is one of the pictures this tool writes (an earlier run's)."""
    return path.name in NAMES and (path.is_file() or path.is_symlink())


def _replace_earlier_run(staging: Path, out: Path) -> None:
    """:func:`~mearm.fileio.replace_earlier_run`, a failure said in one line (exit 1)."""
    try:
        replace_earlier_run(staging, out, list(NAMES), _is_own)
    except OSError as exc:
        name = Path(exc.filename2 or exc.filename or "?").name
        error = MearmError(
            f"cannot replace {name} in --out {out}: {exc.strerror or exc}; the earlier "
            "run's pictures are kept as they were"
        )
        error.exit_status = 1
        raise error from None


if __name__ == "__main__":
    run(main)
