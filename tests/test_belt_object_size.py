"""A belt's arrivals land every object wholly on the belt, its size counted.

``belt.arrivals.lateral_cm`` was checked against half the belt's width for the object's
centre only, so an object near the edge hung off it by its footprint's radius. The
classes' sizes are the task's, the offset the belt's: the whole config checks both.
Real parts: the shipped belt configs and the loader; ``mearm sort``'s one line (exit 2)
is tests/test_conveyor_honest.py's.
"""

from __future__ import annotations

import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.errors import ConfigError

#: A 6 cm belt (3 cm either side of its middle line) bringing 2 cm cylinders (1 cm radius).
KINEMATIC = ROOT / "configs" / "sim_conveyor_kinematic.yaml"


@pytest.mark.parametrize("config", ["sim_conveyor_kinematic.yaml", "sim_conveyor.yaml"])
def test_the_shipped_belts_land_their_objects_on_the_belt(config):
    """1.5 cm off the middle line, a 1 cm radius: 2.5 cm of the belt's 3 cm."""
    assert load_config(ROOT / "configs" / config).belt is not None


def test_an_object_hanging_off_the_edge_is_refused_with_both_numbers():
    """Its centre 2.5 cm out is on the belt, its edge 3.5 cm out is not: refused, naming the
    offset, the object's radius, the half width and what is allowed (2 cm, taken)."""
    with pytest.raises(ConfigError) as caught:
        load_config(KINEMATIC, ["belt.arrivals.lateral_cm=2.5"])
    (problem,) = caught.value.problems
    assert problem == (
        "belt.arrivals.lateral_cm: 2.5 cm would land objects off the belt: that offset plus "
        "the footprint radius of the largest object of task.classes (red, 1 cm) is 3.5 cm, "
        "beyond half the belt's width (width_cm 6 cm), 3 cm: at most 2 cm"
    )
    assert load_config(KINEMATIC, ["belt.arrivals.lateral_cm=2"]).belt.arrivals.lateral_cm == 2


def test_the_largest_class_decides():
    """A 2 cm cube reaches 1.414 cm out at 45°: with it among the classes, 1.58 cm (shown
    rounded down, so it is taken) is the most; the cylinders alone allowed 2 cm."""
    cube = ["task.classes.green.shape=cube", "task.classes.green.hue_bands_deg=null"]
    with pytest.raises(
        ConfigError, match=r"\(green, 1\.414 cm\) is 3\.414 cm.*: at most 1\.58 cm$"
    ):
        load_config(KINEMATIC, [*cube, "belt.arrivals.lateral_cm=2"])
    assert load_config(KINEMATIC, [*cube, "belt.arrivals.lateral_cm=1.58"]).belt is not None


def test_a_belt_narrower_than_its_objects_allows_no_offset():
    """A 1.5 cm belt cannot carry 2 cm cylinders, not even along its middle line."""
    with pytest.raises(ConfigError, match=r"none: its red objects \(2 cm across\) are wider than"):
        load_config(KINEMATIC, ["belt.width_cm=1.5", "belt.arrivals.lateral_cm=0"])


def test_a_belt_shorter_than_an_object_is_refused():
    """``belt.length_cm`` 0.5 landed every 2 cm object past the end, on the table, and the
    sort said "never seen by the camera"; 2 cm holds one."""
    with pytest.raises(ConfigError) as caught:
        load_config(KINEMATIC, ["belt.length_cm=0.5"])
    (problem,) = caught.value.problems
    assert problem == (
        "belt.length_cm: 0.5 cm is shorter than the largest object of task.classes (red, "
        "2 cm across), which would land past the belt's end: at least 2 cm"
    )
    assert load_config(KINEMATIC, ["belt.length_cm=2"]).belt is not None
