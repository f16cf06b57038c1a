r"""Colour object detection: the paper's HSV recipe on OpenCV (paper §4).

For each colour class (``task.classes``, in their order): classify pixels
(:mod:`mearm.vision.classify`), a k×k median filter on the class's mask (3×3 in the
paper), 8-connected regions, regions under ``min_area_px`` dropped; each remaining region
is one :class:`Detection` with its pixel area, bounding box and sub-pixel centroid (the
mean of its pixel centres, i.e. the image moments m10/m00, m01/m00).

Two shortcuts make this fast without changing the result. Work is confined to the box
around every classified pixel (grown by the median's reach), outside which every mask
is 0. Regions are labelled once on the union of the filtered masks (after the median
the masks are disjoint: a pixel needs 5 of its 9 neighbours in a mask to stay in it): a
union region holding one class *is* that class's region, and the rare union region
holding several (objects of different classes touching) is split by labelling each
class inside its box. A test checks the result against a plain per-class NumPy/SciPy
implementation (:mod:`mearm.vision.reference`).

Touching objects of one class form one region. It is reported once, with its real area
and centroid, and flagged ``merged`` (the caller must not pick at that centroid, which
lies between the objects) when any of these holds:

- its area exceeds ``merged_area_ratio`` (1.6) × the area of one object of its class (a
  disc of the class's ``diameter_cm``) at the calibration's scale at that place — only
  when the detector was given a calibration;
- the ratio of its principal axes (from the second central moments) exceeds
  ``merged_elongation`` (1.5): one disc gives 1.0, two touching discs √5 ≈ 2.24.

Detections come in a fixed order: by class in the configured order, each class by
image row then column of the centroid.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import cv2
import numpy as np

from mearm.config import ColorClass, VisionConfig
from mearm.exceptions import ImageError
from mearm.vision.calibration import Calibration
from mearm.vision.classify import PixelClassifier, and_scalar, equal_mask
from mearm.vision.thresholds import Thresholds

if TYPE_CHECKING:
    from mearm.config import Config


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
    """

    color: str
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
    """Find the objects of each colour class in BGR frames.

    Args:
        vision: Floors and filter settings (the ``vision`` section of the config).
        calibration: Enables the area rule of the merged test (the expected area of one
            object at each place); ``None``: only the elongation rule applies.
        classes: The colour classes (``task.classes``): their hue bands, their order
            (class, then row, then column is the order of the detections) and their
            objects' diameter (the area rule of the merged test).

    Raises:
        ConfigError: no classes, too many, or a name listed twice.
    """

    def __init__(
        self,
        vision: VisionConfig,
        calibration: Calibration | None,
        classes: Sequence[ColorClass],
    ):
        self.classes = tuple(classes)
        self.vision = vision
        self.calibration = calibration
        self.thresholds = Thresholds.from_config(self.classes, vision)
        self.classifier = PixelClassifier(self.thresholds)
        self.class_names = self.thresholds.class_names
        self._diameter_cm = {c.name: float(c.diameter_cm) for c in self.classes}

    @classmethod
    def from_config(cls, config: Config) -> ColorDetector:
        """The detector of a whole config: ``task.classes``, ``vision``, ``calibration``."""
        calibration = Calibration.from_config(config.calibration)
        return cls(config.vision, calibration, config.task.classes)

    def _filtered(self, frame_bgr: np.ndarray) -> tuple[dict[str, np.ndarray], int, int]:
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
        out: dict[str, np.ndarray] = {}
        for code, name in enumerate(self.class_names, start=1):
            mask = equal_mask(box, code)
            out[name] = cv2.medianBlur(mask, k) if k > 1 else mask
        return out, x0, y0

    def masks(self, frame_bgr: np.ndarray) -> dict[str, np.ndarray]:
        """Per class name, its median-filtered mask over the whole frame (uint8 0/255, (H, W)).

        Raises:
            ImageError: the frame is not an 8-bit 3-channel image.
        """
        frame = check_frame(frame_bgr)
        boxed, x0, y0 = self._filtered(frame)
        out: dict[str, np.ndarray] = {}
        for name, m in boxed.items():
            full = np.zeros(frame.shape[:2], np.uint8)
            full[y0 : y0 + m.shape[0], x0 : x0 + m.shape[1]] = m
            out[name] = full
        return out

    def detect(self, frame_bgr: np.ndarray) -> list[Detection]:
        """Detections in ``frame_bgr`` ((H, W, 3) uint8 BGR), in the documented order.

        Raises:
            ImageError: the frame is not an 8-bit 3-channel image.
        """
        masks, ox, oy = self._filtered(frame_bgr)
        # One image of class codes 1..N (0 = none); the filtered masks are disjoint.
        index = np.zeros_like(next(iter(masks.values())))
        for code, name in enumerate(self.class_names, start=1):
            index = cv2.bitwise_or(index, and_scalar(masks[name], code))
        n, labels, stats, centroids = _label(index)
        min_area = self.vision.min_area_px
        found: list[Detection] = []
        for lab in range(1, n):
            x, y, w, h, area = (int(v) for v in stats[lab])
            if area < min_area:  # its class regions are smaller still
                continue
            roi = (slice(y, y + h), slice(x, x + w))
            region = (labels[roi] == lab).view(np.uint8)
            lo, hi, _, _ = cv2.minMaxLoc(index[roi], mask=region)
            if lo == hi:  # one class: the union region is that class's region
                found.append(self._detection(int(lo), region, centroids[lab], area, (x, y)))
                continue
            for i in range(int(lo), int(hi) + 1):  # different classes touch: split them
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
        order = {name: i for i, name in enumerate(self.class_names)}
        found.sort(key=lambda d: (order[d.color], d.centroid_px[1], d.centroid_px[0]))
        return self._flag_by_area(found)

    def _detection(
        self, code: int, region: np.ndarray, centroid: np.ndarray, area: int, xy: tuple[int, int]
    ) -> Detection:
        """A detection from a region (0/1 image of its bounding box) in working-box pixels."""
        elongation = _elongation(region)
        h, w = region.shape
        return Detection(
            color=self.class_names[code - 1],
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
        diameters_cm = np.array([self._diameter_cm[d.color] for d in found])
        expected = self.calibration.expected_disc_area_px(centroids, diameters_cm)
        limit = self.vision.merged_area_ratio * expected
        return [
            d if d.merged or d.area_px <= lim else replace(d, merged=True)
            for d, lim in zip(found, limit, strict=True)
        ]
