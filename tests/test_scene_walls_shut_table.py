"""A random table whose grown walls shut every way from home to it is refused at once.

``mearm sort --config sim --random 34 --seed 34345`` with a wider green and a taller blue
grows 13 cm walls for its 12 reds beside home: every pick from home meets them as the arm
leaves it, so each layout drew its reds again until its 20,000 draws ran out, planning a
pick for most of them, and the refusal laid out four such tables (over 5 minutes, and no
word of the walls). The walls are now named, with a count whose table lays out.
"""

from __future__ import annotations

import re

import pytest

from mearm.config import load_config
from mearm.task.scene import SceneError, _walls_shut_table, random_scene

SETS = ("task.classes.green.diameter_cm=2.34", "task.classes.blue.height_cm=2.20")
SEED = 34345


def test_walls_that_shut_the_table_are_named_with_a_count_that_lays_out() -> None:
    config = load_config("sim", SETS).with_scene([])
    with pytest.raises(SceneError) as info:
        random_scene(config, 34, seed=SEED)
    text = str(info.value)
    assert text.startswith("class red: its bin's walls, built 13 cm tall to hold its 12 "), text
    assert "leave the arm no way from home to the table" in text, text
    assert "bin_red_wall" in text, text
    asked = re.search(r": ask for (\d+) or fewer, or set the class's bin_height_cm", text)
    assert asked is not None, text
    most = int(asked.group(1))
    assert len(random_scene(config, most, seed=SEED)) == most
    with pytest.raises(SceneError, match="no way from home to the table"):
        random_scene(config, most + 1, seed=SEED)


def test_a_table_with_a_way_in_passes_and_no_grown_wall_plans_nothing() -> None:
    config = load_config("sim", SETS).with_scene([])
    reds = ["red"] * 10 + ["green"] * 9 + ["blue"] * 9
    assert _walls_shut_table(config, reds) is None
    assert _walls_shut_table(config, []) is None  # (no wall grew: nothing planned)


def test_a_count_the_walls_by_home_take_but_whose_walls_shut_the_table_is_not_named() -> None:
    """``sim_shapes --random 38 --seed 34305`` (a taller red cylinder, a wider green
    prism): refused by the walls by home, which take 28, whose own walls shut the table;
    the refusal laid out 28 and the counts below it for over 5 minutes."""
    sets = ("task.classes.red_cylinder.height_cm=2.56", "task.classes.green_prism.diameter_cm=2.16")
    config = load_config("sim_shapes", sets).with_scene([])
    with pytest.raises(SceneError) as info:
        random_scene(config, 38, seed=34305)
    text = str(info.value)
    assert "of the arm at home" in text, text
    asked = re.fullmatch(r".*: ask for (\d+) or fewer", text)
    assert asked is not None, text
    most = int(asked.group(1))
    assert len(random_scene(config, most, seed=34305)) == most
    with pytest.raises(SceneError, match="no way from home to the table"):
        random_scene(config, most + 1, seed=34305)
