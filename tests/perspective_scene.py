"""Ray-cast renders of upright cylinders on a table through a known pinhole camera with distortion.

The ground truth of the perspective tests: every pixel (3 × 3 sub-samples) is undistorted
with the true camera and its ray cut with the table (z = 0) and with each cylinder's top
disc and side wall, nearest hit first. The top face takes the class's colour, the side
wall the same colour darker (lit from above), the table a light grey; Gaussian sensor
noise is added. Exact geometry, no texture: what these scenes test is the camera model.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mearm.vision.pinhole import Extrinsics, Intrinsics, PerspectiveCamera

#: The webcam of the issue: 640 × 480 px, ≈ 65° horizontal field of view.
WIDTH, HEIGHT = 640, 480
FOCAL_PX = (WIDTH / 2) / math.tan(math.radians(65.0 / 2))
#: Mild barrel distortion, as a cheap webcam lens.
DISTORTION = (-0.12, 0.05, 0.0008, -0.0006, 0.0)
TABLE_BGR = (175, 178, 180)
SIDE_SHADE = 0.6
SUB = 3


@dataclass(frozen=True)
class Cylinder:
    """An upright cylinder standing on the table at (x, y) [cm]."""

    x: float
    y: float
    radius: float
    height: float
    bgr: tuple[int, int, int]


def true_camera(
    height_cm: float = 55.0,
    tilt_deg: float = 0.0,
    target_cm: Sequence[float] = (0.0, 44.0),
    yaw_deg: float = 0.0,
    distortion: Sequence[float] = DISTORTION,
) -> PerspectiveCamera:
    """A camera ``height_cm`` above the table, tilted about its x axis, aimed at ``target_cm``.

    Untilted it looks straight down with the image's right along +x and its top along +y
    (the paper's camera). Tilted, it moves towards −y and looks back at the target.
    """
    K = np.array([[FOCAL_PX, 0, (WIDTH - 1) / 2], [0, FOCAL_PX, (HEIGHT - 1) / 2], [0, 0, 1]])
    intr = Intrinsics(K, distortion, (WIDTH, HEIGHT), 0.0, camera_id="truth")
    down = np.array([[1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0]]).T  # columns: camera x, y, z
    t = math.radians(tilt_deg)
    tilt = np.array([[1, 0, 0], [0, math.cos(t), -math.sin(t)], [0, math.sin(t), math.cos(t)]])
    y = math.radians(yaw_deg)
    yaw = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    R = yaw @ tilt @ down
    axis = R[:, 2]
    centre = np.array([target_cm[0], target_cm[1], 0.0]) - axis * (height_cm / -axis[2])
    ext = Extrinsics(R, centre, 0.0, camera_id="truth", size_px=(WIDTH, HEIGHT))
    return PerspectiveCamera(intr, ext)


#: Per camera: each pixel's sub-sample rays, (HEIGHT, WIDTH, SUB * SUB, 3), and which
#: pixels' are filled in. A scene without a texture traces only the box around its
#: objects, so a pixel's rays are worked out the first time a box takes it in (the whole
#: frame's, 2.8 million undistorted points, took 1.1 s of CPU, and most were never used).
_RAYS: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}


def _rays(camera: PerspectiveCamera, u0: int, v0: int, u1: int, v1: int) -> np.ndarray:
    """The rays of the pixels [v0:v1, u0:u1], (v1 - v0, u1 - u0, SUB * SUB, 3): the same
    numbers whichever box asks first (each point is undistorted on its own)."""
    e, i = camera.extrinsics, camera.intrinsics
    key = b"".join(a.tobytes() for a in (e.rotation, e.position_cm, i.camera_matrix, i.distortion))
    if key not in _RAYS:
        _RAYS.clear()
        rays = np.empty((HEIGHT, WIDTH, SUB * SUB, 3))
        _RAYS[key] = (rays, np.zeros((HEIGHT, WIDTH), dtype=bool))
    rays, done = _RAYS[key]
    vs, us = np.nonzero(~done[v0:v1, u0:u1])
    if len(vs):
        vs, us = vs + v0, us + u0
        offs = (np.arange(SUB) + 0.5) / SUB - 0.5
        # sub-sample k = row * SUB + column: the column's offset along u, the row's along v
        su = np.broadcast_to(us[:, None, None] + offs[None, None, :], (len(us), SUB, SUB))
        sv = np.broadcast_to(vs[:, None, None] + offs[None, :, None], (len(vs), SUB, SUB))
        px = np.stack([su.ravel(), sv.ravel()], axis=1)
        rays[vs, us] = camera.rays(px).reshape(len(vs), SUB * SUB, 3)
        done[vs, us] = True
    return rays[v0:v1, u0:u1]


@dataclass(frozen=True)
class Texture:
    """A picture lying on the table: grey uint8 image, its top-left corner at (x0, y1) [cm]."""

    image: np.ndarray
    x0: float
    y1: float
    px_per_cm: float


def sheet(
    markers: dict[int, tuple[float, float]], side_cm: float, px_per_cm: float = 40
) -> Texture:
    """White paper under ArUco markers (DICT_4X4_50) centred at ``markers`` [cm], top edge +y."""
    import cv2

    from mearm.vision.aruco import marker_image

    xy = np.array(list(markers.values()))
    margin = side_cm
    x0, y0 = xy.min(axis=0) - side_cm / 2 - margin
    x1, y1 = xy.max(axis=0) + side_cm / 2 + margin
    w, h = round((x1 - x0) * px_per_cm), round((y1 - y0) * px_per_cm)
    page = np.full((h, w), 255, np.uint8)
    side = round(side_cm * px_per_cm)
    for marker_id, (x, y) in markers.items():
        u = (x - side_cm / 2 - x0) * px_per_cm
        v = (y1 - (y + side_cm / 2)) * px_per_cm
        M = np.float32([[1, 0, u], [0, 1, v]])
        img = marker_image(marker_id, side)
        placed = cv2.warpAffine(img, M, (w, h), flags=cv2.INTER_NEAREST, borderValue=255)
        cover = cv2.warpAffine(
            np.zeros_like(img), M, (w, h), flags=cv2.INTER_NEAREST, borderValue=255
        )
        page = np.where(cover == 0, placed, page)
    return Texture(page, float(x0), float(y1), px_per_cm)


def render(
    camera: PerspectiveCamera,
    cylinders: Sequence[Cylinder],
    noise_std: float = 2.0,
    seed: int = 0,
    texture: Texture | None = None,
) -> np.ndarray:
    """The BGR uint8 frame the camera sees."""
    o = camera.centre_cm
    # each cylinder is traced only through the pixels around its image; without a texture
    # every other pixel is the plain table, and only the box around them is traced
    windows = []
    for c in cylinders:
        hull = camera.silhouette_px((c.x, c.y), c.radius, c.height)
        u0, v0 = np.maximum(np.floor(hull.min(axis=0)).astype(int) - 3, 0)
        u1, v1 = np.minimum(np.ceil(hull.max(axis=0)).astype(int) + 4, (WIDTH, HEIGHT))
        if u0 < u1 and v0 < v1:
            windows.append((c, int(u0), int(v0), int(u1), int(v1)))
    if texture is None:
        if not windows:
            img = np.empty((HEIGHT, WIDTH, 3))
            img[:] = TABLE_BGR
            return _finish(img, noise_std, seed)
        U0, V0 = min(w[1] for w in windows), min(w[2] for w in windows)
        U1, V1 = max(w[3] for w in windows), max(w[4] for w in windows)
    else:
        U0, V0, U1, V1 = 0, 0, WIDTH, HEIGHT
    d_img = _rays(camera, U0, V0, U1, V1)
    d = d_img.reshape(-1, 3)
    n = len(d)
    best = (0.0 - o[2]) / d[:, 2]  # the table
    colour = np.tile(np.array(TABLE_BGR, dtype=float), (n, 1))
    if texture is not None:
        p = o[:2] + best[:, None] * d[:, :2]
        u = (p[:, 0] - texture.x0) * texture.px_per_cm - 0.5
        v = (texture.y1 - p[:, 1]) * texture.px_per_cm - 0.5
        h, w = texture.image.shape
        inside = (u >= 0) & (v >= 0) & (u <= w - 1) & (v <= h - 1)
        ui, vi = (
            np.clip(np.rint(u), 0, w - 1).astype(int),
            np.clip(np.rint(v), 0, h - 1).astype(int),
        )
        grey = texture.image[vi, ui].astype(float)
        colour[inside] = np.repeat(grey[inside, None], 3, axis=1) * 0.9
    best_img = best.reshape(V1 - V0, U1 - U0, SUB * SUB)
    colour_img = colour.reshape(V1 - V0, U1 - U0, SUB * SUB, 3)
    for c, u0, v0, u1, v1 in windows:
        u0, u1, v0, v1 = u0 - U0, u1 - U0, v0 - V0, v1 - V0
        dw = d_img[v0:v1, u0:u1].reshape(-1, 3)
        bw = best_img[v0:v1, u0:u1].reshape(-1)
        cw = colour_img[v0:v1, u0:u1].reshape(-1, 3)
        bgr = np.array(c.bgr, dtype=float)
        # top disc
        t = (c.height - o[2]) / dw[:, 2]
        p = o[:2] + t[:, None] * dw[:, :2]
        hit = (np.sum((p - (c.x, c.y)) ** 2, axis=1) <= c.radius**2) & (t < bw)
        bw = np.where(hit, t, bw)
        cw[hit] = bgr
        # side wall: |o + t d - c|_xy = r, nearest root with 0 <= z <= h
        ox, oy = o[0] - c.x, o[1] - c.y
        a = dw[:, 0] ** 2 + dw[:, 1] ** 2
        b = 2 * (ox * dw[:, 0] + oy * dw[:, 1])
        cc = ox**2 + oy**2 - c.radius**2
        disc = b * b - 4 * a * cc
        ok = disc >= 0
        t = np.where(ok, (-b - np.sqrt(np.where(ok, disc, 0))) / (2 * a), np.inf)
        z = o[2] + t * dw[:, 2]
        hit = ok & (z >= 0) & (z <= c.height) & (t < bw) & (t > 0)
        bw = np.where(hit, t, bw)
        cw[hit] = bgr * SIDE_SHADE
        best_img[v0:v1, u0:u1] = bw.reshape(v1 - v0, u1 - u0, SUB * SUB)
        colour_img[v0:v1, u0:u1] = cw.reshape(v1 - v0, u1 - u0, SUB * SUB, 3)
    img = np.empty((HEIGHT, WIDTH, 3))
    img[:] = TABLE_BGR
    img[V0:V1, U0:U1] = colour_img.mean(axis=2)
    return _finish(img, noise_std, seed)


def _finish(img: np.ndarray, noise_std: float, seed: int) -> np.ndarray:
    """Sensor noise, then the uint8 frame."""
    if noise_std > 0:
        img = img + np.random.default_rng(seed).normal(0.0, noise_std, img.shape)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)
