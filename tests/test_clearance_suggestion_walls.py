"""A clearance a refusal at home names is one the sort then starts with, walls and all.

``mearm sort --config sim_conveyor_kinematic --set belt.arrivals.count=500 --set
belt.arrivals.seed=26106`` builds the bins' walls for what the belt brings (170 cm for
169 reds, 179 cm for 178 greens); the arm at home keeps 0.11 cm from the red bin's, and the
refusal said ``task.clearance_cm … at most 0.11 cm``. With that clearance the sort was
refused again: the green bin's walls leave the arm no way in with one held (as ``--config
sim_shapes --set task.clearance_cm=9`` named 3.30 cm, with which the cube's bin was shut).
A clearance is now named only when the arm at it still gets into every bin from home.
"""

from __future__ import annotations

import re

import pytest

from mearm.config import Config, load_config
from mearm.errors import ConfigError
from mearm.task.check import check_consistency
from mearm.task.scene import check_scene

#: The belt's arrivals whose walls the arm at home keeps 0.11 cm from, and shut green's bin.
TALL_WALLS = ["belt.arrivals.count=500", "belt.arrivals.seed=26106"]


def _starts(config: Config) -> None:
    """The checks a sort on a simulated table passes before it starts."""
    check_consistency(config)
    check_scene(config, config.task.scene)


def _named(text: str) -> list[str]:
    return re.findall(r"bin at home \(\w+, [\d.]+ cm\)[^;]*?: at most ([\d.]+) cm", text)


@pytest.mark.parametrize(
    ("name", "overrides"),
    [
        ("sim_conveyor_kinematic", TALL_WALLS),
        ("sim", ["task.clearance_cm=9"]),  # named, and taken (tests/test_clearance_suggestion.py)
        # 3.30 cm at home, where the cube held comes within it of its bin's walls: 1.58 cm
        ("sim_shapes", ["task.clearance_cm=9"]),
    ],
)
def test_a_named_clearance_lets_the_sort_start(name: str, overrides: list[str]) -> None:
    with pytest.raises(ConfigError) as caught:
        _starts(load_config(name, overrides))
    text = str(caught.value)
    assert "task.clearance_cm" in text, text
    named = _named(text)
    if named:  # one figure per bin too near: the least is the one that holds for all
        least = min(named, key=float)
        _starts(load_config(name, [*overrides, f"task.clearance_cm={least}"]))


def test_walls_no_clearance_gets_past_say_so_and_name_none() -> None:
    with pytest.raises(ConfigError) as caught:
        check_consistency(load_config("sim_conveyor_kinematic", TALL_WALLS))
    text = str(caught.value)
    assert _named(text) == [] and "at most" not in text, text
    # red's own walls (170 cm) leave the jaws opened at its release no way up, at any
    # clearance; green's (179 cm) shut its way in too
    assert "no clearance leaves the arm a way into red's bin" in text, text
    assert "lower its walls" in text, text  # the way out that holds: fewer objects
