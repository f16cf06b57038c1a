"""Blown-out tops classified by their hue (``vision.highlight_saturation_min``; synthetic)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from pydantic import ValidationError

from mearm.config import VisionConfig
from mearm.config.defaults import default_classes
from mearm.vision.detector import ColorDetector
from mearm.vision.highlights import union_box

GREEN = (40, 170, 45)  # BGR
BLOWN_GREEN = (157, 255, 188)  # a green top under a lamp overhead (rendered: S ≈ 0.38, V = 1)
TABLE = (95, 140, 175)  # a lit wooden table, BGR


def _disc(top: tuple[int, int, int], rim: tuple[int, int, int] = GREEN) -> np.ndarray:
    """A disc of radius 30 px at (100, 100) on a table: a 3 px rim of ``rim``, its top
    ``top`` (BGR)."""
    frame = np.full((200, 200, 3), TABLE, np.uint8)
    cv2.circle(frame, (100, 100), 30, rim, -1, cv2.LINE_AA)
    cv2.circle(frame, (100, 100), 27, top, -1, cv2.LINE_AA)
    return frame


def _found(frame: np.ndarray, low: float | None) -> list:
    vision = VisionConfig(highlight_saturation_min=low)
    return ColorDetector(vision, None, default_classes()).detect(frame)


def test_a_blown_out_top_counts_for_its_hue_with_highlight_saturation_min():
    """Without the setting only the green rim is left (a ring, its area a fifth of the
    disc's); with 0.2 the disc is found whole, as an unblown one; a disc blown out all
    over (no rim) is found too."""
    whole = _found(_disc(GREEN), None)
    assert [d.color for d in whole] == ["green"]
    ring = _found(_disc(BLOWN_GREEN), None)
    assert all(d.area_px < 0.3 * whole[0].area_px for d in ring)
    found = _found(_disc(BLOWN_GREEN), 0.2)
    assert [d.color for d in found] == ["green"]
    assert abs(found[0].area_px - whole[0].area_px) <= 0.02 * whole[0].area_px
    assert _found(_disc(GREEN), 0.2)[0].area_px == whole[0].area_px
    alone = _found(_disc(BLOWN_GREEN, BLOWN_GREEN), 0.2)
    assert [d.color for d in alone] == ["green"]


@pytest.mark.parametrize(
    ("colour", "what"),
    [
        ((180, 215, 190), "a pastel green at an ordinary exposure (V 0.84, S 0.16)"),
        ((150, 200, 165), "a pale green (V 0.78, S 0.25): not at the clip"),
        ((250, 255, 252), "a white highlight (paper): S 0.02"),
        ((200, 235, 255), "a blown-out wooden table: its hue, 28°, in no band"),
    ],
)
def test_only_a_tint_at_the_clip_of_a_class_hue_is_taken(colour, what):
    """The lower floor holds for pixels at the clip only, of a class's hue, S ≥ 0.2."""
    assert _found(_disc(colour, colour), 0.2) == [], what


def test_highlight_saturation_min_must_be_below_saturation_min():
    with pytest.raises(ValidationError, match="highlight_saturation_min: 0.4 must be below"):
        VisionConfig(highlight_saturation_min=0.4)
    assert VisionConfig(highlight_saturation_min=0.2).highlight_saturation_min == 0.2


def test_union_box_skips_empty_boxes():
    assert union_box((0, 0, 0, 0), (2, 3, 4, 5)) == (2, 3, 4, 5)
    assert union_box((2, 3, 4, 5), (1, 1, 0, 7)) == (2, 3, 4, 5)
    assert union_box((2, 3, 4, 5), (0, 10, 1, 1)) == (0, 3, 6, 8)
