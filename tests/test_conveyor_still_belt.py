"""A belt sort whose left object stays in view ends, as one whose objects ride off does.

The belt's run ends once nothing to sort has been seen for a while. It counted any
sighting: on a still belt (``belt.speed_cm_s=0``) an object whose pick failed stays in
view for ever, and the sort waited for ever, seeing it (a fresh-seed sweep killed it after
300 s, ``sorted 1 of 6``). Only objects still to sort keep the run waiting now.
"""

from __future__ import annotations

import subprocess

import pytest
from conftest import ROOT, mearm_cli

pytestmark = pytest.mark.heavy

#: Two arrivals 0.2 to 0.3 s apart on a belt that does not move: the first's pick fails
#: (the second landed against it) and it stays where it lay.
STILL = [
    "belt.arrivals.count=2",
    "belt.speed_cm_s=0",
    "belt.arrivals.min_gap_s=0.2",
    "belt.arrivals.max_gap_s=0.3",
    "belt.arrivals.seed=16213",
]


def test_an_object_left_on_a_still_belt_does_not_keep_the_sort_running() -> None:
    """In a process of its own: the hang is the failure, and a timeout ends a process."""
    sets = [a for s in STILL for a in ("--set", s)]
    try:
        out = mearm_cli("sort", "--config", "sim_conveyor_kinematic", "--quiet", *sets,
                        cwd=ROOT, timeout=120)  # fmt: skip
    except subprocess.TimeoutExpired:
        pytest.fail("the sort of a still belt ran on past 120 s")
    assert out.returncode == 1, out.stderr[-2000:]
    line = out.stderr.strip().splitlines()[-1]
    assert line.startswith("mearm sort: sorted 0 of 2 objects (simulated; 1 pick failed"), line
