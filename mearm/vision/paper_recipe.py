"""The paper's recipe in plain NumPy/SciPy, for cross-checks and the benchmark (paper §4).

Per colour class: float64 HSV thresholds, ``scipy.ndimage.median_filter`` (borders replicated,
as OpenCV's ``medianBlur``), ``scipy.ndimage.label`` with 8-connectivity, regions under
the minimum area dropped, centroid = mean pixel position, elongation = the principal-axis
ratio of the second central moments. No shortcuts: every step runs
on the whole frame, as the paper's MATLAB did. Needs SciPy (the ``dev`` extra).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mearm.config import ColorClass, VisionConfig
from mearm.vision.classify import classify_hsv, hsv_exact
from mearm.vision.detector import Detection
from mearm.vision.thresholds import Thresholds

_EIGHT = np.ones((3, 3), dtype=bool)


def detect_reference(
    frame_bgr: np.ndarray, classes: Sequence[ColorClass], vision: VisionConfig
) -> list[Detection]:
    """Detections of ``frame_bgr`` ((H, W, 3) uint8 BGR) without OpenCV, in detector order.

    ``merged`` is left False: the merged test is the detector's addition, not the recipe.

    Args:
        frame_bgr: The frame, (H, W, 3) uint8 BGR.
        classes: The colour classes (``task.classes``), in order.
        vision: Floors and filter settings.
    """
    from scipy import ndimage  # lazy: scipy costs 0.7 s to import

    thr = Thresholds.from_config(classes, vision)
    codes = classify_hsv(*hsv_exact(frame_bgr), thr)
    k = vision.median_kernel
    rows, cols = np.indices(codes.shape)
    found: list[Detection] = []
    for color, code in thr.codes.items():
        mask = (codes == code).astype(np.uint8)
        if k > 1:
            mask = ndimage.median_filter(mask, size=k, mode="nearest")
        labels, n = ndimage.label(mask, structure=_EIGHT)
        if n == 0:
            continue
        flat = labels.ravel()
        area = np.bincount(flat, minlength=n + 1)
        sum_u = np.bincount(flat, weights=cols.ravel(), minlength=n + 1)
        sum_v = np.bincount(flat, weights=rows.ravel(), minlength=n + 1)
        u, v = cols.ravel().astype(float), rows.ravel().astype(float)
        sum_uu = np.bincount(flat, weights=u * u, minlength=n + 1)
        sum_vv = np.bincount(flat, weights=v * v, minlength=n + 1)
        sum_uv = np.bincount(flat, weights=u * v, minlength=n + 1)
        boxes = ndimage.find_objects(labels)
        per_color = []
        for lab in range(1, n + 1):
            if area[lab] < vision.min_area_px:
                continue
            sv, su = boxes[lab - 1]
            a, cu, cv = area[lab], sum_u[lab] / area[lab], sum_v[lab] / area[lab]
            cov = np.array(
                [[sum_uu[lab] / a - cu * cu, sum_uv[lab] / a - cu * cv],
                 [sum_uv[lab] / a - cu * cv, sum_vv[lab] / a - cv * cv]]
            )  # fmt: skip
            lam_min, lam_max = np.linalg.eigvalsh(cov)
            per_color.append(
                Detection(
                    color=color,
                    centroid_px=np.array([sum_u[lab], sum_v[lab]]) / area[lab],
                    area_px=int(area[lab]),
                    bbox_px=(su.start, sv.start, su.stop - su.start, sv.stop - sv.start),
                    elongation=float(np.sqrt(lam_max / lam_min)) if lam_min > 1e-12 else np.inf,
                )
            )
        per_color.sort(key=lambda d: (d.centroid_px[1], d.centroid_px[0]))
        found.extend(per_color)
    return found
