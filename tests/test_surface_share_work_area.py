"""The work area's edge, for the surface rule and for shadows (synthetic frames).

The surface rule (mearm.vision.on_table): ring pixels inside the frame but outside the
work area count as the surface, as those beyond the frame do. Left out of the share, they
made the robot along one side of a cube near the work area's edge weigh more than the
quarter of the ring it is (a third of the rest with a quarter of the ring outside): the
cube was dropped 4 px from the edge where mid-area it is kept. A cube standing on the
robot is still dropped there.

Shadows (mearm.vision.shadows, ``vision.shadow_value_min``): grown inside a given work
area (``whole_frame`` too) as without one, and never past the work area or into the
excluded pixels (the arm's mask), which the weak pixels ignored with the calibrated
table's outline as the work area.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_vision_on_table import CAL, ROBOT_BGR, SIDE_PX, TABLE_BGR, _cube, _robot, _table, _taught
from test_vision_shadows import _disc

from mearm.config import VisionConfig
from mearm.config.defaults import default_classes
from mearm.config.sections import WHOLE_FRAME
from mearm.vision import ColorDetector
from mearm.vision.detection import Detection

#: The frame's width [px] (``_table``'s).
WIDTH = 640
#: The robot: a band along the frame's top, this many rows.
BAND_ROWS = 61
#: The work area's last column: it keeps columns 0 … EDGE (its polygon's edge is kept).
EDGE = 480

Polygon = list[tuple[float, float]]


def _in_work_area(polygon: Polygon) -> ColorDetector:
    """The taught detector of ``test_vision_on_table``, with ``polygon`` its work area."""
    taught = _taught()
    vision = taught.vision.model_copy(update={"work_area_px": polygon})
    return ColorDetector(vision, CAL, taught.classes)


def _left_part(mirrored: bool) -> Polygon:
    """The columns 0 … EDGE, or (``mirrored``) as many from the frame's right edge."""
    lo, hi = (WIDTH - 1 - EDGE, WIDTH - 1) if mirrored else (0, EDGE)
    return [(lo, 0), (hi, 0), (hi, 479), (lo, 479)]


def _beside_the_robot(u: int, beyond_bgr: tuple[int, int, int], *, mirrored: bool) -> np.ndarray:
    """A red cube at column ``u`` touching the robot's band along its top side.

    Past the work area's edge (column EDGE) the frame is ``beyond_bgr``. ``mirrored``: the
    frame flipped left to right (the cube as far from the work area's left edge).
    """
    frame = _table()
    frame[:, EDGE + 1 :] = beyond_bgr
    frame[:BAND_ROWS] = ROBOT_BGR
    _cube(frame, "red", u, BAND_ROWS + SIDE_PX // 2)
    return np.ascontiguousarray(frame[:, ::-1]) if mirrored else frame


@pytest.mark.parametrize("mirrored", [False, True])
@pytest.mark.parametrize("beyond", ["table", "robot"])
def test_a_cube_beside_the_robot_is_kept_at_the_work_areas_edge_as_mid_area(
    mirrored: bool, beyond: str
) -> None:
    """Mid-area and with its side 4 px from the work area's right (or left) edge: both kept,
    whatever lies past the edge (the table, or the robot's base beyond the table)."""
    detector = _in_work_area(_left_part(mirrored))
    beyond_bgr = TABLE_BGR if beyond == "table" else ROBOT_BGR
    edge_u = EDGE + 1 - 4 - SIDE_PX // 2  # its right side 4 px from the edge (column 476)
    for u in (EDGE // 2, edge_u):
        frame = _beside_the_robot(u, beyond_bgr, mirrored=mirrored)
        assert len(detector._detect(frame)) == 1  # found before the rule
        found = detector.detect(frame)
        assert [d.color for d in found] == ["red"], f"the cube at u={u} was dropped"


def test_a_cube_on_the_robot_at_the_work_areas_edge_is_still_dropped() -> None:
    """The robot's dark base 3 objects wide across the work area's edge, a cube on it."""
    detector = _in_work_area(_left_part(mirrored=False))
    for robot_u, cube_u in ((EDGE - 40, EDGE - 40), (EDGE - 20, EDGE - 20), (EDGE, EDGE - 30)):
        frame = _table()
        _robot(frame, robot_u, 240, 48)
        _cube(frame, "blue", cube_u, 240)
        assert len(detector._detect(frame)) == 1
        assert detector.detect(frame) == [], f"the cube on the robot at u={cube_u} was kept"


def _detected(
    frame: np.ndarray,
    polygon: Polygon | str | None = None,
    *,
    table_area_px: Polygon | None = None,
    exclude: np.ndarray | None = None,
) -> Detection:
    """The one green detection with ``shadow_value_min`` 0.08 (hue bands, no reference)."""
    vision = VisionConfig(shadow_value_min=0.08, work_area_px=polygon)
    detector = ColorDetector(vision, None, default_classes(), table_area_px=table_area_px)
    found = detector.detect(frame, exclude=exclude)
    assert [d.color for d in found] == ["green"]
    return found[0]


#: A work area holding the disc of ``test_vision_shadows`` (centre (100, 100), radius 30).
AROUND: Polygon = [(20.0, 20.0), (180.0, 20.0), (180.0, 180.0), (20.0, 180.0)]


@pytest.mark.parametrize("polygon", [WHOLE_FRAME, AROUND])
def test_shadow_value_min_grows_regions_inside_a_given_work_area(polygon: str | Polygon) -> None:
    """The disc's shadowed third (``test_vision_shadows``) is found with a work area given
    (``whole_frame``, or a square holding the disc) as without one: its area within 2 %
    of the unshadowed disc's. It was cut off there (``shadow_value_min`` was unused)."""
    whole = _detected(_disc(shadowed=False)).area_px
    assert abs(_detected(_disc(shadowed=True)).area_px - whole) < 0.02 * whole
    assert abs(_detected(_disc(shadowed=True), polygon).area_px - whole) < 0.02 * whole


#: A work area whose left edge, column 75, crosses the disc's shadowed third (columns
#: 70 … 89): the disc's leftmost 5 columns lie outside it.
CUT: Polygon = [(75.0, 0.0), (199.0, 0.0), (199.0, 199.0), (75.0, 199.0)]


def test_shadows_grow_up_to_the_work_areas_edge_and_no_further() -> None:
    """The shadowed part inside the work area is grown into, the part outside is not: the
    region starts at column 75, the work area's edge, with the table's outline as the work
    area (the default one, where the shadows were grown past it to column 70) as with the
    same polygon given."""
    shadowed = _disc(shadowed=True)
    for found in (_detected(shadowed, table_area_px=CUT), _detected(shadowed, CUT)):
        assert found.bbox_px[0] in (75, 76), found.bbox_px


def test_shadows_are_not_grown_into_the_excluded_pixels() -> None:
    """Columns under 80 excluded (as the arm's mask is): the region starts at 80 (at 70,
    in the excluded pixels, when the shadows ignored the mask)."""
    exclude = np.zeros((200, 200), np.uint8)
    exclude[:, :80] = 255
    found = _detected(_disc(shadowed=True), exclude=exclude)
    assert found.bbox_px[0] in (80, 81), found.bbox_px
