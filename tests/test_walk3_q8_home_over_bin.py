"""The way home from over another bin, to a home that hangs the jaws over the red bin.

The paper arm's home holds the TCP about 20 cm over the red bin, the open jaws between its
walls. A belt's sort goes home after every catch. From over the green bin (belt seed
997000, the twin's or the kinematic simulator's belt) the straight joint line home sank
onto the red bin's wall as it came in, and rising to the safe height first did not help:
the sort stopped after its second object with ``not parked: the way home
gripper_jaw_left_pad comes within 0.30 cm of bin_red_wall_py``, exit 1. Home is now come
down to from over it when the straight way is not clear.
"""

from __future__ import annotations

import pytest

from mearm.config import load_config
from mearm.config.belt_config import belt_classes
from mearm.task.rig import run_sort


@pytest.mark.heavy
def test_a_belt_sort_goes_home_from_the_green_bin_over_the_red_bin() -> None:
    """The seed's first 3 arrivals (red, green, blue: a shorter belt draws the same first
    ones), the failing way home, after the green, between the second and the third."""
    config = load_config(
        "configs/sim_conveyor.yaml",
        overrides=["simulator=kinematic", "belt.arrivals.seed=997000", "belt.arrivals.count=3"],
    )
    assert belt_classes(config.belt, config.task.classes) == ["red", "green", "blue"]
    report = run_sort(config, echo=None)  # raised SortAborted (not parked) before
    assert report.complete
    assert report.outcome.n_sorted == report.outcome.n_objects == 3
