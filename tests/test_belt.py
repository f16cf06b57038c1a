"""The conveyor belt: its config, its arrivals, and the kinematic world riding it."""

from __future__ import annotations

import math

import pytest
from conftest import ROOT

from mearm.config import config_from_dict, load_config
from mearm.config.belt_config import FOLLOW_SHARE, BeltConfig, follow_limit_cm_s
from mearm.exceptions import ConfigError, WorldError
from mearm.sim import World
from mearm.sim.belt import Belt, belt_arrivals

KINEMATIC = ROOT / "configs" / "sim_conveyor_kinematic.yaml"


@pytest.fixture(scope="module")
def config():
    return load_config(KINEMATIC)


def _with(config, **belt):
    data = config.model_dump(mode="json")
    data["belt"] = {**data["belt"], **belt}
    return config_from_dict(data)


def test_the_belt_geometry_round_trips():
    """A point put along and across the belt is read back where it was put."""
    belt = Belt(BeltConfig(start_cm=(5.0, 40.0), heading_deg=30.0, length_cm=20, width_cm=4))
    x, y = belt.point_cm(7.5, -1.25)
    assert belt.along_across_cm(x, y) == pytest.approx((7.5, -1.25))
    assert belt.carries(x, y) and not belt.carries(*belt.point_cm(7.5, 2.5))
    assert not belt.carries(*belt.point_cm(-0.1, 0.0))
    assert belt.velocity_cm_s == pytest.approx(
        [2.0 * math.cos(math.radians(30)), 2.0 * math.sin(math.radians(30))]
    )


def test_nearest_is_the_distance_from_the_base_axis_to_the_middle_line():
    """A belt along y = 47 cm passes 47 cm from the base axis; one that ends short, its end."""
    assert BeltConfig(
        start_cm=(19, 47), heading_deg=180, length_cm=31, width_cm=6
    ).nearest_cm() == (pytest.approx(47.0))
    short = BeltConfig(start_cm=(30, 40), heading_deg=180, length_cm=10, width_cm=6)
    assert short.nearest_cm() == pytest.approx(math.hypot(20, 40))


def test_arrivals_are_seeded_and_spaced(config):
    """The same seed brings the same objects; gaps within the bounds; ids go on per class."""
    a, b = belt_arrivals(config), belt_arrivals(config)
    assert a == b and len(a) == config.belt.arrivals.count
    gaps = [q.t_s - p.t_s for p, q in zip(a, a[1:], strict=False)]
    assert all(6.0 <= g <= 9.0 for g in gaps) and a[0].t_s == 1.0
    belt = Belt(config.belt)
    for arrival in a:
        along, across = belt.along_across_cm(arrival.x_cm, arrival.y_cm)
        assert along == pytest.approx(1.0) and abs(across) <= 1.5
    red = [x.id for x in a if x.color == "red"]
    assert red == [f"red{i}" for i in range(1, len(red) + 1)]
    assert belt_arrivals(_with(config, arrivals={"count": 20, "seed": 1})) != a


def test_the_world_brings_objects_at_their_times_and_carries_them(config):
    """An object appears at its arrival time and rides at the belt's speed, then drops off."""
    world = World.from_config(config)
    first = world.objects[0]
    assert world.table_objects() == [] and first.waiting
    world.advance(first.arrives_s - 0.01)
    assert world.table_objects() == []
    x0 = first.x_cm
    world.advance(2.01)  # 2 s after its arrival
    assert world.table_objects() == [first]
    assert first.x_cm == pytest.approx(x0 - 2 * config.belt.speed_cm_s)
    world.advance(100.0)  # past the downstream end (x = -12 cm): on the table beyond it
    assert first.on_table and first.x_cm == pytest.approx(-13.0)
    world.advance(10.0)
    assert first.x_cm == pytest.approx(-13.0)


def test_a_held_object_does_not_ride(config):
    """What the gripper holds stays where the gripper is."""
    world = World.from_config(config)
    world.advance(2.0)
    obj = world.table_objects()[0]
    world.grip(obj)
    x = obj.x_cm
    world.advance(3.0)
    assert obj.x_cm == x


def test_the_world_refuses_to_run_backwards(config):
    """Time only goes forward: a negative or NaN step is a WorldError."""
    world = World.from_config(config)
    for bad in (-1.0, math.nan):
        with pytest.raises(WorldError, match="cannot advance the world"):
            world.advance(bad)


def test_a_belt_faster_than_the_arm_follows_is_refused(config):
    """The bound is FOLLOW_SHARE of the first joint's TCP sweep at the belt; the message
    gives it and the numbers it comes from."""
    slow = config.model_dump(mode="json")
    slow["arm"]["joints"][0]["servo"]["seconds_per_60deg"] = 1.0  # 60 deg/s
    slow["belt"]["speed_cm_s"] = 30.0
    limit = follow_limit_cm_s(60.0, config.belt)
    assert limit == pytest.approx(FOLLOW_SHARE * math.radians(60) * 47.0)
    with pytest.raises(ConfigError) as err:
        config_from_dict(slow)
    text = str(err.value)
    assert "belt.speed_cm_s: 30 cm/s is faster than the arm can follow" in text
    assert f"at most {limit:.3g} cm/s" in text and "60 deg/s, 47 cm" in text


def test_gaps_must_be_ordered(config):
    """max_gap_s below min_gap_s is refused, naming both."""
    with pytest.raises(ConfigError, match="max_gap_s: 2 s is below min_gap_s"):
        _with(config, arrivals={"min_gap_s": 5.0, "max_gap_s": 2.0})
