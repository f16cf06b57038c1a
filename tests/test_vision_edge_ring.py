"""The surface rule at the frame's edge (mearm.vision.on_table): what is beyond it is no evidence.

A cube touching the robot along one side is kept (the robot is a quarter of its ring). Near
the frame's edge part of its ring is beyond the frame; left out of the share, that part
made the robot's side weigh a third of what was left, and the cube was dropped 4 px from
the edge where mid-frame it is kept. A cube standing on the robot is still dropped there.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from test_vision_on_table import ROBOT_BGR, SIDE_PX, _cube, _robot, _table, _taught

#: The frame's width [px] (``_table``'s).
WIDTH = 640
#: The robot: a band along the frame's top, this many rows.
BAND_ROWS = 61


def _beside_the_robot(u: int, *, mirrored: bool) -> np.ndarray:
    """A red cube at column ``u`` touching the robot's band along its top side.

    ``mirrored``: the frame flipped left to right (the cube as far from the left edge).
    """
    frame = _table()
    cv2.rectangle(frame, (0, 0), (WIDTH - 1, BAND_ROWS - 1), ROBOT_BGR, -1)
    _cube(frame, "red", u, BAND_ROWS + SIDE_PX // 2)
    return np.ascontiguousarray(frame[:, ::-1]) if mirrored else frame


@pytest.mark.parametrize("mirrored", [False, True])
def test_a_cube_beside_the_robot_is_kept_at_the_frame_edge_as_mid_frame(mirrored: bool) -> None:
    """Mid-frame and with its side 4 px from the frame's right (or left) edge: both kept."""
    detector = _taught()
    edge_u = WIDTH - 4 - SIDE_PX // 2  # its right side 4 px from the edge (column 635)
    for u in (WIDTH // 2, edge_u):
        frame = _beside_the_robot(u, mirrored=mirrored)
        assert len(detector._detect(frame)) == 1  # found before the rule
        found = detector.detect(frame)
        assert [d.color for d in found] == ["red"], f"the cube at u={u} was dropped"


def test_a_cube_on_the_robot_at_the_frame_edge_is_still_dropped() -> None:
    """The robot's dark base 3 objects wide, cut by the frame's edge, a cube on it."""
    detector = _taught()
    for robot_u, cube_u in ((600, 600), (620, 620), (640, 610)):
        frame = _table()
        _robot(frame, robot_u, 240, 48)
        _cube(frame, "blue", cube_u, 240)
        assert len(detector._detect(frame)) == 1
        assert detector.detect(frame) == [], f"the cube on the robot at u={cube_u} was kept"
