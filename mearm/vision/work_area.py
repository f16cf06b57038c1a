"""The work area by default: the calibrated table's outline seen by a calibrated camera.

Objects can only be on the table. The table the rig was calibrated on is the
calibrated field (the frame's corners mapped by the calibration's ``homography`` onto the
table, as the twin builds its table) and the classes' bins beside it; with a perspective
calibration its outline is those corners on the table plane projected into the frame
(:meth:`~mearm.vision.pinhole.PerspectiveCamera.table_to_pixel`), their convex hull
clipped to the frame. Outside it lie the arm's base, the room and the table's edge.
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np
import numpy.typing as npt

from mearm.config import CalibrationConfig, CameraConfig, ColorClass, VisionConfig
from mearm.kinematics.bodies import bin_half_outer_m
from mearm.kinematics.chain import M_PER_CM
from mearm.vision.calibration import CameraGeometry
from mearm.vision.pinhole import PerspectiveCamera


def table_corners_cm(
    calibration: CalibrationConfig, camera: CameraConfig, classes: Sequence[ColorClass]
) -> np.ndarray:
    """The calibrated field's corners and each bin's outer corners on the table, (N, 2) [cm]."""
    H = np.asarray(calibration.homography, dtype=float)
    w, h = camera.width_px, camera.height_px
    frame = np.array([[0, 0, 1], [w, 0, 1], [w, h, 1], [0, h, 1]], dtype=float)
    xyw = frame @ H.T
    points = [xyw[:, :2] / xyw[:, 2:]]
    for c in classes:
        half = bin_half_outer_m(c) / M_PER_CM
        x, y = c.bin_cm[0], c.bin_cm[1]
        points.append(np.array([[x - half, y - half], [x + half, y - half],
                                [x + half, y + half], [x - half, y + half]]))  # fmt: skip
    return np.concatenate(points)


def outline_px(
    camera: PerspectiveCamera, table_cm: npt.ArrayLike, size_px: tuple[int, int]
) -> list[tuple[float, float]] | None:
    """The convex hull of table points (z = 0) in the frame, clipped to it; ``None``: not seen.

    Args:
        camera: The calibrated camera.
        table_cm: Points on the table, (N, 2) [cm].
        size_px: The frame's (width, height) [px].
    """
    px = np.asarray(camera.table_to_pixel(np.asarray(table_cm, dtype=float)), dtype=np.float32)
    hull = cv2.convexHull(px.reshape(-1, 1, 2))
    w, h = size_px
    frame = np.array([[0, 0], [w, 0], [w, h], [0, h]], np.float32).reshape(-1, 1, 2)
    area, inside = cv2.intersectConvexConvex(hull, frame)
    if inside is None or area <= 0 or len(inside) < 3:
        return None
    return [(float(u), float(v)) for u, v in inside.reshape(-1, 2)[:64]]


def default_work_area(
    vision: VisionConfig,
    geometry: CameraGeometry,
    calibration: CalibrationConfig,
    camera: CameraConfig,
    classes: Sequence[ColorClass],
) -> list[tuple[float, float]] | None:
    """The work area a detector uses when the config gives none: the table's outline.

    Only with a perspective calibration (a homography's field is the whole frame); ``None``
    when ``vision.work_area_px`` is given (the user's polygon rules) or there is none.
    """
    if vision.work_area_px is not None or not isinstance(geometry, PerspectiveCamera):
        return None
    corners = table_corners_cm(calibration, camera, classes)
    return outline_px(geometry, corners, (camera.width_px, camera.height_px))
