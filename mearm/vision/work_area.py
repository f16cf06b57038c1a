"""The work area: by default the calibrated table's outline; a given one, fitted to a frame.

Objects can only be on the table. The table the rig was calibrated on is the
calibrated field (the frame's corners mapped by the calibration's ``homography`` onto the
table, as the twin builds its table) and the classes' bins beside it; with a perspective
calibration its outline is those corners on the table plane projected into the frame
(:meth:`~mearm.vision.pinhole.PerspectiveCamera.table_to_pixel`), their convex hull
clipped to the frame. Outside it lie the arm's base, the room and the table's edge.

A polygon given in ``vision.work_area_px`` is in the pixels of the frames it was drawn
on; on frames of another size (a config taught on a photo, used on the camera) it may
leave out most of the frame or all of it: :func:`check_work_area` says so. A polygon
whose points lie on one line holds no object in any frame: refused
(:func:`flat_work_area`), by every command that takes one, and by the config as it loads.
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np
import numpy.typing as npt

from mearm.config import CalibrationConfig, CameraConfig, ColorClass, VisionConfig
from mearm.config.polygon import enclosed_px2, extent, why_flat
from mearm.errors import ConfigError
from mearm.kinematics.bodies import bin_half_outer_m
from mearm.kinematics.chain import M_PER_CM
from mearm.vision.calibration import CameraGeometry
from mearm.vision.learned import area_mask
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


#: A work area leaving out more than this share of a frame, with more than this share of
#: its own area outside the frame, was drawn on frames of another size (a small table
#: seen whole lies inside the frame; a polygon reaching past the frame to take in its
#: edges covers nearly all of it).
DRAWN_ELSEWHERE_SHARE = 0.5


def pixels_inside(polygon_px: Sequence[tuple[float, float]], size_px: tuple[int, int]) -> int:
    """How many pixels of a frame of ``size_px`` (width, height) the polygon keeps."""
    w, h = size_px
    return int(cv2.countNonZero(area_mask(polygon_px, (h, w))))


#: What a user can do about a ``vision.work_area_px`` with no pixel in a frame.
OTHER_SIZE_ADVICE = (
    "it was drawn on frames of another size? teach the colours again on these frames "
    "(mearm learn-colours), or give a polygon in their pixels or whole_frame"
)


def flat_work_area(
    polygon_px: Sequence[tuple[float, float]], name: str = "vision.work_area_px"
) -> str | None:
    """Why a work-area polygon can hold no object whatever the frame, or ``None``.

    Its points on one line enclose no area: the only pixels it keeps are those the line
    crosses, so nothing is ever detected. ``mearm learn-colours --work-area``,
    ``mearm detect`` and ``mearm sort`` refuse it through this one check, so no command
    accepts a polygon another refuses.

    Args:
        polygon_px: The polygon (u, v) [px].
        name: How the user gave it, for the message (``--work-area``).
    """
    why = why_flat(polygon_px)
    return None if why is None else f"{name} {why}"


def check_work_area(
    polygon_px: Sequence[tuple[float, float]],
    size_px: tuple[int, int],
    frame: str,
    *,
    name: str = "vision.work_area_px",
    advice: str = OTHER_SIZE_ADVICE,
) -> str | None:
    """How a work-area polygon fits a frame: a warning line, or ``None`` when it fits.

    A polygon enclosing no area (:func:`flat_work_area`) is refused whatever the frame.
    The frame's pixels inside the polygon are the ones detection keeps
    (:func:`~mearm.vision.learned.area_mask`). None of them: nothing can ever be detected
    in such frames, so the polygon is refused. Under :data:`DRAWN_ELSEWHERE_SHARE` of the
    frame while most of the polygon lies outside it: the polygon was drawn on frames of
    another size, and objects in the rest of the frame are never seen; a warning.

    Args:
        polygon_px: ``vision.work_area_px``.
        size_px: The frame's (width, height) [px].
        frame: The frame, for messages (an image's path, ``camera``).
        name: How the user gave the polygon, for messages (``--work-area``).
        advice: What to do about a polygon with no pixel in the frame.

    Raises:
        ConfigError: the polygon encloses no area, or no pixel of the frame lies in it.
    """
    flat = flat_work_area(polygon_px, name)
    if flat is not None:
        raise ConfigError(None, [flat])
    w, h = size_px
    inside = pixels_inside(polygon_px, size_px)
    where = f"{name} ({extent(polygon_px)}) "
    if inside == 0:
        raise ConfigError(
            None,
            [
                f"{where}has no pixel in {frame}'s {w}x{h} px frame, so nothing can be "
                f"detected there: {advice}"
            ],
        )
    covered = inside / (w * h)
    own = max(enclosed_px2(polygon_px), 1.0)
    if covered < DRAWN_ELSEWHERE_SHARE and inside / own < DRAWN_ELSEWHERE_SHARE:
        return (
            f"{where}covers {covered:.0%} of {frame}'s {w}x{h} px frame and lies mostly "
            "outside it (drawn on frames of another size?): objects elsewhere in the frame "
            "are never detected"
        )
    return None
