"""The plain 8-bit OpenCV colour recipe: ``cv2.inRange`` on HSV, a median, labelling.

The peer the detector is timed and scored against (``mearm vision-bench``, ``mearm
bench``): what a maker writes first from the OpenCV tutorials.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from mearm.config import ColorClass, VisionConfig
from mearm.vision.calibration import Calibration
from mearm.vision.detector import Detection


def detect_inrange(
    frame_bgr: np.ndarray,
    classes: Sequence[ColorClass],
    vision: VisionConfig,
    calibration: Calibration | None = None,
) -> list[Detection]:
    """The plain 8-bit OpenCV recipe, the peer the detector is timed against.

    Per class: ``cv2.inRange`` on OpenCV's 8-bit HSV (hue in 2° bins, each band rounded
    inwards, a wrapping band as two ranges; S and V floors in levels), a median filter,
    ``connectedComponentsWithStats``; each region of at least ``min_area_px`` one
    detection with its centroid, area, box and, given a calibration, its table point.
    No exact classification, merged test or splitting; detections in the detector's
    order (class, then row, then column).
    """
    hsv = cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2HSV)
    s_lo = math.ceil(255 * vision.saturation_min)
    v_lo = math.ceil(255 * vision.value_min)
    found: list[Detection] = []
    for c in classes:
        mask = np.zeros(hsv.shape[:2], np.uint8)
        for band in c.hue_bands_deg or []:  # (a class of any colour: none; no shapes here)
            lo, hi = band.lo_deg / 2.0, band.hi_deg / 2.0
            for a, z in [(lo, hi)] if lo <= hi else [(lo, 180.0), (0.0, hi)]:
                lower = np.array([math.ceil(a), s_lo, v_lo], np.uint8)
                upper = np.array([math.floor(z), 255, 255], np.uint8)
                mask = cv2.bitwise_or(mask, cv2.inRange(hsv, lower, upper))
        if vision.median_kernel > 1:
            mask = cv2.medianBlur(mask, vision.median_kernel)
        n, _, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
        keep = [i for i in range(1, n) if stats[i, cv2.CC_STAT_AREA] >= vision.min_area_px]
        table = calibration.pixel_to_table(centroids[keep]) if calibration and keep else None
        per_class = [
            Detection(
                c.name,
                centroids[i],
                int(stats[i, cv2.CC_STAT_AREA]),
                (int(stats[i, 0]), int(stats[i, 1]), int(stats[i, 2]), int(stats[i, 3])),
                table_cm=None if table is None else table[j],
            )
            for j, i in enumerate(keep)
        ]
        per_class.sort(key=lambda d: (d.centroid_px[1], d.centroid_px[0]))
        found.extend(per_class)
    return found
