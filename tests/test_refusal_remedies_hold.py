"""A refusal's way out is one the user can take: following it is not refused in turn.

Found by a sweep of fresh seeds (34001–34300, 2026-12-08, simulated):

- the kinematic belt with ``task.classes.red.diameter_cm=1.59`` and 29 arrivals was
  refused "the arm at home … touches its bin: move the bin or arm.joints[].home": the
  bin's walls, built 10 cm tall for the nine reds the belt brings, reach the jaws hung at
  home; the same belt bringing 12 sorts whole. The line now names the walls and the count
  that grows them (``belt.arrivals.count``), as the clearance's line does;
- a 0.5 cm/s belt with gaps of 3.33–3.54 s was told ``belt.arrivals.min_gap_s at least
  5.34 s``, and that alone was then refused, ``max_gap_s: 3.54 s is below min_gap_s``: the
  line now says max_gap_s must rise with it.
"""

from __future__ import annotations

import pytest

from mearm.config import load_config
from mearm.errors import ConfigError
from mearm.task.check import check_consistency

NARROW_RED_BELT = [
    "belt.arrivals.seed=34096",
    "belt.speed_cm_s=3",
    "task.classes.red.diameter_cm=1.59",
]


def test_a_bin_whose_grown_walls_touch_the_arm_at_home_names_the_walls_and_the_count() -> None:
    config = load_config("sim_conveyor_kinematic", ["belt.arrivals.count=29", *NARROW_RED_BELT])
    with pytest.raises(ConfigError) as info:
        check_consistency(config)
    text = str(info.value)
    assert "task.classes.red.bin_cm: the arm at home (gripper_jaw_" in text, text
    assert (
        "touches its bin: move the bin or arm.joints[].home, or lower its walls: 10 cm, "
        "built to hold its 9 objects (1 cm high) stacked (fewer objects "
        "(belt.arrivals.count) or lower ones, or task.classes.red.bin_height_cm)" in text
    ), text
    # fewer arrivals, as it says: the walls no longer reach the arm
    check_consistency(
        load_config("sim_conveyor_kinematic", ["belt.arrivals.count=12", *NARROW_RED_BELT])
    )


def test_walls_grown_by_tall_objects_name_lower_ones_on_a_still_table() -> None:
    # one red 4.5 cm tall in a narrow bin: its walls, 9 cm, reach the jaws the paper arm
    # hangs in it at home
    config = load_config("sim", [
        "task.classes.red.height_cm=4.5", "task.classes.red.diameter_cm=1.59",
        "task.scene=[{color: red, x: 0, y: 45}]",
    ])  # fmt: skip
    with pytest.raises(ConfigError) as info:
        check_consistency(config)
    text = str(info.value)
    assert "task.classes.red.bin_cm: the arm at home (gripper_jaw_" in text, text
    assert (
        "touches its bin: move the bin or arm.joints[].home, or lower its walls: 9 cm, "
        "built to hold its 1 objects (4.5 cm high) stacked (fewer or lower objects, or "
        "task.classes.red.bin_height_cm)" in text
    ), text


GAPS = [
    "belt.arrivals.count=8",
    "belt.arrivals.seed=34189",
    "belt.speed_cm_s=0.5",
    "task.classes.red.diameter_cm=2.67",
]


def test_a_min_gap_named_past_max_gap_says_max_gap_rises_with_it() -> None:
    with pytest.raises(ConfigError) as info:
        load_config(
            "sim_conveyor_kinematic",
            [*GAPS, "belt.arrivals.min_gap_s=3.33", "belt.arrivals.max_gap_s=3.54"],
        )
    text = str(info.value)
    assert (
        "belt.arrivals.min_gap_s at least 5.34 s (and max_gap_s, now 3.54 s, at least as "
        "much), a faster belt" in text
    ), text
    # both raised as it says: taken
    load_config(
        "sim_conveyor_kinematic",
        [*GAPS, "belt.arrivals.min_gap_s=5.34", "belt.arrivals.max_gap_s=5.34"],
    )


def test_a_min_gap_named_within_max_gap_says_nothing_of_max_gap() -> None:
    with pytest.raises(ConfigError) as info:
        load_config(
            "sim_conveyor_kinematic",
            [*GAPS, "belt.arrivals.min_gap_s=3.33", "belt.arrivals.max_gap_s=9"],
        )
    text = str(info.value)
    assert "belt.arrivals.min_gap_s at least 5.34 s, a faster belt" in text, text
