"""Blown-out tops: a lamp's highlight classified by its hue with a lower saturation floor.

A glossy object's highlight adds the lamp's white to every channel: the hue and the
chroma (max − min) stay the object's, but the saturation S = chroma / V falls, and where
the brightest channel reaches the sensor's clip the top of the object comes out a pale
tint of its colour. Under a lamp straight above, a whole top blew out to S ≈ 0.37–0.39,
just under the default floor of 0.4: the object was missed, or only its rim found and
placed up to 0.5 cm off. With ``vision.highlight_saturation_min`` set, a pixel at or
near the clip (V ≥ :data:`HIGHLIGHT_VALUE_MIN`) counts for the class whose hue band it
lies in when its saturation is at least that lower floor. Only bright pixels are taken
so: a pale tint at an ordinary exposure (a pastel object, a wooden table's grain) is
held to ``saturation_min`` as before, and a white or grey highlight (paper, a grey
table: S near 0) is under the lower floor.
"""

from __future__ import annotations

import numpy as np

from mearm.vision.classify import PixelClassifier
from mearm.vision.thresholds import Thresholds

#: A pixel is a highlight's when its value is at least this [-]: at the clip (255) or
#: within the sensor noise of it (an 8-bit level of 243 and up).
HIGHLIGHT_VALUE_MIN = 0.95


def highlight_classifier(
    thresholds: Thresholds, highlight_saturation_min: float
) -> PixelClassifier:
    """The highlights' classifier: the same bands, S ≥ the lower floor, V ≥ the clip's."""
    return PixelClassifier(
        Thresholds(thresholds.bands_deg, highlight_saturation_min, HIGHLIGHT_VALUE_MIN)
    )


def with_highlights(codes: np.ndarray, highlights: np.ndarray) -> np.ndarray:
    """``codes`` with each unclassified pixel given its highlight class (uint8 (H, W))."""
    return np.where(codes > 0, codes, highlights).astype(np.uint8)


def union_box(
    a: tuple[int, int, int, int], b: tuple[int, int, int, int]
) -> tuple[int, int, int, int]:
    """The box (x, y, w, h) around two boxes; an empty one (w or h 0) adds nothing."""
    if a[2] == 0 or a[3] == 0:
        return b
    if b[2] == 0 or b[3] == 0:
        return a
    x0, y0 = min(a[0], b[0]), min(a[1], b[1])
    x1, y1 = max(a[0] + a[2], b[0] + b[2]), max(a[1] + a[3], b[1] + b[3])
    return x0, y0, x1 - x0, y1 - y0


__all__ = ["HIGHLIGHT_VALUE_MIN", "highlight_classifier", "union_box", "with_highlights"]
