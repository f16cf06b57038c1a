"""Where the twin's camera is and what its pinhole is: geometry, no rendering.

:func:`camera_pose` puts the camera straight down from :data:`CAMERA_HEIGHT_M` over the
calibrated field's centre (yawed, with the field of view that make
``calibration.homography`` hold on the table), or wherever ``twin.camera`` says;
:func:`twin_camera_model` is that camera in OpenCV's terms. Both the twin's MJCF
(:mod:`mearm.sim.twin.mjcf`) and its renderer (:mod:`mearm.sim.twin.twin_camera`) read it.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from mearm.config import Config
from mearm.kinematics.bodies import M_PER_CM
from mearm.kinematics.errors import ModelError

#: The default camera's height above the table: "about 52 cm" (docs/paper.md §1) [m].
CAMERA_HEIGHT_M = 0.52


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
    :data:`~mearm.sim.twin.mjcf.CAMERA_HEIGHT_M`, yawed by the homography's yaw, with
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


__all__ = [
    "CAMERA_HEIGHT_M",
    "CameraPose",
    "TwinCameraModel",
    "camera_pose",
    "homography_view",
    "twin_camera_model",
]
