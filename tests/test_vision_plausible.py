"""Regions that cannot be objects of the task (too thin, too long for their area) are dropped."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from mearm.config import Config
from mearm.vision.calibration import Calibration
from mearm.vision.detector import ColorDetector
from mearm.vision.plausible import LEAST_SEEN, plausible, rectangle_sides_px, widths_cm

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
RED_BGR = (35, 30, 200)
#: The paper's calibration: 16 px a cm; a class's 2 cm objects are 32 px across.
PX_PER_CM = 16.0


def _frame() -> np.ndarray:
    return np.full((480, 640, 3), 128, np.uint8)


def _detect(frame: np.ndarray, classes=None) -> list:
    detector = ColorDetector(CONFIG.vision, CAL, classes or CONFIG.task.classes)
    return detector.detect(frame)


def test_widths_of_a_class_of_no_shape_cover_every_shape() -> None:
    """No shape: any of the catalogue; a cube: its side and diagonal; a cylinder: its diameter."""
    red = CONFIG.task.classes[0].model_copy(update={"shape": None, "diameter_cm": 2.0})
    assert widths_cm([red]) == pytest.approx((math.sqrt(3), 2 * math.sqrt(2)))
    cube = red.model_copy(update={"shape": "cube"})
    assert widths_cm([cube]) == pytest.approx((2.0, 2 * math.sqrt(2)))
    assert widths_cm([red.model_copy(update={"shape": "cylinder"})]) == pytest.approx((2.0, 2.0))


def test_rectangle_sides_of_a_turned_strip() -> None:
    """A strip 100 × 8 px turned by 30° keeps its sides (within a pixel's rounding)."""
    mask = np.zeros((200, 200), np.uint8)
    box = cv2.boxPoints(((100.0, 100.0), (100.0, 8.0), 30.0))
    cv2.fillConvexPoly(mask, np.round(box).astype(np.int32), 1)
    long_px, short_px = rectangle_sides_px(mask)
    assert long_px == pytest.approx(101, abs=2.5)
    assert short_px == pytest.approx(9, abs=2.5)


@pytest.mark.parametrize(
    ("w", "h", "ok"),
    [
        (30, 30, True),  # one object's top
        (90, 30, True),  # three in a row
        (30, 15, True),  # half of one (a shaded side, a blown-out top)
        (80, 10, False),  # a strip thinner than half an object: glare, a cable, an edge
    ],
)
def test_plausible_by_thickness(w: int, h: int, ok: bool) -> None:
    """A region must be at least half an object's narrowest width thick."""
    region = np.ones((h, w), np.uint8)
    footprint = math.pi * (PX_PER_CM) ** 2  # a 2 cm disc [px]
    widths = widths_cm(CONFIG.task.classes[:1])
    assert plausible(region, w * h, PX_PER_CM, footprint, widths, 1.0) is ok


def test_a_sparse_chain_is_too_long_for_its_area() -> None:
    """Thin bars on a one-pixel line along 300 px (a comb): as thick as an object, but far
    longer than the few objects its area could hold would be in a row."""
    region = np.zeros((17, 300), np.uint8)
    region[16, :] = 1
    for x in range(0, 300, 20):
        region[:, x : x + 2] = 1
    area = int(region.sum())
    footprint = math.pi * PX_PER_CM**2
    widths = widths_cm(CONFIG.task.classes[:1])
    most = area / (LEAST_SEEN * footprint)
    assert 300 > most * PX_PER_CM * widths[1]  # the rule's own numbers
    assert not plausible(region, area, PX_PER_CM, footprint, widths, 1.0)


def test_a_thin_strip_is_no_object_but_a_cube_beside_it_is() -> None:
    """A red strip 6 px wide (glare along a frame) is dropped; a 2 cm red square is found."""
    frame = _frame()
    cv2.rectangle(frame, (100, 200), (131, 231), RED_BGR, -1)  # 32 px: one object
    cv2.rectangle(frame, (300, 100), (440, 105), RED_BGR, -1)  # 141 × 6 px
    found = _detect(frame)
    assert [(d.color, round(d.centroid_px[0])) for d in found] == [("red", 116)]


def test_a_strip_cut_by_the_border_is_kept() -> None:
    """Along the frame's border only part of a region is seen: it is not judged."""
    frame = _frame()
    cv2.rectangle(frame, (0, 100), (5, 240), RED_BGR, -1)
    assert [d.color for d in _detect(frame)] == ["red"]


def test_a_row_of_touching_cubes_is_kept() -> None:
    """Three 2 cm squares touching in a row are objects (a merged region), not a strip."""
    frame = _frame()
    cv2.rectangle(frame, (200, 200), (295, 231), RED_BGR, -1)
    found = _detect(frame)
    assert found and all(d.color == "red" for d in found)


def test_smaller_objects_need_a_class_of_their_size() -> None:
    """A 0.8 cm red square is under half a 2 cm object: found only with a class that size."""
    frame = _frame()
    cv2.rectangle(frame, (200, 200), (212, 212), RED_BGR, -1)  # 13 px = 0.8 cm
    assert _detect(frame) == []
    classes = [*CONFIG.task.classes]
    classes.append(classes[0].model_copy(update={"name": "small", "diameter_cm": 0.8}))
    assert [d.color for d in _detect(frame, classes)] == ["red"]
