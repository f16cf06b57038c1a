"""ArUco calibration on perspective frames: the project's sheet as a webcam above it sees it.

The frames are rendered, not mocked: the A4 page of ``tools/aruco_sheet.py`` lies on the
table and a pinhole camera (640×480, 65° horizontal field of view, no distortion) looks
at it from 50–60 cm, straight down or tilted 8°. Each frame is warped from the page at
8× the resolution and box-filtered down (pixel area sampling), then blurred (σ 0.6 px)
and given sensor noise (σ 2 grey levels). The truth is the projection of the page's
marker corners, found exactly in the page by template matching.
"""

from __future__ import annotations

import functools
import math
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import run_in_process

from mearm.config import load_config
from mearm.tools.aruco_sheet import marker_sheet
from mearm.vision import Calibration
from mearm.vision.aruco import detect_markers, marker_image

ROOT = Path(__file__).resolve().parent.parent
IDS = [0, 1, 2, 3]
SIDE_CM = 4.0
DPI = 254  # 100 px per cm: the 4 cm markers are 400 px, exactly
PX_PER_CM = DPI / 2.54
W, H = 640, 480
FOCAL_PX = (W / 2) / math.tan(math.radians(65.0 / 2))
K = np.array([[FOCAL_PX, 0, (W - 1) / 2], [0, FOCAL_PX, (H - 1) / 2], [0, 0, 1.0]])
#: Table position of the page's top-left corner [cm]; its top edge faces +y.
PAGE_ORIGIN_CM = (-10.5, 59.7)
SUPERSAMPLE = 8

#: name → (height above the table [cm], tilt about the camera's x, about its y [deg])
VIEWS = {
    "straight_55cm": (55.0, 0.0, 0.0),
    "straight_50cm": (50.0, 0.0, 0.0),
    "straight_60cm": (60.0, 0.0, 0.0),
    "tilted_x_8deg_55cm": (55.0, 8.0, 0.0),
    "tilted_y_8deg_55cm": (55.0, 0.0, 8.0),
    "tilted_x_8deg_60cm": (60.0, -8.0, 0.0),
    "tilted_y_8deg_50cm": (50.0, 0.0, -8.0),
}
STRAIGHT = [v for v in VIEWS if v.startswith("straight")]
TILTED = [v for v in VIEWS if v.startswith("tilted")]


PAGE = marker_sheet(IDS, SIDE_CM, DPI)


def page_to_table(page_xy: np.ndarray) -> np.ndarray:
    """Page coordinates (x right, y down, pixel edges at integers) → table (x, y) [cm]."""
    p = np.asarray(page_xy, dtype=float) / PX_PER_CM
    return np.column_stack([PAGE_ORIGIN_CM[0] + p[:, 0], PAGE_ORIGIN_CM[1] - p[:, 1]])


@functools.cache
def marker_truth() -> dict[int, np.ndarray]:
    """Marker id → its corners on the table (TL, TR, BR, BL) [cm], found in the page (once
    per worker that runs these tests, not at every worker's collection)."""
    side = round(SIDE_CM * PX_PER_CM)
    out = {}
    for marker_id in IDS:
        template = marker_image(marker_id, side)
        scores = cv2.matchTemplate(PAGE, template, cv2.TM_SQDIFF)
        low, _, (x, y), _ = cv2.minMaxLoc(scores)
        assert low < 255.0**2 / 2  # exactly there (not one pixel differs; float sums)
        quad = np.array([[x, y], [x + side, y], [x + side, y + side], [x, y + side]], float)
        out[marker_id] = page_to_table(quad)
    return out


def camera_matrix(view: str) -> np.ndarray:
    """Table (x, y, 1) [cm] → pixel (u, v, 1) homography of a view (pixel centres at integers)."""
    height, tilt_x, tilt_y = VIEWS[view]
    page_w, page_h = PAGE.shape[1] / PX_PER_CM, PAGE.shape[0] / PX_PER_CM
    centre = np.array([PAGE_ORIGIN_CM[0] + page_w / 2, PAGE_ORIGIN_CM[1] - page_h / 2, 0.0])
    down = np.diag([1.0, -1.0, -1.0])  # image x along +x, image y along −y, optical axis −z
    rx = cv2.Rodrigues(np.array([math.radians(tilt_x), 0.0, 0.0]))[0]
    ry = cv2.Rodrigues(np.array([0.0, math.radians(tilt_y), 0.0]))[0]
    R = rx @ ry @ down
    t = -R @ (centre + np.array([0.0, 0.0, height]))
    return K @ np.column_stack([R[:, 0], R[:, 1], t])


def to_pixels(Hc: np.ndarray, table_cm: np.ndarray) -> np.ndarray:
    p = np.column_stack([table_cm, np.ones(len(table_cm))]) @ Hc.T
    return p[:, :2] / p[:, 2:]


def render(view: str, seed: int = 0) -> np.ndarray:
    """The view of the page on a grey table, (480, 640, 3) uint8."""
    page_centre_to_table = np.array(
        [
            [1 / PX_PER_CM, 0, PAGE_ORIGIN_CM[0] + 0.5 / PX_PER_CM],
            [0, -1 / PX_PER_CM, PAGE_ORIGIN_CM[1] - 0.5 / PX_PER_CM],
            [0, 0, 1],
        ]
    )
    s = SUPERSAMPLE
    fine = np.array([[s, 0, (s - 1) / 2], [0, s, (s - 1) / 2], [0, 0, 1.0]])
    M = fine @ camera_matrix(view) @ page_centre_to_table
    big = cv2.warpPerspective(PAGE, M, (W * s, H * s), flags=cv2.INTER_LINEAR, borderValue=(95,))
    frame = cv2.resize(big, (W, H), interpolation=cv2.INTER_AREA).astype(np.float32)
    frame = cv2.GaussianBlur(frame, (0, 0), 0.6)
    frame += np.random.default_rng(seed).normal(0.0, 2.0, frame.shape).astype(np.float32)
    grey = np.clip(np.rint(frame), 0, 255).astype(np.uint8)
    return cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)


def corner_error_px(view: str) -> float:
    found = detect_markers(render(view))
    assert sorted(found) == IDS  # each marker once: a dict cannot hold an id twice
    Hc = camera_matrix(view)
    return max(float(np.abs(found[i] - to_pixels(Hc, marker_truth()[i])).max()) for i in IDS)


@pytest.mark.parametrize("view", list(VIEWS))
def test_each_marker_once_at_its_corners(view: str) -> None:
    """Every marker of the sheet is found once, its corners within 0.5 px of the truth."""
    assert corner_error_px(view) < 0.5


def run_calibrate_tool(view: str, tmp_path: Path) -> Calibration:
    image = tmp_path / f"{view}.png"
    cv2.imwrite(str(image), render(view))
    config = tmp_path / "lab.yaml"
    config.write_text((ROOT / "configs" / "lab.yaml").read_text())
    args = ["--config", str(config), "--image", str(image), "--marker-side-cm", str(SIDE_CM)]
    for marker_id, corners in marker_truth().items():
        x, y = (float(v) for v in corners.mean(axis=0))
        args += ["--marker", f"{marker_id}:{x!r},{y!r}"]
    if view == STRAIGHT[0]:  # the script as a user runs it, once
        result = subprocess.run(
            [sys.executable, str(ROOT / "tools" / "calibrate_camera.py"), *args],
            capture_output=True, text=True, timeout=60,
        )  # fmt: skip
        code, stdout, stderr = result.returncode, result.stdout, result.stderr
    else:  # the same command in this process (a process each cost 0.45 s of CPU)
        out = run_in_process(["calibrate-camera", *args], within_s=6)
        code, stdout, stderr = out.code, out.stdout, out.stderr
    assert code == 0, stderr
    assert "fitted from 4 ArUco marker centres and corners" in stdout
    return Calibration.from_config(load_config(config).calibration)


def table_error_cm(view: str, fitted: Calibration, *, whole_page: bool = False) -> float:
    """Largest distance between the fitted and the true table point [cm].

    Over the area the markers span (where the fit interpolates), or the whole page
    (most of which, below the markers, it extrapolates).
    """
    if whole_page:
        x0, y1 = PAGE_ORIGIN_CM
        x1, y0 = x0 + PAGE.shape[1] / PX_PER_CM, y1 - PAGE.shape[0] / PX_PER_CM
    else:
        corners = np.concatenate(list(marker_truth().values()))
        (x0, y0), (x1, y1) = corners.min(axis=0), corners.max(axis=0)
    gx, gy = np.meshgrid(np.linspace(x0, x1, 15), np.linspace(y0, y1, 21))
    table = np.column_stack([gx.ravel(), gy.ravel()])
    pixels = to_pixels(camera_matrix(view), table)
    return float(np.linalg.norm(fitted.pixel_to_table(pixels) - table, axis=1).max())


@pytest.mark.parametrize("view", STRAIGHT)
def test_calibrate_tool_on_a_straight_view(view: str, tmp_path: Path) -> None:
    """The tool (the first view through its script) maps the sheet's plane within 0.05 cm."""
    assert table_error_cm(view, run_calibrate_tool(view, tmp_path)) < 0.05


@pytest.mark.parametrize("view", TILTED)
@pytest.mark.heavy
def test_calibrate_tool_on_a_tilted_view(view: str, tmp_path: Path) -> None:
    """Tilted 8°: still a plane, so the homography is as good (within 0.05 cm)."""
    assert table_error_cm(view, run_calibrate_tool(view, tmp_path)) < 0.05
