"""Regions grown into their own shadows: hysteresis on the value floor.

A lamp's shadow falling across an object (a bin's, a neighbour's) leaves the shadowed
part of the object its hue and saturation but takes its value below ``vision.value_min``;
the class mask then stops at the shadow's edge, and an outline cut there places the
object wrong. With ``vision.shadow_value_min`` set, each class is classified twice: at
the floors (the *strong* pixels) and with the value floor lowered to
``shadow_value_min`` (the *weak* ones). A connected region of a class's weak pixels is
kept whole when it holds a strong pixel of that class, and dropped otherwise (Canny's
hysteresis, on value instead of gradient): the shadowed part of an object joins its lit
part, and a dark patch of the class's hue alone (a dark table, a shadow's noise) never
becomes an object.
"""

from __future__ import annotations

import cv2
import numpy as np

from mearm.vision.classify import PixelClassifier, equal_mask
from mearm.vision.thresholds import Thresholds


def weak_classifier(thresholds: Thresholds, shadow_value_min: float) -> PixelClassifier:
    """The weak pixels' classifier: the same bands and S floor, V ≥ ``shadow_value_min``."""
    return PixelClassifier(
        Thresholds(thresholds.bands_deg, thresholds.saturation_min, shadow_value_min)
    )


def grow_into_shadows(strong: np.ndarray, weak: np.ndarray, classes: int) -> np.ndarray:
    """Class codes of the weak pixels whose 8-connected region of one class holds a strong one.

    Args:
        strong: Class codes at the floors, uint8 (H, W) (0: none).
        weak: Class codes with the lower value floor, uint8 (H, W); every strong pixel
            is a weak pixel of the same class.
        classes: Number of classes (codes 1 … ``classes``).

    Returns:
        The grown class codes, uint8 (H, W).
    """
    out = np.zeros_like(weak)
    for code in range(1, classes + 1):
        mask = equal_mask(weak, code)
        if not cv2.countNonZero(mask):
            continue
        n, labels = cv2.connectedComponents(mask, connectivity=8, ltype=cv2.CV_32S)
        keep = np.zeros(n, bool)
        keep[labels[strong == code]] = True
        keep[0] = False
        out[keep[labels]] = code
    return out
