"""A lamp low to one side is not a moved view: the bins' shadows are not their feet.

A lamp low to the robot's left (25 cm up, 25 cm left of the bins, the room's ambient light
0.2 of white) casts each bin's shadow some 2.4 cm across the table beside its +x side,
the side the camera sees: the shaded table is as saturated as the lit one but darker than
a table-like pixel, so the bins' feet were seen where their shadows ended, all three
2.35 cm off alike, and an unbumped sort stopped on "the view moved" before its first
pick. The shaded table is told from a bin's wall by its colour: a line whose step leads
onto saturated pixels says nothing (:mod:`mearm.vision.bin_edges`). The sorts and frames
here are the MuJoCo twin's (simulated).
"""

from __future__ import annotations

import pytest
from conftest import ROOT
from test_camera_bump_bins import PARKED, TWO, _bump, _sort

from mearm.config import load_config
from mearm.task.table_tracking import check_bins
from mearm.vision.bin_edges import SHADE_CM, BinFeet
from mearm.vision.calibration import camera_geometry

CONFIG = ROOT / "configs" / "sim_mujoco_lamp.yaml"
#: A desk lamp low to the robot's left, pointed at the bins, in a dim room.
LOW_LAMP = (
    "twin.lamp.position_cm=[-45, 45, 25]",
    "twin.lamp.target_cm=[-20, 45]",
    "twin.lamp.ambient=0.2",
)


@pytest.mark.heavy
def test_the_bins_shadows_are_not_their_feet():
    """In the twin's frame under the low lamp every side measured is within SHADE_CM of its
    place (green's -y foot, 0.15 cm out, lies past a narrow shadow of its own; the +x
    sides' lines end in the wide shadows and say nothing: they were 2.35 cm off), and the
    look finds no moved view."""
    from mearm.sim.twin.twin_bus import TwinArm
    from mearm.sim.twin.twin_camera import TwinCamera

    config = load_config(CONFIG, [TWO, *LOW_LAMP])
    with TwinCamera(config, TwinArm(config)) as camera:
        frame = camera.read()
    geometry = camera_geometry(config.calibration, config.camera)
    size = (config.camera.width_px, config.camera.height_px)
    sides = BinFeet(geometry, list(config.task.classes), size).measure(frame)
    assert sides, "no side measured: the -y sides are lit"
    assert all(abs(s.offset_cm) <= SHADE_CM for s in sides), sides
    check_bins(sides, {}, "test")


@pytest.mark.heavy
def test_an_unbumped_sort_under_a_low_lamp_sorts(tmp_path, capsys):
    """No bump, the low lamp's shadows beside the bins: the sort sorts both objects."""
    code, err, trial = _sort(tmp_path, capsys, CONFIG, TWO, *LOW_LAMP)
    assert code == 0, err
    assert not trial.faults
    assert "view moved" not in err
    assert trial.summary is not None and trial.summary.ok


@pytest.mark.heavy
def test_a_bump_under_a_low_lamp_still_stops_the_sort(tmp_path, capsys):
    """The camera moved 2 cm along y before the first look, under the same lamp: the bins'
    lit -y sides show it, and the sort stops on the camera, the arm parked."""
    code, err, trial = _sort(tmp_path, capsys, CONFIG, TWO, *LOW_LAMP, _bump(0.0, [0, -2, 0]))
    assert code == 1, err
    (fault,) = trial.faults
    assert fault.reason.startswith("camera (twin): the view moved: the bins of "), fault.reason
    assert fault.reason.endswith(PARKED), fault.reason
