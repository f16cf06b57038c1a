"""One detection (a region of one colour class: where it is, what it looks like); frame checks."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any

import numpy as np

from mearm.vision.errors import ImageError
from mearm.vision.shapes import table_yaw_deg

if TYPE_CHECKING:
    from mearm.vision.calibration import CameraGeometry


@dataclass(frozen=True)
class Detection:
    """One region of one colour class.

    Attributes:
        color: The name of its class (one of ``task.classes``).
        centroid_px: Mean (u, v) of the region's pixel centres [px], (2,), read-only.
        area_px: Number of pixels in the region [px].
        bbox_px: Bounding box (x, y, w, h) [px].
        merged: The region looks like several touching objects (see the module docstring).
        elongation: Ratio of the region's principal axes [-] (1 for a disc).
        table_cm: Where the object stands on the table (x, y), base frame [cm], (2,),
            when the detector has a calibration: the centroid's table point under the
            paper's homography; the centre of its top face's outline under a
            perspective calibration (:meth:`PerspectiveCamera.locate_object`).
        shape: The shape its outline has (:mod:`mearm.vision.shapes`); ``None`` when it
            cannot be told: the region is merged or cut by the image border.
        yaw_px_deg: A cube's sides' direction in the image, from the u axis towards +v,
            in [0, 90) [deg], from the silhouette's smallest rectangle; ``None`` for other
            shapes.
        yaw_deg: A cube's sides' direction on the table, from the base frame's x axis
            towards y, in [0, 90) [deg], when the detector has a calibration: under the
            paper's homography ``yaw_px_deg`` turned through it; under a perspective
            calibration the fitted top square's turn (the silhouette's walls turn its
            rectangle), or for a part of a split region its ``yaw_px_deg`` turned onto
            the table. ``None`` for other shapes, or without a calibration.
    """

    color: str
    centroid_px: np.ndarray = field(compare=False)
    area_px: int
    bbox_px: tuple[int, int, int, int]
    merged: bool = False
    elongation: float = 1.0
    table_cm: np.ndarray | None = field(default=None, compare=False)
    shape: str | None = None
    yaw_px_deg: float | None = None
    yaw_deg: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "centroid_px", _point(self.centroid_px))
        if self.table_cm is not None:
            object.__setattr__(self, "table_cm", _point(self.table_cm))

    def evolve(self, **changes: Any) -> Detection:
        """This detection with ``changes``, as :func:`dataclasses.replace` gives it.

        A frame's detections are each changed a few times, and ``replace`` re-runs the
        generated ``__init__`` and inspects the fields on every call (5.7 against 1.6 µs).
        """
        unknown = changes.keys() - _FIELDS
        if unknown:
            raise TypeError(f"Detection has no field {sorted(unknown)}")
        new = object.__new__(Detection)
        values = {**self.__dict__, **changes}
        if "centroid_px" in changes:
            values["centroid_px"] = _point(values["centroid_px"])
        if changes.get("table_cm") is not None:
            values["table_cm"] = _point(values["table_cm"])
        new.__dict__.update(values)
        return new


_FIELDS = frozenset(f.name for f in fields(Detection))


def _made(
    color: str,
    centroid_px: np.ndarray,
    area_px: int,
    bbox_px: tuple[int, int, int, int],
    *,
    merged: bool,
    elongation: float,
    table_cm: np.ndarray | None,
    shape: str | None,
    yaw_px_deg: float | None,
    yaw_deg: float | None,
) -> Detection:
    """A detection of values the detector has made ready, without ``__init__``'s checks.

    ``centroid_px`` and ``table_cm`` must be what :func:`_point` keeps (read-only (2,)
    float rows of read-only arrays); a frame's detections are made by the dozen (the
    generated ``__init__`` with its checks costs several µs each).
    """
    new = object.__new__(Detection)
    new.__dict__.update(
        color=color,
        centroid_px=centroid_px,
        area_px=area_px,
        bbox_px=bbox_px,
        merged=merged,
        elongation=elongation,
        table_cm=table_cm,
        shape=shape,
        yaw_px_deg=yaw_px_deg,
        yaw_deg=yaw_deg,
    )
    return new


def _point(value: object) -> np.ndarray:
    """``value`` as a read-only float (2,) array; one already so is kept, not copied.

    Kept only if no one can write it: not writeable, and neither is the array whose
    memory it views (NumPy points a view's ``base`` at that array).
    """
    if (
        isinstance(value, np.ndarray)
        and value.shape == (2,)
        and value.dtype == np.float64
        and not value.flags.writeable
        and (
            value.base is None
            or (isinstance(value.base, np.ndarray) and not value.base.flags.writeable)
        )
    ):
        return value
    p = np.array(value, dtype=float).reshape(2)
    p.setflags(write=False)
    return p


def check_frame(frame: object, source: str = "frame") -> np.ndarray:
    """Return ``frame`` as a C-contiguous (H, W, 3) uint8 BGR array, or raise ImageError."""
    if not isinstance(frame, np.ndarray):
        raise ImageError(source, f"expected a numpy array, got {type(frame).__name__}")
    if frame.dtype != np.uint8:
        raise ImageError(source, f"expected 8-bit pixels (uint8), got {frame.dtype}")
    if frame.ndim != 3 or frame.shape[2] != 3:
        raise ImageError(
            source,
            f"expected a colour image of shape (H, W, 3) in BGR order, got {frame.shape}",
        )
    if frame.shape[0] < 1 or frame.shape[1] < 1:
        raise ImageError(source, f"image is empty, shape {frame.shape}")
    return np.ascontiguousarray(frame)


def _with_table_yaw(d: Detection, cal: CameraGeometry) -> Detection:
    """``d`` with a cube's image yaw (the silhouette's) turned onto the table."""
    if d.yaw_px_deg is None:
        return d
    return d.evolve(yaw_deg=table_yaw_deg(cal.pixel_to_table, d.centroid_px, d.yaw_px_deg))
