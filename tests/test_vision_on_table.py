"""Objects stand on the work surface (mearm.vision.on_table): what surrounds a detection."""

from __future__ import annotations

import functools

import cv2
import numpy as np
import pytest

from mearm.config import Config
from mearm.vision import Calibration, ColorDetector
from mearm.vision.on_table import SURFACE_SHARE, surface_share
from mearm.vision.teaching import Sample, teach

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
TABLE_BGR = (190, 195, 200)
ROBOT_BGR = (28, 28, 30)
COLOURS = {"red": (35, 30, 200), "green": (40, 170, 40), "blue": (200, 90, 40)}
#: The paper's calibration: 16 px a cm; the classes' 2 cm objects are 32 px across.
SIDE_PX = 32


def _cube(frame: np.ndarray, name: str, u: int, v: int) -> None:
    h = SIDE_PX // 2
    cv2.rectangle(frame, (u - h, v - h), (u + h - 1, v + h - 1), COLOURS[name], -1)


def _table() -> np.ndarray:
    return np.full((480, 640, 3), TABLE_BGR, np.uint8)


@functools.cache
def _taught() -> ColorDetector:
    """The detector taught one click per class on a frame of one cube of each (taught when
    a test first asks: at import, every worker's collection paid its 0.3 s of CPU)."""
    frame = _table()
    at = {"red": (120, 120), "green": (320, 120), "blue": (520, 120)}
    for name, (u, v) in at.items():
        _cube(frame, name, u, v)
    taught = teach([frame], [Sample(n, u, v) for n, (u, v) in at.items()], find_area=False)
    classes = [
        c.model_copy(update={"learned_colour": taught.colours[c.name]}) for c in CONFIG.task.classes
    ]
    vision = CONFIG.vision.model_copy(update={"reference_bgr": taught.reference_bgr})
    return ColorDetector(vision, CAL, classes)


def _robot(frame: np.ndarray, u: int, v: int, half_px: int) -> None:
    cv2.rectangle(frame, (u - half_px, v - half_px), (u + half_px, v + half_px), ROBOT_BGR, -1)


def test_a_cube_on_the_table_is_kept_and_one_on_the_robot_is_not() -> None:
    """The same blue cube on the table, and on a robot's dark base 3 objects wide."""
    frame = _table()
    _cube(frame, "blue", 160, 240)
    _robot(frame, 460, 240, 48)
    _cube(frame, "blue", 460, 240)
    found = _taught().detect(frame)
    assert [(d.color, round(d.centroid_px[0])) for d in found] == [("blue", 160)]
    plain = _taught()._detect(frame)  # before the rule: both
    assert len(plain) == 2


def test_the_robot_along_one_side_a_shadow_a_neighbour_or_the_frame_edge_cost_nothing() -> None:
    """Cubes beside the robot's edge, with a shadow, touching another, cut by the border."""
    frame = _table()
    cv2.rectangle(frame, (0, 0), (639, 60), ROBOT_BGR, -1)  # the robot, along the top
    _cube(frame, "red", 120, 61 + SIDE_PX // 2)  # touching it along one side
    shadow = tuple(int(0.6 * c) for c in TABLE_BGR)
    cv2.rectangle(frame, (300, 236), (330, 266), shadow, -1)  # a shadow at its foot
    _cube(frame, "green", 290, 240)
    _cube(frame, "blue", 450, 300)
    _cube(frame, "red", 450 + SIDE_PX + 1, 300)  # touching, another class
    _cube(frame, "green", 625, 420)  # cut by the frame's right edge
    found = _taught().detect(frame)
    assert len(found) == 5
    assert len(found) == len(_taught()._detect(frame))


def test_without_a_reference_colour_every_detection_is_kept() -> None:
    """The rule needs the table's colour: the shipped bands keep the cube on the robot."""
    frame = _table()
    _robot(frame, 320, 240, 48)
    _cube(frame, "blue", 320, 240)
    shipped = ColorDetector(CONFIG.vision, CAL, CONFIG.task.classes)
    assert [d.color for d in shipped.detect(frame)] == ["blue"]
    assert _taught().detect(frame) == []


@pytest.mark.parametrize("robot_share", [0.0, 0.25, 0.5, 0.75, 1.0])
def test_the_share_is_what_of_the_ring_is_the_surface(robot_share: float) -> None:
    """A square's ring with the robot on a share of its width: that share is not surface."""
    own = np.zeros((100, 100), bool)
    own[34:66, 34:66] = True
    surface = np.ones((100, 100), bool)
    cut = round(robot_share * 100)
    surface[:, :cut] = False  # the robot covers the left columns
    share = surface_share(surface, own, None, 8.0, 16.0)
    assert share is not None
    assert share == pytest.approx(1.0 - robot_share, abs=0.12)
    counted = np.zeros((100, 100), bool)
    assert surface_share(surface, own, counted, 8.0, 16.0) is None  # nothing counted: no verdict
    assert 0.0 < SURFACE_SHARE < 1.0
