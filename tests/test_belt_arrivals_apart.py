"""A belt whose arrivals would land on one another is refused at load.

Each object lands its footprint's radius down from the belt's upstream end; one brought
before has ridden ``speed_cm_s`` times the gap on since. ``--set belt.speed_cm_s=0`` with
arrivals 0.2 to 0.3 s apart landed the second object on the first: the camera saw one
region, a pick failed, and the sort waited for ever on the object it left (a fresh-seed
sweep, seed 16213). Such a belt is now one line naming the two arrivals and the way out.
"""

from __future__ import annotations

import pytest

from mearm.config import load_config
from mearm.errors import ConfigError

ARRIVALS = [
    "belt.arrivals.min_gap_s=0.2",
    "belt.arrivals.max_gap_s=0.3",
    "belt.arrivals.seed=16213",
]


def test_a_still_belt_with_two_arrivals_is_refused() -> None:
    with pytest.raises(ConfigError) as info:
        load_config(
            "sim_conveyor_kinematic",
            overrides=["belt.speed_cm_s=0", "belt.arrivals.count=2", *ARRIVALS],
        )
    message = str(info.value)
    assert "belt.arrivals: arrival 2 (green, at 1.24 s) lands on arrival 1 (green" in message
    assert "a still belt lands them on one spot" in message


def test_arrivals_too_close_for_the_belts_speed_name_the_gap_that_clears_them() -> None:
    with pytest.raises(ConfigError, match=r"belt\.arrivals\.min_gap_s at least 2 s"):
        load_config(
            "sim_conveyor_kinematic",
            overrides=["belt.speed_cm_s=1", "belt.arrivals.count=5",
                       "belt.arrivals.min_gap_s=0.5", "belt.arrivals.max_gap_s=1"],
        )  # fmt: skip


@pytest.mark.parametrize("overrides", [
    ["belt.speed_cm_s=0", "belt.arrivals.count=1"],  # one object: nothing to land on
    ["belt.speed_cm_s=1", "belt.arrivals.count=5", "belt.arrivals.min_gap_s=2",
     "belt.arrivals.max_gap_s=3"],  # the gap the refusal above names
    [],  # the config's own belt
])  # fmt: skip
def test_arrivals_that_land_clear_load(overrides: list[str]) -> None:
    assert load_config("sim_conveyor_kinematic", overrides=overrides).belt is not None
