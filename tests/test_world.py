"""The simulated table shared by the sim camera and the sim arm."""

from __future__ import annotations

import pytest

from mearm.config import Config, SceneObject
from mearm.exceptions import WorldError
from mearm.world import World


@pytest.fixture
def world() -> World:
    return World.from_config(Config())


def test_from_config_names_objects_by_colour(world):
    """The paper's 12 objects, named red1..blue4 in scene order, all on the table."""
    assert [o.id for o in world.objects[:5]] == ["red1", "red2", "red3", "red4", "green1"]
    assert len(world.table_objects()) == 12 and world.held_object() is None
    assert (world.objects[0].x_cm, world.objects[0].y_cm) == (-10.99, 49.70)
    assert set(world.bins_cm) == {"red", "green", "blue"}


def test_nearest_on_table(world):
    obj, d = world.nearest_on_table(-0.40, 42.51)
    assert obj.id == "red3" and d == pytest.approx(0.5)
    assert World().nearest_on_table(0, 0) == (None, float("inf"))


def test_grip_and_release_into_bin(world):
    """A gripped object leaves the table; released into a bin it sits at the bin."""
    red3 = world.objects[2]
    world.grip(red3)
    assert world.held_object() is red3 and red3 not in world.table_objects()
    assert world.release_into_bin("blue") is red3
    assert red3.bin == "blue" and not red3.on_table and world.in_bin("blue") == [red3]
    assert (red3.x_cm, red3.y_cm) == (-20.0, 55.0)
    assert world.nearest_on_table(-20.0, 55.0)[0] is not red3


def test_release_on_table(world):
    obj = world.objects[0]
    world.grip(obj)
    world.release_on_table(5.0, 30.0)
    assert obj.on_table and (obj.x_cm, obj.y_cm) == (5.0, 30.0)


def test_nearest_bin(world):
    assert world.nearest_bin(-19.0, 46.0) == ("green", pytest.approx(2**0.5))
    assert World().nearest_bin(0, 0) == (None, float("inf"))


def test_impossible_changes(world):
    a, b = world.objects[:2]
    with pytest.raises(WorldError, match="nothing is held"):
        world.release_on_table(0, 0)
    world.grip(a)
    with pytest.raises(WorldError, match="red1 is already held"):
        world.grip(b)
    with pytest.raises(WorldError, match="no bin 'purple'"):
        world.release_into_bin("purple")  # type: ignore[arg-type]
    world.release_into_bin("red")
    with pytest.raises(WorldError, match="not on the table"):
        world.grip(a)


def test_from_scene():
    w = World.from_scene([SceneObject(color="blue", x=1, y=2)], {"blue": (0.0, 0.0, 0.0)})
    assert [(o.id, o.x_cm) for o in w.objects] == [("blue1", 1.0)]
