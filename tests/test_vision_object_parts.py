"""Parts of objects: fragments of one object are one detection, a long thin part none."""

from __future__ import annotations

import cv2
import numpy as np

from mearm.config import Config
from mearm.vision.calibration import Calibration
from mearm.vision.detector import ColorDetector
from mearm.vision.object_parts import fragment_pairs
from mearm.vision.plausible import LEAST_SEEN, widths_cm

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
RED_BGR = (35, 30, 200)
GREEN_BGR = (40, 170, 40)
#: The paper's calibration: 16 px a cm; a class's 2 cm objects are 32 px across.
PX_PER_CM = 16.0


def _detect(frame: np.ndarray) -> list:
    return ColorDetector(CONFIG.vision, CAL, CONFIG.task.classes).detect(frame)


def _frame() -> np.ndarray:
    return np.full((480, 640, 3), 128, np.uint8)


def test_an_object_cut_by_a_highlight_is_one_detection() -> None:
    """A 2 cm red disc cut in two by a white band is found once, at its centre."""
    frame = _frame()
    cv2.circle(frame, (216, 216), 16, RED_BGR, -1)  # 2 cm: one object
    cv2.rectangle(frame, (215, 195), (217, 236), (255, 255, 255), -1)  # the glint
    plain = ColorDetector(CONFIG.vision, CAL, CONFIG.task.classes)._detect(frame)
    assert len(plain) == 2  # the case this is about: two regions
    found = _detect(frame)
    assert len(found) == 1
    d = found[0]
    assert d.color == "red" and not d.merged
    assert np.allclose(d.centroid_px, (216.0, 216.0), atol=1.0)
    assert d.area_px == sum(p.area_px for p in plain)
    assert np.allclose(d.table_cm, CAL.pixel_to_table(d.centroid_px), atol=1e-6)


def test_two_touching_objects_stay_two() -> None:
    """Two 2 cm red squares side by side, a dark seam between them, are two objects."""
    frame = _frame()
    cv2.rectangle(frame, (200, 200), (231, 231), RED_BGR, -1)
    cv2.rectangle(frame, (235, 200), (266, 231), RED_BGR, -1)
    cv2.rectangle(frame, (232, 200), (234, 231), (20, 20, 20), -1)
    assert [d.color for d in _detect(frame)] == ["red", "red"]


def test_fragments_of_two_colours_are_not_joined() -> None:
    """A red and a green region close together are two objects of two classes."""
    frame = _frame()
    cv2.rectangle(frame, (200, 200), (213, 231), RED_BGR, -1)
    cv2.rectangle(frame, (218, 200), (231, 231), GREEN_BGR, -1)
    assert sorted(d.color for d in _detect(frame)) == ["green", "red"]


def test_pairs_need_both_nearness_and_little_area() -> None:
    """Near but with an object's area each, or far apart, or of two classes: no pair."""
    at = np.array([[0.0, 0.0], [10.0, 0.0]])
    narrow, foot = np.full(2, 32.0), np.full(2, 1024.0)
    assert fragment_pairs(at, np.array([300.0, 300.0]), ["r", "r"], narrow, foot) == [(0, 1)]
    assert fragment_pairs(at, np.array([600.0, 600.0]), ["r", "r"], narrow, foot) == []
    assert fragment_pairs(at, np.array([300.0, 300.0]), ["r", "g"], narrow, foot) == []
    far = np.array([[0.0, 0.0], [40.0, 0.0]])
    assert fragment_pairs(far, np.array([300.0, 300.0]), ["r", "r"], narrow, foot) == []


def test_a_part_of_an_object_is_no_longer_than_the_object() -> None:
    """A strip thicker than half an object but thinner than one, longer than one, is dropped.

    20 px is over half the narrowest width (a prism's height, 27.7 px) and under the
    whole; 80 px is longer than any one object (a cube's diagonal, 45 px). The same strip
    40 px long is an object seen in part, and kept; so is the long one cut by the border.
    """
    narrow, wide = (PX_PER_CM * w for w in widths_cm(CONFIG.task.classes[:1]))
    assert LEAST_SEEN * narrow < 20 < narrow and 40 < wide < 80  # the rule's own numbers
    frame = _frame()
    cv2.rectangle(frame, (100, 100), (179, 119), RED_BGR, -1)  # 80 × 20 px
    cv2.rectangle(frame, (300, 300), (339, 319), RED_BGR, -1)  # 40 × 20 px
    cv2.rectangle(frame, (0, 400), (79, 419), RED_BGR, -1)  # 80 × 20 px at the border
    plain = ColorDetector(CONFIG.vision, CAL, CONFIG.task.classes)._detect(frame)
    assert len(plain) == 3  # the plain detector keeps all three
    found = _detect(frame)
    assert [(d.color, round(d.centroid_px[0])) for d in found] == [("red", 320), ("red", 39)]


def test_a_turned_strip_is_judged_as_a_straight_one() -> None:
    """The 80 × 20 px strip turned by 30° is still no object (its moments, not its box)."""
    frame = _frame()
    corners = cv2.boxPoints(((300.0, 240.0), (80.0, 20.0), 30.0))
    cv2.fillPoly(frame, [np.round(corners).astype(np.int32)], RED_BGR)
    assert _detect(frame) == []
