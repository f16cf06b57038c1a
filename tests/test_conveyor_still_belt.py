"""A belt sort whose left object stays in view ends, as one whose objects ride off does.

The belt's run ends once nothing to sort has been seen for a while. It counted any
sighting: on a still belt (``belt.speed_cm_s=0``) an object whose pick failed stays in
view for ever, and the sort waited for ever, seeing it (a fresh-seed sweep killed it after
300 s, ``sorted 1 of 6``; its arrivals, landing on one another, are now refused at load:
tests/test_belt_arrivals_apart.py). Only objects still to sort keep the run waiting now.
"""

from __future__ import annotations

import subprocess

import pytest
from conftest import ROOT, mearm_cli

pytestmark = pytest.mark.heavy

#: One object on a still belt by the blue bin: its pick is refused (the jaws come near the
#: bin's wall: a collision) and it stays where it lay, in view.
STILL = [
    "belt.arrivals.count=1",
    "belt.speed_cm_s=0",
    "belt.start_cm=[-19.0,57.0]",
    "belt.heading_deg=0",
    "belt.length_cm=3",
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
    # its pick refused for the blue bin's wall: counted as a collision, not as an object
    # the belt took past the arm (every pick of 45 refused by grown walls said "45 missed
    # on the belt")
    assert line == "mearm sort: sorted 0 of 1 objects (simulated; 1 no route clear of collisions)"
