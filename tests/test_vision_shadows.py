"""Regions grown into their shadows, and rim edges found beside a shadow (synthetic images)."""

from __future__ import annotations

import math

import cv2
import numpy as np

from mearm.config import VisionConfig
from mearm.config.defaults import default_classes
from mearm.vision.detector import ColorDetector
from mearm.vision.pinhole import subpixel_edges
from mearm.vision.shadows import grow_into_shadows

GREEN = (40, 170, 45)  # BGR
TABLE = (95, 140, 175)  # a lit wooden table, BGR


def test_weak_pixels_count_only_joined_to_strong_ones_of_their_class():
    """A weak region holding a strong pixel of its class is kept whole; a weak region
    alone, or holding only another class's strong pixel, is dropped."""
    strong = np.zeros((6, 12), np.uint8)
    weak = np.zeros_like(strong)
    weak[1:4, 0:4] = 1  # class 1, with a strong pixel
    strong[2, 1] = 1
    weak[1:4, 6:8] = 1  # class 1, weak only
    weak[1:4, 9:12] = 2  # class 2, next to a strong class-1 pixel only
    strong[0, 10] = 1
    grown = grow_into_shadows(strong, weak, 2)
    assert (grown[1:4, 0:4] == 1).all()
    assert not grown[:, 5:].any()


def _disc(shadowed: bool) -> np.ndarray:
    """A green disc of radius 30 px at (100, 100), anti-aliased, on a table; with
    ``shadowed`` a shadow across its left third darkens it to a quarter (as a bin's does
    under a lamp), and the table there."""
    frame = np.full((200, 200, 3), TABLE, np.uint8)
    cv2.circle(frame, (100 * 16, 100 * 16), 30 * 16, GREEN, -1, cv2.LINE_AA, 4)
    if shadowed:
        frame[:, :90] = (frame[:, :90] * 0.25).astype(np.uint8)
    return frame


def test_the_detector_keeps_an_objects_shadowed_part_with_shadow_value_min():
    """The shadowed third of the disc is under ``value_min``: without ``shadow_value_min``
    it is cut off; with it the region is the whole disc, as found unshadowed (its area
    within 2 %); in the unshadowed frame the setting changes nothing."""
    classes = default_classes()

    def area(frame: np.ndarray, shadow: float | None) -> int:
        found = ColorDetector(VisionConfig(shadow_value_min=shadow), None, classes).detect(frame)
        assert [d.color for d in found] == ["green"]
        return found[0].area_px

    lit, shadowed = _disc(shadowed=False), _disc(shadowed=True)
    whole = area(lit, None)
    assert area(lit, 0.08) == whole
    assert area(shadowed, None) < 0.85 * whole
    assert abs(area(shadowed, 0.08) - whole) < 0.02 * whole


def _outline(radius: float, n: int = 180) -> np.ndarray:
    a = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return np.column_stack([100 + radius * np.cos(a), 100 + radius * np.sin(a)])


def _radii(frame: np.ndarray) -> np.ndarray:
    return np.linalg.norm(subpixel_edges(frame, _outline(29.5)) - 100, axis=1)


def test_a_dark_shadow_beyond_the_rim_is_not_taken_for_the_object():
    """A shadow 2 px wide just beyond the rim (a lamp behind the camera casts it there):
    the edge found is the disc's, where it is found without the shadow (within 0.1 px;
    0.03 here), not pulled towards the shadow's outer edge (in B, G, R the dark ring lies
    nearer the green than the table does: scored that way, 0.14 px outwards here and a
    pixel on the twin's renders)."""
    plain = _disc(shadowed=False)
    frame = np.full((200, 200, 3), TABLE, np.uint8)
    cv2.circle(frame, (100 * 16, 100 * 16), 32 * 16, (20, 28, 35), -1, cv2.LINE_AA, 4)
    cv2.circle(frame, (100 * 16, 100 * 16), 30 * 16, GREEN, -1, cv2.LINE_AA, 4)
    assert np.abs(_radii(frame) - _radii(plain)).max() < 0.1


def test_a_shadow_across_the_rim_does_not_pull_the_edge_onto_the_face():
    """A shadow's edge across the disc's left rim, 2.5 px in (as a bin's falls across an
    object under the lamp): the rim beyond it is found where it is found unshadowed,
    within 0.2 px (0.15 here). Scored against the face's colour 3 px in, lit, it came
    out on the shadow's edge instead, 2.9–3.1 px inwards. (Where the shadow's own edge
    meets the rim the rim is ambiguous, and not tested.)"""
    plain = _disc(shadowed=False)
    shadowed = plain.copy()
    shadowed[:, :73] = (shadowed[:, :73] * 0.25).astype(np.uint8)
    tip = np.argsort(_outline(29.5)[:, 0])[:9]  # the rim in the shadow, its face lit 3 px in
    assert np.abs(_radii(shadowed) - _radii(plain))[tip].max() < 0.2
