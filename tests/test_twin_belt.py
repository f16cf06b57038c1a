"""The twin's conveyor belt: a moving surface (MuJoCo's surfacevel) carries what lies on it."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import config_from_dict, load_config
from mearm.exceptions import ConfigError, ModelError
from mearm.sim.belt import Belt, belt_arrivals
from mearm.sim.twin.mjcf import twin_model
from mearm.sim.twin.twin_bus import TwinArm

CONVEYOR = ROOT / "configs" / "sim_conveyor.yaml"


def _config(**belt):
    data = load_config(CONVEYOR).model_dump(mode="json")
    data["belt"] = {**data["belt"], **belt}
    return config_from_dict(data)


@pytest.fixture(scope="module")
def one_object():
    """The twin conveyor bringing one object at t = 0.2 s, at 3 cm/s."""
    config = _config(speed_cm_s=3.0, arrivals={"count": 1, "first_s": 0.2, "lateral_cm": 1.0})
    return config, TwinArm(config)


def test_the_belt_carries_an_object_at_its_speed(one_object):
    """It lands at its time where the arrivals put it, and rides at the belt's speed, along
    the belt only (no drift across), on the belt's surface."""
    config, twin = one_object
    (arrival,) = belt_arrivals(config)
    oid = arrival.id
    assert oid in twin.object_ids
    twin.settle(0.19)
    assert twin.object_pose(oid).position_cm[1] < -100  # still waiting, off the table
    twin.settle(0.71)  # 0.7 s on the belt: up to speed (the measured take-up is < 0.5 s)
    p0 = twin.object_pose(oid).position_cm
    twin.settle(1.0)
    pose = twin.object_pose(oid)
    belt = Belt(config.belt)
    moved = pose.position_cm[:2] - p0[:2]
    np.testing.assert_allclose(moved, belt.velocity_cm_s * 1.0, atol=0.01)
    assert pose.speed_cm_s == pytest.approx(3.0, abs=0.01)
    along, across = belt.along_across_cm(*pose.position_cm[:2])
    assert across == pytest.approx(belt.along_across_cm(arrival.x_cm, arrival.y_cm)[1], abs=0.01)
    height = config.task.class_named(arrival.color).height_cm
    assert pose.position_cm[2] == pytest.approx(config.belt.surface_cm + height / 2, abs=0.01)


def test_reset_puts_the_belts_objects_back_to_wait(one_object):
    """After a reset the object waits off the table again and arrives anew."""
    config, twin = one_object
    twin.reset()
    (arrival,) = belt_arrivals(config)
    assert twin.object_pose(arrival.id).position_cm[1] < -100
    twin.settle(0.21)
    assert twin.object_pose(arrival.id).position_cm[:2] == pytest.approx(
        [arrival.x_cm, arrival.y_cm], abs=0.05
    )


def test_a_belt_over_a_bin_is_refused():
    """The twin refuses a belt laid over a bin, naming the bin and what to change."""
    config = _config(start_cm=[19.0, 45.0], length_cm=40.0)
    with pytest.raises(ModelError, match="the belt runs over the bin of class green"):
        twin_model(config)


def test_a_belt_over_the_base_is_refused():
    """A belt across the arm's base is refused as the config loads, before any twin is
    built (the twin's own check, which refused it first, is now a second line)."""
    with pytest.raises(ConfigError, match="the belt crosses the arm's base"):
        _config(start_cm=[19.0, 2.0], arrivals={"count": 1})
