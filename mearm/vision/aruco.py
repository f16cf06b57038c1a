"""ArUco markers for calibration: find them, draw them, print them (paper §4).

A marker lies flat on the table with its top edge towards +y of the base frame. Its
centre is the intersection of its image diagonals (exact under any homography, unlike
the mean of the corners). Given the table position of each marker's centre — and, if
its printed side is given, its four corners too — :func:`calibration_from_markers`
fits the pixel → table homography.
"""

from __future__ import annotations

from collections.abc import Mapping

import cv2
import numpy as np
import numpy.typing as npt

from mearm.exceptions import CalibrationError
from mearm.vision.calibration import Calibration

DEFAULT_DICTIONARY = "DICT_4X4_50"


def get_dictionary(name: str = DEFAULT_DICTIONARY) -> cv2.aruco.Dictionary:
    """The predefined ArUco dictionary ``name`` (e.g. ``"DICT_4X4_50"``).

    Raises:
        CalibrationError: no such dictionary.
    """
    choices = sorted(n for n in dir(cv2.aruco) if n.startswith("DICT_"))
    if name not in choices:
        raise CalibrationError(f"unknown ArUco dictionary {name!r}; choose from {choices}")
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))


def marker_image(marker_id: int, side_px: int, dictionary: str = DEFAULT_DICTIONARY) -> np.ndarray:
    """The marker ``marker_id`` as a (side_px, side_px) uint8 image (black on white)."""
    d = get_dictionary(dictionary)
    n = len(d.bytesList)
    if not 0 <= marker_id < n:
        raise CalibrationError(f"marker id {marker_id} is not in {dictionary} (ids 0..{n - 1})")
    return cv2.aruco.generateImageMarker(d, marker_id, side_px)


def table_corners_cm(center_cm: npt.ArrayLike, side_cm: float) -> np.ndarray:
    """Table positions of a marker's corners in OpenCV's order (TL, TR, BR, BL), (4, 2) [cm].

    The marker's top edge faces +y.
    """
    x, y = np.asarray(center_cm, dtype=float)
    h = side_cm / 2.0
    return np.array([[x - h, y + h], [x + h, y + h], [x + h, y - h], [x - h, y - h]])


def diagonal_center(corners_px: npt.ArrayLike) -> np.ndarray:
    """Intersection of the diagonals TL–BR and TR–BL of a quadrilateral, (2,) [px]."""
    c = np.asarray(corners_px, dtype=float).reshape(4, 2)
    p, r = c[0], c[2] - c[0]
    q, s = c[1], c[3] - c[1]
    denom = r[0] * s[1] - r[1] * s[0]
    if abs(denom) < 1e-12:
        return c.mean(axis=0)
    t = ((q[0] - p[0]) * s[1] - (q[1] - p[1]) * s[0]) / denom
    return p + t * r


def detect_markers(
    frame_bgr: np.ndarray, dictionary: str = DEFAULT_DICTIONARY
) -> dict[int, np.ndarray]:
    """Markers found in a frame: id → its 4 corners (TL, TR, BR, BL), (4, 2) [px].

    Raises:
        CalibrationError: the same id appears more than once.
    """
    params = cv2.aruco.DetectorParameters()
    # Sub-pixel corners; and keep a marker whose white margin is close to its border
    # (the default rate drops the inner square when the sheet's edge is near).
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    params.minMarkerDistanceRate = 0.02
    detector = cv2.aruco.ArucoDetector(get_dictionary(dictionary), params)
    corners, ids, _ = detector.detectMarkers(frame_bgr)
    found: dict[int, np.ndarray] = {}
    for c, i in zip(corners, [] if ids is None else ids.ravel(), strict=False):
        if int(i) in found:
            raise CalibrationError(f"marker {int(i)} appears twice in the image: use each id once")
        found[int(i)] = np.asarray(c, dtype=float).reshape(4, 2)
    return found


def calibration_from_markers(
    frame_bgr: np.ndarray,
    centers_cm: Mapping[int, tuple[float, float]],
    *,
    side_cm: float | None = None,
    dictionary: str = DEFAULT_DICTIONARY,
) -> Calibration:
    """Fit the calibration to ArUco markers at known table positions.

    Args:
        frame_bgr: The camera's view of the table with the markers, (H, W, 3) uint8.
        centers_cm: Marker id → table position (x, y) of its centre [cm].
        side_cm: Printed side of the markers [cm]; when given, their corners are used
            too (4 more pairs per marker, and a reprojection error that means something).
        dictionary: ArUco dictionary name.

    Raises:
        CalibrationError: a marker is missing from the image, or the points are degenerate.
    """
    found = detect_markers(frame_bgr, dictionary)
    missing = sorted(set(centers_cm) - set(found))
    if missing:
        raise CalibrationError(
            f"markers {missing} not found in the image (found {sorted(found)}): check the "
            "lighting, that each marker is flat, whole and in view, and --dictionary"
        )
    pixels, table = [], []
    for marker_id, center in sorted(centers_cm.items()):
        corners = found[marker_id]
        pixels.append(diagonal_center(corners))
        table.append(np.asarray(center, dtype=float))
        if side_cm is not None:
            pixels.extend(corners)
            table.extend(table_corners_cm(center, side_cm))
    return Calibration.fit(np.array(pixels), np.array(table))


def draw_marker_on_table(
    frame_bgr: np.ndarray,
    calibration: Calibration,
    marker_id: int,
    center_cm: tuple[float, float],
    side_cm: float,
    dictionary: str = DEFAULT_DICTIONARY,
) -> None:
    """Draw a printed marker (with a white margin) lying on the table into ``frame_bgr``.

    For tests and the simulator: the marker goes where the calibration puts it.
    """
    modules = get_dictionary(dictionary).markerSize + 2  # data bits + black border
    side_px = 40 * modules
    margin = 80  # two modules of white paper around the marker
    sheet = np.full((side_px + 2 * margin, side_px + 2 * margin), 255, np.uint8)
    sheet[margin:-margin, margin:-margin] = marker_image(marker_id, side_px, dictionary)
    full = side_cm * (side_px + 2 * margin) / side_px
    src = np.array(
        [[0, 0], [sheet.shape[1], 0], [sheet.shape[1], sheet.shape[0]], [0, sheet.shape[0]]]
    )
    dst = calibration.table_to_pixel(table_corners_cm(center_cm, full))  # pixel centres
    M = cv2.getPerspectiveTransform(src.astype(np.float32) - 0.5, dst.astype(np.float32))
    h, w = frame_bgr.shape[:2]
    warped = cv2.warpPerspective(sheet, M, (w, h), flags=cv2.INTER_LINEAR, borderValue=0)
    cover = cv2.warpPerspective(np.full_like(sheet, 255), M, (w, h), flags=cv2.INTER_LINEAR)
    alpha = (cover.astype(np.float32) / 255.0)[..., None]
    mixed = alpha * cv2.cvtColor(warped, cv2.COLOR_GRAY2BGR) + (1 - alpha) * frame_bgr
    frame_bgr[...] = np.clip(np.rint(mixed), 0, 255).astype(np.uint8)
