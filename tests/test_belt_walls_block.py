"""A belt whose objects grow a bin's walls across every way from home to it is refused.

``mearm sort --config sim_conveyor_kinematic --set belt.arrivals.count=45 --set
belt.arrivals.seed=22102`` built the red bin 13 cm tall for the 12 reds the belt brings,
beside where the arm hangs at home: each of the 45 picks was planned and refused for the
wall, ``sorted 0 of 45 objects``, after a run of a minute and more (44 sort whole). The
start now plans a pick from home along the belt and refuses the belt, one line, before
anything moves; the twin's belt refused the same table already (its release below the
walls).
"""

from __future__ import annotations

import pytest

from mearm.config import load_config
from mearm.task.scene import BELT_CHECK_POINTS, SceneError, check_scene

BELT = "sim_conveyor_kinematic"


def test_walls_that_shut_the_way_to_the_belt_are_refused_at_the_start() -> None:
    config = load_config(BELT, ["belt.arrivals.count=45", "belt.arrivals.seed=22102"])
    with pytest.raises(SceneError) as err:
        check_scene(config, [], "task.scene")
    text = str(err.value)
    assert text.startswith("class red: its bin's walls, built 13 cm tall to hold its 12 ")
    assert "leave the arm no way from home to the belt (a pick planned to each of " in text
    assert f"{BELT_CHECK_POINTS} points along it: collision: " in text and "bin_red_wall" in text
    assert text.endswith("bring fewer objects (belt.arrivals.count), or set the class's "
                         "bin_height_cm (task.classes)")  # fmt: skip


@pytest.mark.parametrize("count", [20, 44])
def test_a_belt_the_arm_reaches_from_home_is_not(count: int) -> None:
    config = load_config(BELT, [f"belt.arrivals.count={count}", "belt.arrivals.seed=22102"])
    check_scene(config, [], "task.scene")  # (44 sort 44 of 44)
