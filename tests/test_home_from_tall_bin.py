"""A place is sent only when the open jaws have a way up out of the bin from its release.

Walls grown tall for a class's objects (four 4.8 cm greens on ``configs/sim.yaml``: 24 cm,
above the release at 20 cm) leave the jaws, once open at the release, just clear of a
wall; straight up from there the wrist tilts them into it, and the way home found no
clear way: the sort stopped at its first green, the arm left in the bin (``not parked:
the way home gripper_jaw_right_finger comes within 0.30 cm of bin_green_wall_ny``; the
belt's ``--set belt.arrivals.count=49`` on ``sim_conveyor_kinematic``: 24 cm walls for
23 greens). The release is now raised to where the open jaws clear every wall, and the
object drops the rest (:meth:`mearm.task.plan.Planner.plan_place`).
"""

from __future__ import annotations

import re

import pytest
from conftest import run_main

from mearm import sort


def test_tall_greens_are_released_above_their_walls_and_the_arm_parks(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code, out, err = run_main(
        capsys, sort.main, "--config", "sim", "--set", "task.classes.green.height_cm=4.8"
    )
    assert code == 0, err
    assert "not parked" not in out + err
    assert out.strip().endswith("sorted 12 of 12 objects (simulated)")
    releases = {
        name: float(z)
        for name, z in re.findall(r"^place (\w+)\s+target \([^,]+,[^,]+,\s*([\d.]+)\)", out, re.M)
    }
    assert len(releases) == 12, out
    for name, z in releases.items():
        # the greens' 24 cm walls: released above them; the others' where they always were
        assert z > 24.0 if name.startswith("green") else z == 20.0, (name, z)
