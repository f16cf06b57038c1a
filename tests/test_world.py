"""The simulated table shared by the sim camera and the sim arm."""

from __future__ import annotations

import importlib.util

import pytest

import mearm.sim
from mearm.config import ColorClass, Config, HueBand, SceneObject, TaskConfig, default_classes
from mearm.exceptions import WorldError
from mearm.sim import World


@pytest.fixture
def world() -> World:
    return World.from_config(Config())


def test_from_config_names_objects_by_class(world):
    """The paper's 12 objects, named red1..blue4 in scene order, all on the table."""
    assert [o.id for o in world.objects[:5]] == ["red1", "red2", "red3", "red4", "green1"]
    assert len(world.table_objects()) == 12 and world.held_object() is None
    assert (world.objects[0].x_cm, world.objects[0].y_cm) == (-10.99, 49.70)
    assert set(world.bins_cm) == {"red", "green", "blue"}
    assert world.bins_cm == {c.name: c.bin_cm for c in Config().task.classes}


def test_any_classes_get_their_bins():
    """A fourth class from the config has its bin and its objects; one class works too."""
    yellow = ColorClass(
        name="yellow",
        hue_bands_deg=[HueBand(lo_deg=45, hi_deg=65)],
        draw_rgb=(230, 200, 30),
        bin_cm=(-20.0, 25.0, 20.0),
    )
    scene = [SceneObject(color="yellow", x=0, y=35), SceneObject(color="red", x=1, y=40)]
    w = World.from_config(
        Config(task=TaskConfig(classes=[*default_classes(), yellow], scene=scene))
    )
    assert list(w.bins_cm) == ["red", "green", "blue", "yellow"]
    assert [o.id for o in w.objects] == ["yellow1", "red1"]
    w.grip(w.objects[0])
    assert w.release_into_bin("yellow").bin == "yellow"
    assert (w.objects[0].x_cm, w.objects[0].y_cm) == (-20.0, 25.0)
    (blue,) = default_classes()[2:]
    one = Config(task=TaskConfig(classes=[blue], scene=[SceneObject(color="blue", x=0, y=40)]))
    assert World.from_config(one).bins_cm == {"blue": blue.bin_cm}


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


def test_in_bin_is_the_class_rule(world):
    """A dropped object counts in the bin whose walls it lies within (``ColorClass.in_bin``)."""
    red, obj = world.bins["red"], world.objects[0]
    world.grip(obj)
    world.release_into_bin("red")
    assert world.in_bin("red") == [obj] and red.in_bin(obj.x_cm, obj.y_cm)
    assert world.in_bin("blue") == [] and world.in_bin("purple") == []
    obj.x_cm = red.bin_cm[0] + red.bin_inner_width_cm / 2 + 0.01  # beyond the wall
    assert not red.in_bin(obj.x_cm, obj.y_cm) and world.in_bin("red") == []


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
        world.release_into_bin("purple")
    world.release_into_bin("red")
    with pytest.raises(WorldError, match="not on the table"):
        world.grip(a)


def test_from_scene():
    blue = default_classes()[2]
    w = World.from_scene([SceneObject(color="blue", x=1, y=2)], [blue])
    assert [(o.id, o.x_cm) for o in w.objects] == [("blue1", 1.0)]
    assert w.bins == {"blue": blue} and w.bins_cm == {"blue": blue.bin_cm}


def test_sim_package_exports():
    """Every name of mearm.sim.__all__ exists; the servo bus's are loaded on first access."""
    lazy = {"SimArm", "GripResult", "ReleaseResult", "quantize_deg"}
    assert lazy <= set(mearm.sim.__all__)
    assert sorted(mearm.sim.__all__) == sorted(set(mearm.sim.__all__))
    for name in sorted(set(mearm.sim.__all__) - lazy):
        assert getattr(mearm.sim, name) is not None, name
    if importlib.util.find_spec("mearm.sim.kinematic.servo_bus") is None:
        with pytest.raises(ModuleNotFoundError, match="mearm.sim.kinematic.servo_bus"):
            mearm.sim.SimArm  # noqa: B018
    else:
        for name in sorted(lazy):
            assert getattr(mearm.sim, name) is not None, name
    with pytest.raises(AttributeError, match="no attribute 'Nope'"):
        mearm.sim.Nope  # noqa: B018
