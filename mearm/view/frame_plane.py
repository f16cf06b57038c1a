"""The camera frame as a texture lying on the table where the calibration puts it.

The calibration maps pixels to table points (paper §4), in general by a homography, so
the image's outline on the table is a quadrilateral, not always a rectangle. A textured
plane in meshcat is a rectangle with an affine texture, so the frame is resampled here
into an axis-aligned, top-down texture of the quadrilateral's bounding box, transparent
outside it: each texture pixel then shows the frame pixel that the calibration maps
there, for any homography.

Pixel convention (OpenCV's): integer coordinates are pixel centres, so the image's outer
edge runs through (−0.5, −0.5) and (W − 0.5, H − 0.5).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import cv2
import numpy as np
import numpy.typing as npt

from mearm.view.errors import ViewInputError

PixelToTable = Callable[[np.ndarray], npt.ArrayLike]
"""(N, 2) pixel coordinates (u, v) [px] → (N, 2) table points (x, y), base frame [cm]."""

#: Texture resolution [px/cm] and largest side [px]: 640 px across the paper's 40 cm field.
TEXTURE_PX_PER_CM = 16.0
TEXTURE_MAX_SIDE_PX = 1024


@dataclass(frozen=True)
class FramePlane:
    """A frame resampled onto the table.

    Attributes:
        texture_bgra: Top-down texture, rows from +y (top) to −y, columns from −x to +x;
            alpha 0 outside the frame's outline, (h, w, 4) uint8.
        corners_cm: Where the image corners land, in the order top-left, top-right,
            bottom-right, bottom-left, base frame [cm], (4, 2).
        x_range_cm: The texture's extent along x [cm], (min, max).
        y_range_cm: The texture's extent along y [cm], (min, max).
    """

    texture_bgra: np.ndarray
    corners_cm: np.ndarray
    x_range_cm: tuple[float, float]
    y_range_cm: tuple[float, float]

    @property
    def center_cm(self) -> np.ndarray:
        """Centre of the texture rectangle [cm], (2,)."""
        return np.array([sum(self.x_range_cm) / 2.0, sum(self.y_range_cm) / 2.0])

    @property
    def size_cm(self) -> np.ndarray:
        """Width (along x) and height (along y) of the texture rectangle [cm], (2,)."""
        return np.array(
            [self.x_range_cm[1] - self.x_range_cm[0], self.y_range_cm[1] - self.y_range_cm[0]]
        )

    def table_to_texture(self, xy_cm: npt.ArrayLike) -> np.ndarray:
        """Texture pixel coordinates (column, row) of table points [px], (N, 2)."""
        xy = np.atleast_2d(np.asarray(xy_cm, dtype=float))
        h, w = self.texture_bgra.shape[:2]
        sx = w / (self.x_range_cm[1] - self.x_range_cm[0])
        sy = h / (self.y_range_cm[1] - self.y_range_cm[0])
        return np.column_stack(
            [(xy[:, 0] - self.x_range_cm[0]) * sx - 0.5, (self.y_range_cm[1] - xy[:, 1]) * sy - 0.5]
        )


def _as_bgr(frame: npt.ArrayLike) -> np.ndarray:
    img = np.asarray(frame)
    if img.dtype != np.uint8:
        raise ViewInputError("frame_bgr", f"array of {img.dtype}", "an 8-bit (uint8) image")
    if img.ndim == 2:
        img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
    if img.ndim != 3 or img.shape[2] != 3 or img.shape[0] < 2 or img.shape[1] < 2:
        raise ViewInputError(
            "frame_bgr", f"array of shape {img.shape}", "an (H, W, 3) BGR or (H, W) grey image"
        )
    return img


def _image_corners_px(width: int, height: int) -> np.ndarray:
    """The image's outer corners, top-left, top-right, bottom-right, bottom-left [px], (4, 2)."""
    return np.array(
        [[-0.5, -0.5], [width - 0.5, -0.5], [width - 0.5, height - 0.5], [-0.5, height - 0.5]]
    )


def _table_corners(pixel_to_table: PixelToTable, width: int, height: int) -> np.ndarray:
    try:
        corners = np.asarray(pixel_to_table(_image_corners_px(width, height)), dtype=float)
    except Exception as exc:  # any callable may be given; report what it raised
        raise ViewInputError(
            "pixel_to_table",
            pixel_to_table,
            f"a callable mapping (N, 2) px to cm (it raised {exc})",
        ) from exc
    if corners.shape != (4, 2) or not np.all(np.isfinite(corners)):
        raise ViewInputError(
            "pixel_to_table(corners)", corners.tolist(), "4 finite (x, y) points [cm], (4, 2)"
        )
    edges = np.roll(corners, -1, axis=0) - corners
    following = np.roll(edges, -1, axis=0)
    turns = edges[:, 0] * following[:, 1] - edges[:, 1] * following[:, 0]
    if not (np.all(turns > 1e-9) or np.all(turns < -1e-9)):
        raise ViewInputError(
            "pixel_to_table(corners)",
            np.round(corners, 3).tolist(),
            "the image corners to land on a convex quadrilateral (check the calibration)",
        )
    return corners


def frame_plane(
    frame_bgr: npt.ArrayLike,
    pixel_to_table: PixelToTable,
    px_per_cm: float = TEXTURE_PX_PER_CM,
    max_side_px: int = TEXTURE_MAX_SIDE_PX,
) -> FramePlane:
    """Resample a camera frame onto the table (see the module docstring).

    Args:
        frame_bgr: The frame, (H, W, 3) BGR or (H, W) grey, uint8.
        pixel_to_table: Maps (N, 2) pixels [px] to (N, 2) table points [cm], e.g.
            ``Calibration.pixel_to_table``. Only the image corners are mapped; the frame is
            warped by the homography through them, exact when the map is a homography.
        px_per_cm: Texture resolution [px/cm].
        max_side_px: The texture's longest side is at most this [px].

    Returns:
        The texture and where it lies.

    Raises:
        ViewInputError: Not an 8-bit image, or the calibration maps the corners to
            something other than a convex quadrilateral.
    """
    img = _as_bgr(frame_bgr)
    height, width = img.shape[:2]
    corners = _table_corners(pixel_to_table, width, height)
    (x0, y0), (x1, y1) = corners.min(axis=0), corners.max(axis=0)
    scale = min(px_per_cm, max_side_px / max(x1 - x0, y1 - y0))
    tex_w = max(2, round((x1 - x0) * scale))
    tex_h = max(2, round((y1 - y0) * scale))
    outline = FramePlane(
        texture_bgra=np.zeros((tex_h, tex_w, 4), np.uint8),
        corners_cm=corners,
        x_range_cm=(float(x0), float(x1)),
        y_range_cm=(float(y0), float(y1)),
    )
    H = cv2.getPerspectiveTransform(
        _image_corners_px(width, height).astype(np.float32),
        outline.table_to_texture(corners).astype(np.float32),
    )
    texture = cv2.warpPerspective(
        cv2.cvtColor(img, cv2.COLOR_BGR2BGRA),
        H,
        (tex_w, tex_h),
        flags=cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=(0, 0, 0, 0),
    )
    return replace(outline, texture_bgra=texture)
