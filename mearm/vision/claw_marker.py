r"""The claw's marker as the calibrated camera sees it: its corners and its pose in the base frame.

An ArUco marker on the tool (``arm.tool.marker``, :class:`~mearm.config.ClawMarker`) is
found in a frame (:func:`~mearm.vision.aruco.detect_markers`: corners refined to a tenth
of a pixel on straight edges), and its pose follows from its printed side and the
camera's calibration: IPPE for a square (OpenCV's ``SOLVEPNP_IPPE_SQUARE``) on the
undistorted corners gives the marker in the camera's frame, and the camera's pose
(:class:`~mearm.vision.pinhole.PerspectiveCamera`) puts it in the base frame,

.. math:: p_{base} = R_{cb}\, t_{cam} + C .

A perspective calibration is needed: the paper's table homography maps pixels to the
table's plane only, and the marker rides 10–30 cm above it.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from mearm.config import ClawMarker
from mearm.config.errors import CalibrationError
from mearm.vision.aruco import detect_markers, get_dictionary
from mearm.vision.pinhole import PerspectiveCamera


@dataclass(frozen=True)
class MarkerSighting:
    """One sighting of the claw's marker.

    Attributes:
        corners_px: Its corners in the frame (TL, TR, BR, BL), (4, 2) [px].
        centre_cm: Its centre in the base frame [cm], (3,).
        rotation: Its frame's axes in the base frame (x right, y to its top edge, z out of
            its face), (3, 3).
        rms_px: The pose's reprojection error of the corners [px].
    """

    corners_px: np.ndarray
    centre_cm: np.ndarray
    rotation: np.ndarray
    rms_px: float


def square_corners(side_cm: float) -> np.ndarray:
    """A square's corners in its own frame, OpenCV's order (TL, TR, BR, BL), (4, 3) [cm]."""
    h = side_cm / 2.0
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])


def check_marker(marker: ClawMarker) -> None:
    """Raise if the marker's dictionary is unknown or its id is not in it.

    Raises:
        CalibrationError: naming the dictionary and the ids it has.
    """
    try:
        n = len(get_dictionary(marker.dictionary).bytesList)
    except CalibrationError as exc:
        raise CalibrationError(f"arm.tool.marker.dictionary: {exc}") from None
    if marker.id >= n:
        raise CalibrationError(
            f"arm.tool.marker.id: {marker.id} is not in {marker.dictionary} (ids 0..{n - 1})"
        )


def find_claw_marker(
    frame_bgr: np.ndarray, marker: ClawMarker, camera: PerspectiveCamera
) -> MarkerSighting | None:
    """The claw marker in a frame, or ``None`` when it is not in view.

    Raises:
        CalibrationError: the marker's id appears at two places (another print of it lies
            in view).
    """
    found = detect_markers(frame_bgr, marker.dictionary)
    if marker.id not in found:
        return None
    return marker_pose(found[marker.id], marker.size_cm, camera)


def marker_pose(
    corners_px: npt.ArrayLike, side_cm: float, camera: PerspectiveCamera
) -> MarkerSighting:
    """The pose of a square marker of side ``side_cm`` whose corners are seen at ``corners_px``."""
    px = np.asarray(corners_px, dtype=float).reshape(4, 2)
    obj = square_corners(side_cm)
    xn = camera.intrinsics.undistort(px)
    ok, rvec, tvec = cv2.solvePnP(obj, xn, np.eye(3), np.zeros(5), flags=cv2.SOLVEPNP_IPPE_SQUARE)
    if not ok:  # pragma: no cover - IPPE answers for any four points of a square's image
        raise CalibrationError("no pose of the claw marker fits its corners")
    R_cm, _ = cv2.Rodrigues(rvec)
    R_cb = camera.extrinsics.rotation
    centre = R_cb @ tvec.ravel() + camera.centre_cm
    proj = camera.project(obj @ (R_cb @ R_cm).T + centre)
    rms = float(np.sqrt(np.mean(np.sum((proj - px) ** 2, axis=1))))
    return MarkerSighting(px, centre, R_cb @ R_cm, rms)
