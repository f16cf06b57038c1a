"""On a grey table an object beside a bin's side is not the bin's foot.

The bins' check reads a foot where the table-like pixels (saturated and lit) end and the
bin's unsaturated wall begins. On a grey table the only saturated things are the objects:
a line across a bin's side that ran from an object onto the grey table beside it looked
like a foot. ``mearm sort --config sim_4colours --random 24 --seed 13003`` (the kinematic
simulator's camera: a grey table, the bins beyond the frame's edge) stopped at its first
look, "the view moved: the bins of red, yellow … appear up to 2.75 cm from where the
calibration puts them", each bin on one side of three lines crossing one object. A side
is now measured only where most of what its lines saw before its foot is table-like
(:data:`~mearm.vision.bin_edges.TABLE_SHARE`): the table stands out from the bin there.
"""

from __future__ import annotations

import pytest
from conftest import run_main

from mearm import sort
from mearm.backends import open_camera, table_world
from mearm.config import load_config
from mearm.task.scene import random_scene
from mearm.task.table_tracking import check_bins
from mearm.vision.bin_edges import BinFeet
from mearm.vision.calibration import camera_geometry


def test_objects_on_a_grey_table_are_no_bins_feet() -> None:
    config = load_config("sim_4colours")
    scene = random_scene(config, 24, seed=13003)
    frame = open_camera(config, table_world(config, scene)).read()
    geometry = camera_geometry(config.calibration, config.camera)
    size = (config.camera.width_px, config.camera.height_px)
    sides = BinFeet(geometry, list(config.task.classes), size).measure(frame)
    assert sides == []  # the grey table does not stand out from the bins: nothing measured
    check_bins(sides, {}, "test")


def test_the_sort_of_that_table_sorts(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_main(
        capsys, sort.main, "--config", "sim_4colours", "--random", 24, "--seed", 13003, "--quiet"
    )
    assert code == 0, err
    assert "view moved" not in out + err
    assert out.strip().endswith("sorted 24 of 24 objects (simulated)")
