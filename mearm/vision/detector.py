r"""Colour object detection: the paper's HSV recipe on OpenCV (SPEC §4).

For each colour: classify pixels (:mod:`mearm.vision.classify`), a k×k median filter on
the colour's mask (3×3 in the paper), 8-connected regions, regions under
``min_area_px`` dropped; each remaining region is one :class:`Detection` with its pixel
area, bounding box and sub-pixel centroid (the mean of its pixel centres, i.e. the
image moments m10/m00, m01/m00).

Two shortcuts make this fast without changing the result. Work is confined to the box
around every classified pixel (grown by the median's reach), outside which every mask
is 0. Regions are labelled once on the union of the three filtered masks (after the
median the masks are disjoint: a pixel needs 5 of its 9 neighbours in a mask to stay in
it): a union region holding one colour *is* that colour's region, and the rare union
region holding several (objects of different colours touching) is split by labelling
each colour inside its box. A test checks the result against a plain per-colour
NumPy/SciPy implementation (:mod:`mearm.vision.reference`).

Touching objects of one colour form one region. It is reported once, with its real
area and centroid, and flagged ``merged`` (the caller must not pick at that centroid,
which lies between the objects) when any of these holds:

- its area exceeds ``merged_area_ratio`` (1.6) × the area of one object
  (``object_diameter_cm``, 2 cm) at the calibration's scale at that place — only when
  the detector was given a calibration;
- the ratio of its principal axes (from the second central moments) exceeds
  ``merged_elongation`` (1.5): one disc gives 1.0, two touching discs √5 ≈ 2.24.

Detections come in a fixed order: red, green, blue, each by image row then column of
the centroid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from mearm.config import COLORS, Color, VisionConfig
from mearm.exceptions import ImageError
from mearm.vision.calibration import Calibration
from mearm.vision.classify import COLOR_CODE, PixelClassifier, and_scalar, equal_mask
from mearm.vision.presets import resolve_thresholds


@dataclass(frozen=True)
class Detection:
    """One coloured region.

    Attributes:
        color: ``"red"``, ``"green"`` or ``"blue"``.
        centroid_px: Mean (u, v) of the region's pixel centres [px], (2,), read-only.
        area_px: Number of pixels in the region [px].
        bbox_px: Bounding box (x, y, w, h) [px].
        merged: The region looks like several touching objects (see the module docstring).
        elongation: Ratio of the region's principal axes [-] (1 for a disc).
    """

    color: Color
    centroid_px: np.ndarray = field(compare=False)
    area_px: int
    bbox_px: tuple[int, int, int, int]
    merged: bool = False
    elongation: float = 1.0

    def __post_init__(self) -> None:
        c = np.array(self.centroid_px, dtype=float).reshape(2)
        c.setflags(write=False)
        object.__setattr__(self, "centroid_px", c)


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


def _label(mask: np.ndarray) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    try:  # 16-bit labels are ~3x faster; OpenCV raises if there are too many regions
        return cv2.connectedComponentsWithStats(mask, connectivity=8, ltype=cv2.CV_16U)
    except cv2.error:
        return cv2.connectedComponentsWithStats(mask, connectivity=8, ltype=cv2.CV_32S)


def _elongation(region: np.ndarray) -> float:
    """Principal-axis ratio √(λ_max/λ_min) of a binary region's second central moments."""
    m = cv2.moments(region, binaryImage=True)
    a, b, c = m["mu20"], m["mu11"], m["mu02"]
    root = math.sqrt(max((a - c) ** 2 + 4.0 * b * b, 0.0))
    lam_max, lam_min = (a + c + root) / 2.0, (a + c - root) / 2.0
    if lam_max <= 1e-12:  # a single pixel
        return 1.0
    if lam_min <= 1e-12:  # a line
        return math.inf
    return math.sqrt(lam_max / lam_min)


class ColorDetector:
    """Find red, green and blue objects in BGR frames.

    Args:
        vision: Thresholds and filter settings (the ``vision`` section of the config).
        calibration: Enables the area rule of the merged test (the expected area of one
            object at each place). Without it only the elongation rule applies.
    """

    def __init__(self, vision: VisionConfig, calibration: Calibration | None = None):
        self.vision = vision
        self.calibration = calibration
        self.thresholds = resolve_thresholds(vision)
        self.classifier = PixelClassifier(self.thresholds)

    def _filtered(self, frame_bgr: np.ndarray) -> tuple[dict[Color, np.ndarray], int, int]:
        """Filtered masks of the box around every classified pixel, and the box origin.

        Outside that box (grown by the median's reach) every mask is 0, so working
        inside it gives the full frame's result exactly, for less work.
        """
        frame = check_frame(frame_bgr)
        codes, (x, y, w, h) = self.classifier.classify_with_box(frame)
        k = self.vision.median_kernel
        if w == 0 or h == 0:
            x, y, w, h = 0, 0, 1, 1
        reach = k // 2
        x0, y0 = max(x - reach, 0), max(y - reach, 0)
        x1, y1 = min(x + w + reach, codes.shape[1]), min(y + h + reach, codes.shape[0])
        box = codes[y0:y1, x0:x1]
        out: dict[Color, np.ndarray] = {}
        for color in COLORS:
            mask = equal_mask(box, COLOR_CODE[color])
            out[color] = cv2.medianBlur(mask, k) if k > 1 else mask
        return out, x0, y0

    def masks(self, frame_bgr: np.ndarray) -> dict[Color, np.ndarray]:
        """Per colour, its median-filtered mask over the whole frame (uint8 0/255, (H, W)).

        Raises:
            ImageError: the frame is not an 8-bit 3-channel image.
        """
        frame = check_frame(frame_bgr)
        boxed, x0, y0 = self._filtered(frame)
        out: dict[Color, np.ndarray] = {}
        for color, m in boxed.items():
            full = np.zeros(frame.shape[:2], np.uint8)
            full[y0 : y0 + m.shape[0], x0 : x0 + m.shape[1]] = m
            out[color] = full
        return out

    def detect(self, frame_bgr: np.ndarray) -> list[Detection]:
        """Detections in ``frame_bgr`` ((H, W, 3) uint8 BGR), in the documented order.

        Raises:
            ImageError: the frame is not an 8-bit 3-channel image.
        """
        masks, ox, oy = self._filtered(frame_bgr)
        # One image of colour indices 1..3 (0 = none); the filtered masks are disjoint.
        index = and_scalar(masks["red"], 1)
        index = cv2.bitwise_or(index, and_scalar(masks["green"], 2))
        index = cv2.bitwise_or(index, and_scalar(masks["blue"], 3))
        n, labels, stats, centroids = _label(index)
        min_area = self.vision.min_area_px
        found: list[Detection] = []
        for lab in range(1, n):
            x, y, w, h, area = (int(v) for v in stats[lab])
            if area < min_area:  # its colour regions are smaller still
                continue
            roi = (slice(y, y + h), slice(x, x + w))
            region = (labels[roi] == lab).view(np.uint8)
            lo, hi, _, _ = cv2.minMaxLoc(index[roi], mask=region)
            if lo == hi:  # one colour: the union region is that colour's region
                found.append(self._detection(int(lo), region, centroids[lab], area, (x, y)))
                continue
            for i in range(int(lo), int(hi) + 1):  # different colours touch: split them
                sub = equal_mask(index[roi], i)
                sub = cv2.bitwise_and(sub, sub, mask=region)
                m, sub_labels, sub_stats, sub_centroids = _label(sub)
                for s in range(1, m):
                    sx, sy, sw, sh, sarea = (int(v) for v in sub_stats[s])
                    if sarea >= min_area:
                        piece = (sub_labels[sy : sy + sh, sx : sx + sw] == s).view(np.uint8)
                        centroid = sub_centroids[s] + (x, y)
                        found.append(self._detection(i, piece, centroid, sarea, (x + sx, y + sy)))
        found = [self._shifted(d, ox, oy) for d in found]
        order = {c: i for i, c in enumerate(COLORS)}
        found.sort(key=lambda d: (order[d.color], d.centroid_px[1], d.centroid_px[0]))
        return self._flag_by_area(found)

    def _detection(
        self, index: int, region: np.ndarray, centroid: np.ndarray, area: int, xy: tuple[int, int]
    ) -> Detection:
        """A detection from a region (0/1 image of its bounding box) in working-box pixels."""
        elongation = _elongation(region)
        h, w = region.shape
        return Detection(
            color=COLORS[index - 1],
            centroid_px=centroid,
            area_px=int(area),
            bbox_px=(xy[0], xy[1], w, h),
            merged=elongation > self.vision.merged_elongation,
            elongation=elongation,
        )

    @staticmethod
    def _shifted(d: Detection, ox: int, oy: int) -> Detection:
        x, y, w, h = d.bbox_px
        return replace(d, centroid_px=d.centroid_px + (ox, oy), bbox_px=(x + ox, y + oy, w, h))

    def _flag_by_area(self, found: list[Detection]) -> list[Detection]:
        """Apply the area rule of the merged test (needs the calibration)."""
        if self.calibration is None or not found:
            return found
        centroids = np.array([d.centroid_px for d in found])
        expected = self.calibration.expected_disc_area_px(centroids, self.vision.object_diameter_cm)
        limit = self.vision.merged_area_ratio * expected
        return [
            d if d.merged or d.area_px <= lim else replace(d, merged=True)
            for d, lim in zip(found, limit, strict=True)
        ]
