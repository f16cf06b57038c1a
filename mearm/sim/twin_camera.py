r"""The physical twin's camera: MuJoCo renders what the camera above the table sees.

It stands behind the same :class:`~mearm.vision.camera.Camera` interface as a real
camera, so the detector sees perspective, light and shadow as the twin's physics left
them: an object dropped or knocked over is seen where it lies. Rendering is offscreen on
the CPU; on Linux without a display ``MUJOCO_GL`` defaults to ``egl`` (Mesa), set before
MuJoCo is first imported (:mod:`mearm`).

**Where the camera is** (:func:`camera_pose`): by default straight down from
:data:`~mearm.sim.mjcf.CAMERA_HEIGHT_M` over the calibrated field's centre, yawed and
with the field of view that make ``calibration.homography`` hold on the table; with
``twin.camera`` set (:class:`~mearm.config.twin_camera.TwinCameraConfig`), wherever that
puts it, tilted, with any field of view.

**The pinhole** (:func:`twin_camera_model`): MuJoCo's ``fovy`` spans the frame's full
height and its pixels are square, so

.. math::

    f_x = f_y = \frac{h/2}{\tan(\mathrm{fovy}/2)}, \qquad
    c_x = \frac{w - 1}{2}, \quad c_y = \frac{h - 1}{2}

in OpenCV's pixel convention (pixel (0, 0)'s *centre* is at (0, 0); the frame's outer
edge at −0.5 and w − 0.5), which is what ``cv2.projectPoints`` and every detector use.

**The lens**: with non-zero ``distortion`` (k1 k2 p1 p2 k3, OpenCV's model) each frame is
rendered as the ideal pinhole picture, with a margin wide enough to hold every point the
lens bends into the frame, and remapped once per frame: output pixel :math:`p_d` takes the
ideal pixel :math:`p_u` with :math:`p_d = K\,\mathrm{distort}(K^{-1}p_u)`, i.e.
:math:`p_u = K\,\mathrm{undistort}(K^{-1}p_d)` (``cv2.undistortPoints``, iterated to
convergence). ``cv2.initUndistortRectifyMap`` computes the other direction (for every
*ideal* pixel where it lies in the distorted picture) and is what removes distortion, not
what adds it.
"""

from __future__ import annotations

import copy
import math
from typing import TYPE_CHECKING, NamedTuple

import cv2
import mujoco
import numpy as np

from mearm.config import Config
from mearm.exceptions import CameraError, ModelError
from mearm.sim.mjcf import CAMERA_HEIGHT_M, M_PER_CM
from mearm.vision.camera import Camera

if TYPE_CHECKING:
    from mearm.sim.twin_bus import TwinArm

#: The camera's name in the twin's MJCF (:mod:`mearm.sim.mjcf`).
CAMERA_NAME = "camera"
#: The lens maps must invert the distortion to within this [px]; a stronger distortion
#: folds over inside the frame and has no single inverse.
LENS_INVERSE_TOL_PX = 1e-3
#: The ideal picture rendered under a distorting lens may be at most this many times the
#: frame's side (its margin holds what the lens bends into view).
MAX_LENS_MARGIN_FACTOR = 3.0


class CameraPose(NamedTuple):
    """The twin's camera as MuJoCo places it.

    Attributes:
        centre_m: Optical centre in the base frame, (3,) [m].
        R_base_mj: Camera axes as columns, (3, 3): x right and y up in the image, z
            backwards (MuJoCo's cameras look along their −z).
        fovy_deg: Vertical field of view of the ideal pinhole [deg].
    """

    centre_m: np.ndarray
    R_base_mj: np.ndarray
    fovy_deg: float


class TwinCameraModel(NamedTuple):
    """The twin's camera in OpenCV's terms: the truth a calibration is scored against.

    Attributes:
        K: Camera matrix, (3, 3) [px]; pixel centres at integer coordinates.
        dist: Distortion k1, k2, p1, p2, k3, (5,) [-].
        R_base_cam: Maps camera-frame vectors (OpenCV: x right, y down, z forward) to
            the base frame, (3, 3).
        camera_centre_cm: Optical centre in the base frame (table top at z = 0), (3,) [cm].
    """

    K: np.ndarray
    dist: np.ndarray
    R_base_cam: np.ndarray
    camera_centre_cm: np.ndarray


def homography_view(config: Config) -> tuple[np.ndarray, float, float]:
    """The calibrated field as a straight-down camera sees it: centre [m], yaw [rad], height [m].

    Raises:
        ModelError: the homography mirrors the image, which no camera looking down sees.
    """
    H = np.asarray(config.calibration.homography, dtype=float)
    w, h = config.camera.width_px, config.camera.height_px

    def table(u: float, v: float) -> np.ndarray:
        x, y, s = H @ np.array([u, v, 1.0])
        return np.array([x / s, y / s]) * M_PER_CM

    centre = table(w / 2, h / 2)
    right = table(w / 2 + 1, h / 2) - centre
    down = table(w / 2, h / 2 + 1) - centre
    yaw = math.atan2(right[1], right[0])
    up_local = np.array([-math.sin(yaw), math.cos(yaw)])
    if float(np.dot(down, up_local)) >= 0.0 or np.linalg.norm(right) < 1e-12:
        raise ModelError(
            "calibration.homography: the image is mirrored relative to the table (its v axis "
            "runs along +90° from its u axis), which no camera looking down can see; "
            "recalibrate"
        )
    extent = float(np.linalg.norm(table(w / 2, h) - table(w / 2, 0)))
    return centre, yaw, extent


def _rot(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation by ``angle`` [rad] about the unit vector ``axis`` (Rodrigues), (3, 3)."""
    k = np.asarray(axis, dtype=float)
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * Kx + (1 - math.cos(angle)) * (Kx @ Kx)


def camera_pose(config: Config) -> CameraPose:
    r"""Where the twin's camera stands, how it is turned and its field of view.

    Unconfigured (``twin.camera`` null): over the calibrated field's centre at
    :data:`~mearm.sim.mjcf.CAMERA_HEIGHT_M`, yawed by the homography's yaw, with
    :math:`\mathrm{fovy} = 2\arctan(e/2h)` for the field's extent e along the image's v.
    Configured: the straight-down camera over ``target_cm`` at ``height_cm``, yawed by
    ``yaw_deg``, is tilted by ``tilt_deg`` about the horizontal axis across
    ``tilt_direction_deg`` and moved so that its axis still meets the target.

    Raises:
        ModelError: the homography mirrors the image (no camera looking down sees that).
    """
    cam = config.twin.camera
    if cam is None:
        centre, yaw, extent = homography_view(config)
        height = CAMERA_HEIGHT_M
        fovy = 2 * math.degrees(math.atan(extent / 2 / height))
        R = np.array(
            [[math.cos(yaw), -math.sin(yaw), 0.0], [math.sin(yaw), math.cos(yaw), 0.0], [0, 0, 1]]
        )
        return CameraPose(np.array([centre[0], centre[1], height]), R, fovy)
    height = cam.height_cm * M_PER_CM
    needs_field = cam.target_cm is None or cam.yaw_deg is None or cam.fovy_deg is None
    field = homography_view(config) if needs_field else None
    if cam.target_cm is not None:
        target = np.array(cam.target_cm, dtype=float) * M_PER_CM
    else:
        assert field is not None
        target = field[0]
    if cam.yaw_deg is not None:
        yaw = math.radians(cam.yaw_deg)
    else:
        assert field is not None
        yaw = field[1]
    if cam.fovy_deg is not None:
        fovy = cam.fovy_deg
    else:
        assert field is not None
        fovy = 2 * math.degrees(math.atan(field[2] / 2 / height))
    R0 = np.array(
        [[math.cos(yaw), -math.sin(yaw), 0.0], [math.sin(yaw), math.cos(yaw), 0.0], [0, 0, 1]]
    )
    tilt, azimuth = math.radians(cam.tilt_deg), math.radians(cam.tilt_direction_deg)
    look = np.array([math.cos(azimuth), math.sin(azimuth), 0.0])  # horizontal
    # tilting the view from −z towards ``look`` turns about (−z) × look
    R = _rot(np.cross([0.0, 0.0, -1.0], look), tilt) @ R0
    forward = -R[:, 2]
    centre = np.array([target[0], target[1], 0.0]) - forward * (height / math.cos(tilt))
    return CameraPose(centre, R, fovy)


def twin_camera_model(config: Config) -> TwinCameraModel:
    """The twin's camera as ground truth in OpenCV's terms (see the module docstring).

    For scoring a calibration only: the software under test must never read it.

    Raises:
        ModelError: the homography mirrors the image (see :func:`camera_pose`).
    """
    pose = camera_pose(config)
    w, h = config.camera.width_px, config.camera.height_px
    f = (h / 2) / math.tan(math.radians(pose.fovy_deg) / 2)
    K = np.array([[f, 0.0, (w - 1) / 2], [0.0, f, (h - 1) / 2], [0.0, 0.0, 1.0]])
    cam = config.twin.camera
    dist = np.array(cam.distortion if cam is not None else (0.0,) * 5, dtype=float)
    R_base_cam = pose.R_base_mj @ np.diag([1.0, -1.0, -1.0])
    return TwinCameraModel(K, dist, R_base_cam, pose.centre_m / M_PER_CM)


class LensRenderer:
    """Renders the twin's camera through its lens: ideal pinhole, then distortion.

    Args:
        model: The twin's model (it is not changed: a distorting lens renders from a copy
            whose camera sees a margin more).
        config: The whole config (frame size, ``twin.camera``'s lens).
        camera: The camera's name in ``model``.
        option: What to draw (geom groups, …); ``None``: MuJoCo's defaults.

    Raises:
        CameraError: no offscreen OpenGL context could be made, or the distortion has no
            inverse over the frame (it folds over).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        config: Config,
        camera: str = CAMERA_NAME,
        option: mujoco.MjvOption | None = None,
    ):
        self.camera = camera
        self.option = option
        w, h = config.camera.width_px, config.camera.height_px
        self.size_px = (w, h)
        truth = twin_camera_model(config)
        self._maps: tuple[np.ndarray, np.ndarray] | None = None
        render_model, rw, rh = model, w, h
        if np.any(truth.dist != 0):
            map_x, map_y, mx, my = _lens_maps(truth.K, truth.dist, (w, h))
            self._maps = (map_x, map_y)
            rw, rh = w + 2 * mx, h + 2 * my
            render_model = copy.copy(model)
            cam_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
            fy = truth.K[1, 1]
            render_model.cam_fovy[cam_id] = 2 * math.degrees(math.atan(rh / 2 / fy))
            render_model.vis.global_.offwidth = max(rw, model.vis.global_.offwidth)
            render_model.vis.global_.offheight = max(rh, model.vis.global_.offheight)
        self._model = render_model
        try:
            self._renderer = mujoco.Renderer(render_model, rh, rw)
        except Exception as exc:  # MuJoCo raises plain errors for a missing GL
            raise CameraError(
                "twin",
                f"cannot render offscreen ({type(exc).__name__}: {exc}); install Mesa's EGL "
                "or OSMesa and set MUJOCO_GL=egl or MUJOCO_GL=osmesa",
            ) from None

    def render(self, data: mujoco.MjData) -> np.ndarray:
        """The camera's frame of ``data``'s state, (h, w, 3) uint8 BGR."""
        self._renderer.update_scene(data, camera=self.camera, scene_option=self.option)
        bgr = np.ascontiguousarray(self._renderer.render()[:, :, ::-1])
        if self._maps is None:
            return bgr
        return cv2.remap(bgr, *self._maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)

    def close(self) -> None:
        """Free the renderer's GL context."""
        self._renderer.close()


def _lens_maps(
    K: np.ndarray, dist: np.ndarray, size_px: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray, int, int]:
    """Remap tables from an ideal picture with margins (mx, my) to the distorted frame.

    Returns:
        map_x, map_y: for each output (distorted) pixel, where it is in the ideal
        picture rendered with ``mx``, ``my`` extra pixels on each side, (h, w) float32
        [px]; and mx, my [px].

    Raises:
        CameraError: the distortion folds over inside the frame (no inverse).
    """
    w, h = size_px
    u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    p_d = np.stack([u.ravel(), v.ravel()], axis=1).reshape(-1, 1, 2)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    p_u = cv2.undistortPoints(p_d, K, dist, R=np.eye(3), P=K, criteria=criteria).reshape(-1, 2)
    # check the inverse: distorting p_u again must give p_d back
    rays = np.concatenate([(p_u - K[:2, 2]) / np.diag(K)[:2], np.ones((len(p_u), 1))], axis=1)
    back, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), K, dist)
    err = float(np.max(np.abs(back.reshape(-1, 2) - p_d.reshape(-1, 2))))
    if not err <= LENS_INVERSE_TOL_PX:
        raise CameraError(
            "twin",
            f"twin.camera.distortion {tuple(float(d) for d in dist)} folds the frame over "
            f"(no inverse within {LENS_INVERSE_TOL_PX} px; off by {err:.3g} px): use smaller "
            "coefficients",
        )
    mx = math.ceil(max(0.0, -p_u[:, 0].min(), p_u[:, 0].max() - (w - 1))) + 2
    my = math.ceil(max(0.0, -p_u[:, 1].min(), p_u[:, 1].max() - (h - 1))) + 2
    if w + 2 * mx > MAX_LENS_MARGIN_FACTOR * w or h + 2 * my > MAX_LENS_MARGIN_FACTOR * h:
        raise CameraError(
            "twin",
            f"twin.camera.distortion {tuple(float(d) for d in dist)} bends points from "
            f"{mx} px beyond the frame's side into view (more than "
            f"{MAX_LENS_MARGIN_FACTOR:g}x the frame): use smaller coefficients",
        )
    map_x = (p_u[:, 0] + mx).reshape(h, w).astype(np.float32)
    map_y = (p_u[:, 1] + my).reshape(h, w).astype(np.float32)
    return map_x, map_y, mx, my


class TwinCamera(Camera):
    """Frames rendered from the twin's camera, at ``camera.width_px × height_px``.

    With ``twin.camera.distortion`` set, each frame goes through the lens
    (:class:`LensRenderer`).

    Args:
        config: The whole config (``camera`` gives the frame size, ``twin.camera`` the lens).
        twin: The twin whose state is rendered (its ``model`` and ``data``).

    Raises:
        CameraError: no offscreen OpenGL context could be made (install Mesa's EGL or
            OSMesa, and set ``MUJOCO_GL=egl`` or ``osmesa``), or the lens distortion has
            no inverse over the frame.
    """

    def __init__(self, config: Config, twin: TwinArm):
        cam = config.camera
        super().__init__("twin", (cam.width_px, cam.height_px))
        self.twin = twin
        self._lens = LensRenderer(twin.model, config)
        self.frames_read = 0

    def _read(self) -> np.ndarray:
        frame = self._lens.render(self.twin.data)
        self.frames_read += 1
        return frame

    def close(self) -> None:  # noqa: D102
        if not self._closed:
            self._lens.close()
        super().close()
