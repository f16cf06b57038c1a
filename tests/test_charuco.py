"""ChArUco intrinsics: detection, the fit against a known camera, the CLI and its refusals.

The views are synthesised by :mod:`charuco_render` (OpenCV only) through a camera with
known K and distortion, so the fit is compared with the truth.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import check_bad_input, run_in_process
from built_once import built_once, computed_once
from charuco_render import TrueCamera, board_poses, render_view, true_corners

from mearm.exceptions import CalibrationError
from mearm.vision.charuco import (
    DEFAULT_BOARD,
    CalibrationReport,
    calibrate,
    calibrate_report,
    detect_board,
)
from mearm.vision.pinhole import Intrinsics, load_calibration

bad_input = pytest.mark.bad_input
_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 60, 1e-14)


#: The views of the board every fit here uses: how many, and the seed of their poses.
VIEWS, POSE_SEED = 20, 1


@pytest.fixture(scope="module")
def cam() -> TrueCamera:
    return TrueCamera()


@pytest.fixture(scope="module")
def folder(cam: TrueCamera, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """20 views of the board, 20–45 cm away, tilted 10–40°, noise σ = 2, as PNG files
    (rendered once per test run; nothing may write into the folder)."""

    def render(path: Path) -> None:
        for k, pose in enumerate(board_poses(cam, VIEWS, seed=POSE_SEED)):
            cv2.imwrite(str(path / f"view_{k:02d}.png"), render_view(cam, pose, seed=100 + k))

    return built_once(tmp_path_factory, "charuco-views", render)


@pytest.fixture(scope="module")
def views(folder: Path) -> list[np.ndarray]:
    """The views of :func:`folder` (PNG is lossless: the rendered grey images)."""
    return [cv2.imread(str(p), cv2.IMREAD_UNCHANGED) for p in sorted(folder.glob("view_*.png"))]


@pytest.fixture(scope="module")
def report(views: list[np.ndarray], tmp_path_factory: pytest.TempPathFactory) -> CalibrationReport:
    """The fit to the 20 views (fitted once per test run)."""
    return computed_once(
        tmp_path_factory, "charuco-fit", lambda: calibrate_report(views, camera_id="images")
    )


@pytest.mark.heavy
def test_corners_are_found_to_a_tenth_of_a_pixel(cam: TrueCamera, views: list[np.ndarray]) -> None:
    """Detected corners lie within 0.1 px RMS of the true projections, in every view."""
    errors = []
    for view, pose in zip(views, board_poses(cam, VIEWS, seed=POSE_SEED), strict=True):
        corners, ids = detect_board(view)
        assert len(ids) >= 12
        errors.append(np.linalg.norm(corners - true_corners(cam, pose)[ids], axis=1))
    e = np.concatenate(errors)
    assert np.sqrt(np.mean(e**2)) < 0.1 and e.max() < 0.4


def test_no_board_no_corners() -> None:
    """A blank frame, a tiny frame: N = 0, no error."""
    for frame in (np.full((480, 640), 128, np.uint8), np.zeros((16, 16, 3), np.uint8)):
        corners, ids = detect_board(frame)
        assert corners.shape == (0, 2) and ids.shape == (0,)


@pytest.mark.heavy
def test_the_fit_recovers_the_camera(report: CalibrationReport, cam: TrueCamera) -> None:
    """fx, fy, cx, cy within 0.5 px of the truth; reprojection RMS ≤ 0.3 px."""
    K = report.intrinsics.camera_matrix
    for i, j in [(0, 0), (1, 1), (0, 2), (1, 2)]:
        assert abs(K[i, j] - cam.K[i, j]) < 0.5, (i, j, K[i, j], cam.K[i, j])
    assert report.intrinsics.rms_px <= 0.3
    assert report.intrinsics.views >= 18 and not report.dropped
    assert report.coverage >= 0.5


@pytest.mark.heavy
def test_undistortion_agrees_with_the_truth(report: CalibrationReport, cam: TrueCamera) -> None:
    """Undistorted pixels agree with the true model's within 0.15 px where the board was seen.

    Outside the corners' convex hull (the frame's far corners) the fit extrapolates and
    is not held to this.
    """
    w, h = cam.size_px
    u, v = np.meshgrid(np.linspace(0, w - 1, 65), np.linspace(0, h - 1, 49))
    grid = np.stack([u.ravel(), v.ravel()], axis=-1).reshape(-1, 1, 2)
    fit = report.intrinsics
    truth = cv2.undistortPoints(grid, cam.K, cam.dist, None, cam.K, None, _CRITERIA)
    est = cv2.undistortPoints(
        grid, fit.camera_matrix, fit.distortion, None, fit.camera_matrix, None, _CRITERIA
    )
    err = np.linalg.norm((truth - est).reshape(-1, 2), axis=1)
    seen = np.concatenate([true_corners(cam, p) for p in board_poses(cam, VIEWS, seed=POSE_SEED)])
    hull = cv2.convexHull(seen.astype(np.float32))
    inside = np.array(
        [cv2.pointPolygonTest(hull, (float(x), float(y)), False) > 0 for x, y in grid[:, 0]]
    )
    assert err[inside].max() < 0.15


@pytest.mark.heavy
def test_calibrate_returns_intrinsics(views: list[np.ndarray]) -> None:
    """calibrate() is the report's Intrinsics."""
    assert isinstance(calibrate(views[:12]), Intrinsics)


@pytest.mark.heavy
def test_refusals_say_why(views: list[np.ndarray]) -> None:
    """Mixed sizes, too few views, too little coverage: a CalibrationError naming it."""
    small = cv2.resize(views[1], (320, 240))
    with pytest.raises(CalibrationError, match="frame 1 is 320x240 px but the first"):
        calibrate([views[0], small, *views[2:]])
    with pytest.raises(CalibrationError, match="only 4 of 4 views .* at least 6"):
        calibrate(views[:4])
    centre = [v for v, p in zip(views, range(20), strict=False) if p % 9 == 4]  # centred
    with pytest.raises(CalibrationError, match="cover .* of the frame"):
        calibrate(centre * 3)


@pytest.mark.heavy
def test_an_outlier_view_is_dropped(views: list[np.ndarray], cam: TrueCamera) -> None:
    """A view of a warped board is dropped, named, and the fit stays good."""
    bent = views[3].copy()
    h, w = bent.shape
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    bent = cv2.remap(bent, xs + 3 * np.sin(ys / 25), ys + 3 * np.cos(xs / 31), cv2.INTER_LINEAR)
    rep = calibrate_report([*views[:3], bent, *views[4:]])
    assert rep.dropped == ("frame 3",)
    assert abs(rep.intrinsics.camera_matrix[0, 0] - cam.K[0, 0]) < 1.0


# --------------------------------------------------------------------------- CLI


@pytest.mark.heavy
def test_cli_writes_keeps_and_forces(folder: Path, cam: TrueCamera, tmp_path: Path) -> None:
    """Writes a loadable file; a worse run keeps it (exit 2); --force replaces it (.bak)."""
    out = tmp_path / "intrinsics.yaml"
    done = run_in_process(["calibrate-intrinsics", "--images", folder, "--out", out], within_s=30)
    assert done.code == 0, done.stderr
    assert f"wrote {out}" in done.stdout and "camera matrix" in done.stdout
    cal = load_calibration(out, "intrinsics")
    assert isinstance(cal, Intrinsics) and abs(cal.camera_matrix[0, 0] - cam.K[0, 0]) < 0.5
    good = out.read_bytes()

    worse = tmp_path / "worse"
    worse.mkdir()
    for k, pose in enumerate(board_poses(cam, 8, seed=5)):
        cv2.imwrite(str(worse / f"w{k}.png"), render_view(cam, pose, noise=8.0, seed=k))
    refused = check_bad_input(
        ["calibrate-intrinsics", "--images", worse, "--out", out], within_s=30, keep=[out]
    )
    assert "holds a better calibration" in refused.line and out.read_bytes() == good

    forced = run_in_process(
        ["calibrate-intrinsics", "--images", worse, "--out", out, "--force"], within_s=30
    )
    assert forced.code == 0, forced.stderr
    assert out.read_bytes() != good
    assert (tmp_path / "intrinsics.yaml.bak").read_bytes() == good


@pytest.mark.heavy
def test_cli_dry_run_writes_nothing(folder: Path, tmp_path: Path) -> None:
    out = tmp_path / "i.yaml"
    done = run_in_process(
        ["calibrate-intrinsics", "--images", folder, "--out", out, "--dry-run"], within_s=30
    )
    assert done.code == 0 and "dry run" in done.stdout and not out.exists()


def test_board_page_is_printable(tmp_path: Path) -> None:
    """The page records its DPI; the board on it is found, 3 cm squares at 300 dpi."""
    out = tmp_path / "board.png"
    done = run_in_process(["charuco-board", "--output", out], within_s=30)
    assert done.code == 0, done.stderr
    data = out.read_bytes()
    assert b"pHYs" in data[:100]
    page = cv2.imread(str(out), cv2.IMREAD_GRAYSCALE)
    assert page.shape == (2480, 3508)  # A4 landscape at 300 dpi
    corners, ids = detect_board(
        cv2.resize(page, None, fx=0.25, fy=0.25, interpolation=cv2.INTER_AREA)
    )
    assert len(ids) == DEFAULT_BOARD.corners
    # neighbouring corners 3 cm apart: 3 / 2.54 * 300 / 4 px on the reduced page
    step = np.linalg.norm(corners[ids == 1][0] - corners[ids == 0][0])
    assert step == pytest.approx(3 / 2.54 * 300 / 4, abs=0.5)


# --------------------------------------------------------------------------- bad input


def _blank_folder(path: Path) -> Path:
    path.mkdir()
    for k in range(8):
        cv2.imwrite(str(path / f"b{k}.png"), np.full((480, 640), 200, np.uint8))
    return path


@bad_input
@pytest.mark.parametrize(
    ("case", "words"),
    [
        ("text_png", "not an image of a known format"),
        ("truncated_png", "x.png"),
        ("tiny", "no ChArUco board found"),
        ("mixed", "every view must come from the same camera"),
        ("blank_folder", "only 0 of 8 views"),
        ("missing", "no such file or folder"),
        ("no_board_file", "no ChArUco board found"),
        ("empty_folder", "holds no *.png"),
    ],
)
@pytest.mark.heavy
def test_bad_images_are_refused(case: str, words: str, folder: Path, tmp_path: Path) -> None:
    """Each: exit 2, one line naming the problem, --out untouched."""
    first = sorted(folder.iterdir())[0]
    bad = tmp_path / "x.png"
    args: list[object]
    if case == "text_png":
        bad.write_text("not a picture\n")
        args = [first, bad]
    elif case == "truncated_png":
        bad.write_bytes(first.read_bytes()[:300])
        args = [first, bad]
    elif case == "tiny":
        cv2.imwrite(str(bad), np.zeros((16, 16), np.uint8))
        args = [bad]
    elif case == "mixed":
        cv2.imwrite(str(bad), cv2.resize(cv2.imread(str(first)), (320, 240)))
        args = [first, bad]
    elif case == "blank_folder":
        args = [_blank_folder(tmp_path / "blank")]
    elif case == "missing":
        args = [tmp_path / "nowhere"]
    elif case == "no_board_file":
        cv2.imwrite(str(bad), np.full((480, 640), 200, np.uint8))
        args = [first, bad]
    else:
        (tmp_path / "empty").mkdir()
        args = [tmp_path / "empty"]
    out = tmp_path / "out.yaml"
    out.write_text("keep me\n")
    done = check_bad_input(
        ["calibrate-intrinsics", "--images", *args, "--out", out], within_s=10, keep=[out]
    )
    assert words in done.line


@bad_input
@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--device", "0", "--frames", "0"], "--frames must be an integer in [6, 500]"),
        (["--device", "0", "--frames", "x"], "--frames must be an integer"),
        (["--device", "0", "--interval-s", "-1"], "must be a positive number"),
        (["--device", "abc"], "--device must be a camera index"),
        (["--device", "100"], "--device must be a camera index"),
        (["--device", "99"], "camera (device 99)"),
        ([], "one of the arguments --images --device is required"),
        (["--images", "a.png", "--device", "0"], "not allowed with argument"),
    ],
)
def test_bad_arguments_are_refused(args: list[str], words: str, tmp_path: Path) -> None:
    out = tmp_path / "out.yaml"
    done = check_bad_input(["calibrate-intrinsics", *args, "--out", out], within_s=10)
    assert words in done.line and not out.exists()


@bad_input
@pytest.mark.heavy
def test_out_a_folder_is_refused(folder: Path, tmp_path: Path) -> None:
    done = check_bad_input(
        ["calibrate-intrinsics", "--images", folder, "--out", tmp_path], within_s=10
    )
    assert "not a regular file" in done.line


@bad_input
@pytest.mark.parametrize(
    ("args", "words"),
    [(["--dpi", "10"], "--dpi must be in [72, 2400]"),
     (["--output", "{d}/b.jpg"], "must be a .png"),
     (["--output", "{d}"], "must be a .png"),
     (["--output", "/proc/mearm-no-such-folder/b.png"], "cannot write")],
)  # fmt: skip
def test_board_bad_arguments(args: list[str], words: str, tmp_path: Path) -> None:
    argv = [a.format(d=tmp_path) for a in args]
    if "--output" not in argv:
        argv += ["--output", str(tmp_path / "b.png")]
    done = check_bad_input(["charuco-board", *argv], within_s=10, keep=[tmp_path])
    assert words in done.line
