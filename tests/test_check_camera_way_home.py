"""``mearm check-camera`` goes home from each set-down the sort's checked way.

Until 2026-12-07 it went home from above each point along the straight line in joint
space unchecked: a bin standing between the points and home (the kinematic sim's paper
arm, its green bin moved there) had the jaws driven into its wall, and the simulated
servos stopped the check with ``the arm ran into something``. Now the line is checked
(:func:`mearm.task.homing.go_home`, the sort's way home): the arm rises and goes over, or
where nothing is clear, sends nothing more and says so in one line.
"""

from __future__ import annotations

import re

import pytest
from conftest import ROOT

SIM = str(ROOT / "configs" / "sim.yaml")


def _check(capsys: pytest.CaptureFixture[str], *sets: str) -> tuple[int, str, str]:
    from mearm.tools.check_camera import main

    argv = ["--config", SIM]
    for s in sets:
        argv += ["--set", s]
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_a_wall_on_the_straight_way_home_is_gone_over(capsys):
    """The green bin between the first point and home: the arm goes over its wall."""
    code, out, err = _check(
        capsys, "task.classes.green.bin_cm=[-13, 42, 20]", "task.classes.green.bin_height_cm=7"
    )
    assert "ran into" not in err, err
    assert code == 0, err
    assert len(re.findall(r"^point \d+: commanded .* \|r\| ", out, re.M)) == 4, out
    assert "residual: rms" in out


def test_no_clear_way_home_is_refused_in_one_line(capsys):
    """Tall walls beside home: no way home is clear; nothing more is sent, one line."""
    code, out, err = _check(
        capsys, "task.classes.green.bin_cm=[-20, 41, 25]", "task.classes.green.bin_height_cm=11"
    )
    assert code == 1
    assert "ran into" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert re.fullmatch(
        r"mearm check-camera: check stopped: not parked: the way home \S+ comes within "
        r"[\d.]+ cm of bin_green_wall_\w+ at \(.*\); the arm stays where it is",
        lines[0],
    ), lines[0]
    assert "Traceback" not in err
