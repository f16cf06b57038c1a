"""A knocked camera is caught however far it moved the view, and nothing else is taken for one.

A view moved farther than the tracker's ``SAME_OBJECT_CM`` (1.5 cm) left none of the
objects the arm did not go near matched where they lay: they looked gone and new ones
appeared, no common shift was seen, and the sort went on picking on the moved view (a 2 cm
bump: 27 picks failed, run log ``ok: true``; simulated). The sorts here are the MuJoCo
twin's (simulated); the looks of the unit tests are made up.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.runlog import read_runlog
from mearm.sort import main as sort_main
from mearm.task.table_tracking import Seen, TableTracking, TrackedObject
from mearm.vision import Detection
from mearm.vision.errors import CameraError

CONFIG = ROOT / "configs" / "sim_mujoco.yaml"
THREE = (
    "task.scene=[{color: red, x: -5, y: 45}, {color: green, x: 6, y: 50}, "
    "{color: blue, x: 8, y: 40}]"
)
AREA_PX = 300


@pytest.mark.heavy
@pytest.mark.parametrize("shift_cm", [(2, 0, 0), (0, 3, 0), (-3.5, -3.5, 0), (0, -5, 0)], ids=str)
def test_a_camera_knocked_farther_than_an_object_is_matched_stops_the_sort(
    shift_cm, tmp_path, capsys
):
    """The camera moved 2, 3, 4.9 or 5 cm between the first look and the one over the bin
    (simulated): the sort stops on the camera, the arm parked, exit 1, the run log's fault
    says so and its summary is not ok; the shift said is the twin's, the other way."""
    log = tmp_path / "run.jsonl"
    bump = f"{{kind: camera_bump, at_s: 1.0, shift_cm: {list(shift_cm)}}}"
    code = sort_main(
        ["--config", str(CONFIG), "--set", THREE, "--set", f"twin.faults=[{bump}]",
         "--log", str(log), "--quiet"]
    )  # fmt: skip
    err = capsys.readouterr().err
    assert code == 1, err
    (trial,) = read_runlog(log, strict=True).trials
    (fault,) = trial.faults
    reason = fault.reason
    assert reason.startswith("camera (twin): the view moved: green1, blue1, "), reason
    assert reason.endswith("was the camera knocked? Fix its mount and recalibrate "
                           "(tools/calibrate_camera.py); arm parked at home")  # fmt: skip
    by = re.search(r"by \((\S+), (\S+)\) cm", reason)
    assert by is not None, reason
    # (2 % more: the homography places the objects' tops, nearer the camera, on the table)
    np.testing.assert_allclose([float(v) for v in by.groups()], np.negative(shift_cm[:2]),
                               rtol=0.05, atol=0.02)  # fmt: skip
    assert trial.summary is not None and not trial.summary.ok
    assert "mearm sort: stopped: camera (twin): the view moved" in err
    (pick,) = trial.routes  # the first pick, never confirmed: the look failed
    assert pick.step == "pick" and not pick.confirmed


# --- the tracking's looks, made up -------------------------------------------------------


@pytest.fixture(scope="module")
def config():
    return load_config(ROOT / "configs" / "sim.yaml")


class _Camera:
    source = "test"


def _tracking(config, objects: list[tuple[str, float, float]]) -> TableTracking:
    """A table tracking that knows ``objects`` (class, x, y [cm]), seen whole, none picked."""
    t = TableTracking.__new__(TableTracking)
    t.config, t.camera, t.view = config, _Camera(), None  # type: ignore[assignment]
    t._active, t._active_from_cm, t._seen_px = None, (0.0, 0.0), None
    t._objects = [
        TrackedObject(f"{c}{i + 1}", c, x, y, area_px=AREA_PX)
        for i, (c, x, y) in enumerate(objects)
    ]
    return t


def _seen(points: list[tuple[str, float, float]]) -> Seen:
    """Whole detections (well inside the frame) of these classes at these places [cm]."""
    return [
        (
            Detection(
                c, np.array([320.0, 240.0]), AREA_PX, (300, 220, 40, 40), table_cm=np.array([x, y])
            ),  # fmt: skip
            np.array([x, y]),
        )
        for c, x, y in points
    ]


SCATTERED = [("red", -6.0, 45.0), ("green", 5.0, 50.0), ("blue", 8.0, 40.0), ("red", 0.0, 42.0)]


@pytest.mark.parametrize("shift", [(2.0, 0.0), (0.0, -3.0), (-2.5, 2.5), (5.0, 1.0)], ids=str)
def test_a_view_moved_farther_than_an_object_is_matched_is_a_knocked_camera(config, shift):
    """Every object moved by one shift over 1.5 cm: the camera was knocked, on a look that
    starts new objects and on one while the jaws hold one."""
    for track_new in (True, False):
        t = _tracking(config, SCATTERED)
        moved = [(c, x + shift[0], y + shift[1]) for c, x, y in SCATTERED]
        with pytest.raises(CameraError, match="the view moved: red1, green2, blue3, red4, "):
            t._track(_seen(moved), track_new=track_new)


def test_a_view_moved_far_with_objects_hidden_and_one_picked_is_still_seen(config):
    """The arm took one object and hides another; the three others moved 2.5 cm alike."""
    objects = [*SCATTERED, ("green", -10.0, 52.0)]
    t = _tracking(config, objects)
    t._active = t._objects[0]
    t._active_from_cm = (-6.0, 45.0)
    moved = [(c, x + 2.5, y) for c, x, y in objects[2:]]
    with pytest.raises(CameraError, match=r"blue3, red4, green5, .* 2\.50 cm .*\(2\.50, 0\.00\)"):
        t._track(_seen(moved))


def test_a_grid_seen_where_it_lay_is_not_a_moved_view(config):
    """A row of reds 3 cm apart, two of them hidden by the arm, and a new one at the row's
    end: a shift by the pitch maps most of the row onto detections, but those objects are
    seen where they lay, so nothing moved: no fault, the new red is a new object."""
    row = [("red", -6.0 + 3.0 * i, 45.0) for i in range(6)]
    t = _tracking(config, row)
    t._track(_seen([*row[2:], ("red", 12.0, 45.0)]))


def test_a_grid_shifted_by_less_than_its_pitch_is_a_moved_view(config):
    """The same row, the view moved 2 cm along it: none where it lay, all moved alike."""
    row = [("red", -6.0 + 3.0 * i, 45.0) for i in range(6)]
    t = _tracking(config, row)
    with pytest.raises(CameraError, match=r"the view moved: red1, .* 2\.00 cm"):
        t._track(_seen([(c, x + 2.0, y) for c, x, y in row]))


def test_objects_the_arm_went_near_moving_alike_are_not_a_moved_view(config):
    """The jaws took red1 and pushed its neighbour 2 cm; the other two are where they lay."""
    objects = [("red", 0.0, 45.0), ("green", 1.5, 46.5), ("blue", 8.0, 40.0), ("red", -8.0, 52)]
    t = _tracking(config, objects)
    t._active, t._active_from_cm = t._objects[0], (0.0, 45.0)
    t._track(_seen([("red", 2.0, 45.0), ("green", 3.5, 46.5), *objects[2:]]))
    assert [o.id for o in t._objects] == ["red1", "green2", "blue3", "red4"]


def test_two_moved_of_five_are_not_a_moved_view(config):
    """Two objects moved alike by 2 cm while three stayed: not most of them, no fault."""
    objects = [*SCATTERED, ("green", -10.0, 52.0)]
    t = _tracking(config, objects)
    moved = [(c, x + 2.0, y) for c, x, y in objects[:2]]
    t._track(_seen([*moved, *objects[2:]]))


def test_objects_revealed_where_others_hid_are_not_a_moved_view(config):
    """Both objects left alone are hidden by the arm now, and two objects no look saw before
    (it hid them) appear 2 cm from them alike: objects revealed, not the view moved."""
    objects = [("red", -6.0, 45.0), ("green", 5.0, 50.0)]
    t = _tracking(config, objects)
    revealed = [(c, x + 2.0, y) for c, x, y in objects]
    t._track(_seen(revealed), revealed={0, 1})
