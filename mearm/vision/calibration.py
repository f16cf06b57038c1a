r"""Camera → table calibration: a plane homography, pixels ↔ base-frame cm (paper §4).

A pixel (u, v) maps to the table point (x, y) [cm] in the robot base frame through

.. math::

    \begin{bmatrix} x w \\ y w \\ w \end{bmatrix} = H \begin{bmatrix} u \\ v \\ 1 \end{bmatrix}

The paper's rig is the affine special case x = 0.0625·u − 20.5, y = 59.0 − 0.0625·v
(``configs/lab.yaml``). A general H is fitted from four or more pixel ↔ table pairs with
``cv2.findHomography`` (least squares over all pairs); the pairs must span the plane:
at least four, none repeated, and not all on one line (exactly four: no three on one
line), else :class:`~mearm.config.errors.CalibrationError`.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from mearm.config import CalibrationConfig, CameraConfig
from mearm.config.base import short_repr
from mearm.config.errors import CalibrationError
from mearm.errors import MearmError
from mearm.vision.pinhole import PerspectiveCamera

#: Twice a triangle's area over its longest side squared below this is "on one line"
#: (≈ 0.6° of bend at the middle point).
COLLINEAR_RATIO = 1e-2


def _points(name: str, pts: npt.ArrayLike) -> np.ndarray:
    try:
        arr = np.asarray(pts, dtype=float)
    except (TypeError, ValueError):
        raise CalibrationError(f"{name} points must be numbers, got {short_repr(pts)}") from None
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise CalibrationError(f"{name} points must have shape (N, 2), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise CalibrationError(f"{name} points must be finite, got {short_repr(arr.tolist())}")
    return arr


def check_point_set(name: str, pts: np.ndarray) -> None:
    """Raise :class:`CalibrationError` if ``pts`` (N, 2) cannot anchor a homography."""
    n = len(pts)
    if n < 4:
        raise CalibrationError(
            f"a homography needs at least 4 point pairs, got {n}: add points spread over "
            "the field (e.g. its four corners)"
        )
    span = float(np.ptp(pts, axis=0).max())
    for i, j in itertools.combinations(range(n), 2):
        if np.linalg.norm(pts[i] - pts[j]) <= 1e-9 * max(span, 1.0):
            raise CalibrationError(
                f"{name} points {i} and {j} are the same point {tuple(pts[i].tolist())}: "
                "each pair must be a different place on the table"
            )
    centred = pts - pts.mean(axis=0)
    sv = np.linalg.svd(centred, compute_uv=False)
    if sv[1] <= COLLINEAR_RATIO * sv[0]:
        raise CalibrationError(
            f"all {n} {name} points lie on one line: a plane needs points off that line"
        )
    if n == 4:
        for tri in itertools.combinations(range(4), 3):
            a, b, c = pts[list(tri)]
            area2 = abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
            longest = max(np.sum((b - a) ** 2), np.sum((c - b) ** 2), np.sum((a - c) ** 2))
            if area2 <= COLLINEAR_RATIO * longest:
                raise CalibrationError(
                    f"{name} points {tri} lie on one line; with 4 pairs no three may: "
                    "move one point or add more"
                )


def _apply(H: np.ndarray, pts: np.ndarray) -> np.ndarray:
    w = pts @ H[2, :2] + H[2, 2]
    return (pts @ H[:2, :2].T + H[:2, 2]) / w[:, None]


@dataclass(frozen=True)
class Calibration:
    """A pixel → table homography and its inverse.

    Attributes:
        H: Pixel (u, v, 1) → table (x, y, 1) [cm], (3, 3), normalised so H[2, 2] = 1.
        reprojection_error_cm: RMS distance between the fitted and the given table points
            [cm], when fitted from points or recorded in the config; else ``None``.
        max_error_cm: The largest such distance [cm], when fitted; else ``None``.
    """

    H: np.ndarray
    reprojection_error_cm: float | None = None
    max_error_cm: float | None = None

    def __post_init__(self) -> None:
        H = np.array(self.H, dtype=float)
        if H.shape != (3, 3) or not np.all(np.isfinite(H)):
            raise CalibrationError(
                f"homography must be a finite 3x3 matrix, got {short_repr(H.tolist())}"
            )
        if abs(H[2, 2]) > 1e-12:
            H = H / H[2, 2]
        if abs(np.linalg.det(H)) < 1e-12:
            raise CalibrationError("homography is singular (determinant 0): recalibrate")
        H.setflags(write=False)
        H_inv = np.linalg.inv(H)
        H_inv.setflags(write=False)
        object.__setattr__(self, "H", H)
        object.__setattr__(self, "_H_inv", H_inv)
        object.__setattr__(self, "_abs_det", abs(float(np.linalg.det(H))))

    @classmethod
    def from_config(cls, config: CalibrationConfig) -> Calibration:
        """The calibration a config carries (``calibration`` section)."""
        return cls(np.array(config.homography, dtype=float), config.reprojection_error_cm)

    @classmethod
    def fit(cls, pixels_px: npt.ArrayLike, table_cm: npt.ArrayLike) -> Calibration:
        """Fit H to N ≥ 4 pixel ↔ table pairs (least squares over all of them).

        Args:
            pixels_px: Image points (u, v) [px], (N, 2).
            table_cm: The same points on the table (x, y), base frame [cm], (N, 2).

        Raises:
            CalibrationError: shapes differ, fewer than 4 pairs, a repeated point, points
                on one line, or no homography fits.
        """
        px = _points("pixel", pixels_px)
        cm = _points("table", table_cm)
        if len(px) != len(cm):
            raise CalibrationError(
                f"got {len(px)} pixel points but {len(cm)} table points: give them in pairs"
            )
        check_point_set("pixel", px)
        check_point_set("table", cm)
        H, _ = cv2.findHomography(px, cm, method=0)
        if H is None or not np.all(np.isfinite(H)):
            raise CalibrationError("no homography fits these points: check the pairs")
        w = px @ H[2, :2] + H[2, 2]
        if not (np.all(w > 0) or np.all(w < 0)):
            raise CalibrationError(
                "the fitted homography puts the horizon between the points: the pairs are "
                "inconsistent (swapped or mirrored points?)"
            )
        residual = np.linalg.norm(_apply(H, px) - cm, axis=1)
        return cls(
            H,
            reprojection_error_cm=float(np.sqrt(np.mean(residual**2))),
            max_error_cm=float(residual.max()),
        )

    def pixel_to_table(self, pixels_px: npt.ArrayLike) -> np.ndarray:
        """Table points (x, y) [cm] of image points (u, v) [px]; (N, 2) → (N, 2), (2,) → (2,)."""
        px = np.asarray(pixels_px, dtype=float)
        return _apply(self.H, px.reshape(-1, 2)).reshape(px.shape)

    def table_to_pixel(self, table_cm: npt.ArrayLike) -> np.ndarray:
        """Image points (u, v) [px] of table points (x, y) [cm]; (N, 2) → (N, 2), (2,) → (2,)."""
        cm = np.asarray(table_cm, dtype=float)
        return _apply(self._H_inv, cm.reshape(-1, 2)).reshape(cm.shape)  # type: ignore[attr-defined]

    def pixel_area_cm2(self, pixels_px: npt.ArrayLike) -> np.ndarray:
        r"""Table area one pixel covers at each image point [cm²], (N,).

        The Jacobian determinant of the map: :math:`|\det H| / w^3` with
        :math:`w = h_{31} u + h_{32} v + h_{33}`.
        """
        px = np.asarray(pixels_px, dtype=float).reshape(-1, 2)
        w = px @ self.H[2, :2] + self.H[2, 2]
        return self._abs_det / np.abs(w) ** 3  # type: ignore[attr-defined]

    def expected_disc_area_px(
        self, pixels_px: npt.ArrayLike, diameter_cm: npt.ArrayLike
    ) -> np.ndarray:
        """Image area [px] of a disc centred at each image point, (N,).

        Args:
            pixels_px: Disc centres (u, v) [px], (N, 2) or (2,).
            diameter_cm: The discs' diameter [cm]: one for all, or one per centre (N,).
        """
        radius_cm = np.asarray(diameter_cm, dtype=float) / 2.0
        return math.pi * radius_cm**2 / self.pixel_area_cm2(pixels_px)

    def to_config(self) -> CalibrationConfig:
        """This calibration as the ``calibration`` section of a config."""
        rows = tuple(tuple(float(v) for v in row) for row in self.H)
        return CalibrationConfig(
            homography=rows,  # type: ignore[arg-type]
            reprojection_error_cm=self.reprojection_error_cm,
        )


#: What maps pixels to the base frame: the paper's plane homography or a calibrated camera.
CameraGeometry = Calibration | PerspectiveCamera


def camera_geometry(calibration: CalibrationConfig, camera: CameraConfig) -> CameraGeometry:
    """The pixel ↔ base-frame model a ``calibration`` section selects.

    Args:
        calibration: The config's ``calibration`` section.
        camera: The config's ``camera`` section (the frames' size a perspective
            calibration must have been made at).

    Raises:
        CalibrationError: a perspective calibration's files cannot be read, or do not
            belong together or to the configured frame size.
    """
    cal = calibration
    if cal.model == "homography":
        return Calibration.from_config(cal)
    assert cal.intrinsics_file is not None and cal.extrinsics_file is not None
    found = PerspectiveCamera.from_files(cal.intrinsics_file, cal.extrinsics_file)
    size = (camera.width_px, camera.height_px)
    if found.size_px != size:
        raise CalibrationError(
            f"{cal.intrinsics_file}: calibrated at {found.size_px[0]}x{found.size_px[1]} px "
            f"but camera frames are {size[0]}x{size[1]} px: recalibrate at this size or "
            "change camera.width_px/height_px"
        )
    return found


#: One object's width where the calibration cannot say [px]: 2 cm under the paper's.
DEFAULT_OBJECT_PX = 32.0


def object_width_px(
    calibration: CalibrationConfig,
    camera: CameraConfig,
    diameter_cm: float,
    shape: Sequence[int] | None = None,
) -> float:
    """About one object's width [px] at the frame's centre, through the calibration.

    Args:
        calibration: The config's ``calibration`` section.
        camera: The config's ``camera`` section.
        diameter_cm: The object's diameter [cm].
        shape: The frame's (height, width, ...); the camera's frame when ``None``.

    Returns:
        The width of a disc of ``diameter_cm`` at the frame's centre, or
        :data:`DEFAULT_OBJECT_PX` where the calibration cannot say (files that cannot be
        read, a centre off the table).
    """
    h, w = (camera.height_px, camera.width_px) if shape is None else shape[:2]
    try:
        geometry = camera_geometry(calibration, camera)
        area = float(geometry.expected_disc_area_px(np.array([[w / 2.0, h / 2.0]]), diameter_cm)[0])
    except MearmError:
        return DEFAULT_OBJECT_PX
    return (
        2.0 * math.sqrt(area / math.pi) if math.isfinite(area) and area > 0 else DEFAULT_OBJECT_PX
    )
