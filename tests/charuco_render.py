"""Synthetic views of a ChArUco board through a camera with known intrinsics.

Each view is rendered by inverse mapping: every output pixel (3 × 3 sub-samples of it)
is undistorted with the ground-truth model, its ray cut with the board plane, and the
board's picture sampled there; the sub-samples are averaged (anti-aliasing) and
Gaussian noise added. The board lies on a white margin on a grey background.

OpenCV only (no calibration code of the package), so a calibration fitted to these views
can be compared with the truth::

    cam = TrueCamera()
    views = [render_view(cam, pose) for pose in board_poses(cam, 18, seed=1)]
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import cv2
import numpy as np

from mearm.vision.charuco import DEFAULT_BOARD, BoardSpec, board_image

#: Sub-samples per pixel side (3 × 3 per pixel).
SUPERSAMPLE = 3
#: Resolution of the board picture sampled [px per square]; a 3 cm square seen from
#: 20 cm is ~80 px, so the picture is finer than any view of it.
PX_PER_SQUARE = 160
#: White margin around the board [squares].
MARGIN_SQUARES = 0.6
#: Background grey level outside the board's paper.
BACKGROUND = 110
_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 60, 1e-14)


@dataclass(frozen=True)
class TrueCamera:
    """The ground truth: a 640 × 480 webcam with barrel distortion."""

    K: np.ndarray = field(
        default_factory=lambda: np.array([[515.0, 0.0, 322.5], [0.0, 513.0, 238.0], [0, 0, 1]])
    )
    dist: np.ndarray = field(default_factory=lambda: np.array([-0.12, 0.05, 0.0012, -0.0008, 0.0]))
    size_px: tuple[int, int] = (640, 480)

    @cached_property
    def rays(self) -> np.ndarray:
        """Normalised coordinates (x/z, y/z) of every sub-sample, (H·S, W·S, 2).

        OpenCV's distortion model inverted by Newton's method over the whole grid (2.8 M
        points: ``cv2.undistortPoints``' fixed-point loop took 3.7 s of CPU, this ~1 s),
        checked against ``cv2.undistortPoints`` on a sample of them.
        """
        w, h = self.size_px
        s = SUPERSAMPLE
        offs = (np.arange(s) - (s - 1) / 2) / s  # sub-sample centres within a pixel
        u = (np.arange(w)[:, None] + offs[None, :]).reshape(-1)
        v = (np.arange(h)[:, None] + offs[None, :]).reshape(-1)
        uu, vv = np.meshgrid(u, v)
        # in blocks of rows: small arrays stay in the cache (2.8 M points at once: 1 s of
        # page faults)
        n = np.concatenate(
            [_undistorted(uu[r : r + 60], vv[r : r + 60], self.K, self.dist)
             for r in range(0, h * s, 60)]
        )  # fmt: skip
        rng = np.random.default_rng(0)
        k = rng.integers(0, uu.size, 2000)
        px = np.stack([uu.reshape(-1)[k], vv.reshape(-1)[k]], axis=-1).reshape(-1, 1, 2)
        by_cv = cv2.undistortPoints(px, self.K, self.dist, None, None, None, _CRITERIA)
        assert np.abs(n.reshape(-1, 2)[k] - by_cv.reshape(-1, 2)).max() < 1e-12
        return n

    def project(self, points: np.ndarray, rvec: np.ndarray, tvec: np.ndarray) -> np.ndarray:
        """Pixels of board points (N, 3) [cm] at the pose (rvec, tvec), (N, 2)."""
        px, _ = cv2.projectPoints(points.reshape(-1, 1, 3), rvec, tvec, self.K, self.dist)
        return px.reshape(-1, 2)


def _undistorted(u: np.ndarray, v: np.ndarray, K: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """The normalised (x, y) that OpenCV's model (k1, k2, p1, p2, k3) distorts to the
    pixels (u, v), by Newton's method: (*u.shape, 2)."""
    k1, k2, p1, p2, k3 = dist
    xd, yd = (u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1]  # K without skew
    x, y = xd.copy(), yd.copy()
    for _ in range(20):
        r2 = x * x + y * y
        radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        ex = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) - xd
        ey = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y - yd
        if max(np.abs(ex).max(), np.abs(ey).max()) < 1e-15:
            break
        slope = 2 * (k1 + r2 * (2 * k2 + 3 * k3 * r2))  # d radial / d r2, twice
        cross = x * y * slope + 2 * p1 * x + 2 * p2 * y  # d ex / dy = d ey / dx
        a = radial + x * x * slope + 2 * p1 * y + 6 * p2 * x  # d ex / dx
        d = radial + y * y * slope + 6 * p1 * y + 2 * p2 * x  # d ey / dy
        det = a * d - cross * cross
        x, y = x - (d * ex - cross * ey) / det, y - (a * ey - cross * ex) / det
    return np.stack([x, y], axis=-1)


@dataclass(frozen=True)
class Pose:
    """The board's pose in the camera: x_cam = R·x_board + t [cm]."""

    rvec: np.ndarray
    tvec: np.ndarray


def _board_picture(spec: BoardSpec) -> tuple[np.ndarray, int]:
    pic = board_image(spec, PX_PER_SQUARE)
    m = round(MARGIN_SQUARES * PX_PER_SQUARE)
    return cv2.copyMakeBorder(pic, m, m, m, m, cv2.BORDER_CONSTANT, value=255), m


def render_view(
    cam: TrueCamera,
    pose: Pose,
    spec: BoardSpec = DEFAULT_BOARD,
    noise: float = 2.0,
    seed: int = 0,
) -> np.ndarray:
    """The camera's view of the board at ``pose``: (H, W) uint8 grey."""
    pic, margin = _board_picture(spec)
    R, _ = cv2.Rodrigues(np.asarray(pose.rvec, float))
    # ray (x, y, 1)·λ = X·r1 + Y·r2 + t  ⇔  (X, Y, 1) ∝ [r1 r2 t]⁻¹ (x, y, 1)
    Hinv = np.linalg.inv(np.column_stack([R[:, 0], R[:, 1], np.asarray(pose.tvec, float)]))
    n = cam.rays
    q = n[..., 0:1] * Hinv[:, 0] + n[..., 1:2] * Hinv[:, 1] + Hinv[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        bx, by = q[..., 0] / q[..., 2], q[..., 1] / q[..., 2]
    behind = ~(q[..., 2] > 0)
    scale = PX_PER_SQUARE / spec.square_cm
    # picture pixel j covers board x ∈ [j, j+1)/scale: its centre is at (j + ½)/scale
    map_x = (bx * scale + margin - 0.5).astype(np.float32)
    map_y = (by * scale + margin - 0.5).astype(np.float32)
    map_x[behind] = -1e4
    fine = cv2.remap(
        pic.astype(np.float32), map_x, map_y, cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT, borderValue=float(BACKGROUND),
    )  # fmt: skip
    w, h = cam.size_px
    s = SUPERSAMPLE
    img = fine.reshape(h, s, w, s).mean(axis=(1, 3))
    rng = np.random.default_rng(seed)
    img = img + rng.normal(0.0, noise, img.shape)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def board_poses(
    cam: TrueCamera,
    count: int,
    seed: int = 0,
    spec: BoardSpec = DEFAULT_BOARD,
    distance_cm: tuple[float, float] = (20.0, 45.0),
    max_tilt_deg: float = 40.0,
    min_visible: float = 0.8,
) -> list[Pose]:
    """``count`` varied board poses: 20–45 cm away, tilted up to 40°, spread over the frame.

    The board's centre is aimed at points spread over the frame (corners and edges
    first, where distortion shows); a pose is kept when at least ``min_visible`` of the
    board's inner corners land inside the frame with a 10 px border.
    """
    rng = np.random.default_rng(seed)
    w, h = cam.size_px
    centre = np.array([spec.size_cm[0] / 2, spec.size_cm[1] / 2, 0.0])
    corners = spec.board().getChessboardCorners().astype(float)
    aims = [(fx, fy) for fx in (0.2, 0.5, 0.8) for fy in (0.2, 0.5, 0.8)]
    poses: list[Pose] = []
    tries = 0
    while len(poses) < count:
        tries += 1
        if tries > 100 * count:
            raise RuntimeError("could not place the board")
        ax, ay = aims[len(poses) % len(aims)]
        u = w * (ax + rng.uniform(-0.08, 0.08))
        v = h * (ay + rng.uniform(-0.08, 0.08))
        dist = rng.uniform(*distance_cm)
        tilt = math.radians(rng.uniform(10.0, max_tilt_deg))
        azim = rng.uniform(0, 2 * math.pi)
        axis = np.array([math.cos(azim), math.sin(azim), 0.0])
        R_tilt, _ = cv2.Rodrigues(axis * tilt)
        R_roll, _ = cv2.Rodrigues(np.array([0.0, 0.0, math.radians(rng.uniform(-25, 25))]))
        R = R_tilt @ R_roll
        ray = np.linalg.solve(cam.K, [u, v, 1.0])
        ray /= np.linalg.norm(ray)
        t = dist * ray - R @ centre
        rvec, _ = cv2.Rodrigues(R)
        pose = Pose(rvec.reshape(3), t)
        cam_pts = corners @ R.T + t
        if np.any(cam_pts[:, 2] < 5):
            continue
        px = cam.project(corners, pose.rvec, pose.tvec)
        inside = (px[:, 0] > 10) & (px[:, 0] < w - 10) & (px[:, 1] > 10) & (px[:, 1] < h - 10)
        if inside.mean() >= min_visible:
            poses.append(pose)
    return poses


def true_corners(cam: TrueCamera, pose: Pose, spec: BoardSpec = DEFAULT_BOARD) -> np.ndarray:
    """Ground-truth pixels of all the board's inner corners at ``pose``, (N, 2)."""
    corners = spec.board().getChessboardCorners().astype(float)
    return cam.project(corners, pose.rvec, pose.tvec)
