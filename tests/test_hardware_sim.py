"""The simulated arm: error model, picks within tolerance, places into bins."""

from __future__ import annotations

import numpy as np
import pytest
from hardware_helpers import HOME

from mearm.config import Config, config_from_dict
from mearm.exceptions import ConfigError, JointLimitError, ServoNotConnectedError
from mearm.hardware import ArmCommand, SimArm, open_bus
from mearm.hardware.sim import ee_from_joints_cm, quantization_ee_error_cm
from mearm.kinematics import analytic_ik_deg
from mearm.world import World

GRIP_DEG = -60.0


def sim(world: World | None = None, **servo) -> SimArm:
    cfg = config_from_dict({"servo": servo}) if servo else Config()
    bus = open_bus(cfg, world=world if world is not None else World.from_config(cfg))
    assert isinstance(bus, SimArm)
    bus.connect()
    return bus


def above(x: float, y: float, z: float, config: Config | None = None) -> tuple[float, ...]:
    q = analytic_ik_deg((x, y, z), (config or Config()).robot)
    return tuple(q[:3])


def pick_at(bus: SimArm, x: float, y: float, z: float | None = None) -> None:
    z = bus.config.robot.gripper.pick_height_cm if z is None else z
    joints = above(x, y, z)
    bus.move(ArmCommand(joints, GRIP_DEG, False))
    bus.move(ArmCommand(joints, GRIP_DEG, True))


def test_open_bus_needs_world_for_sim():
    with pytest.raises(ConfigError, match="needs the simulated world"):
        open_bus(Config())


def test_not_connected():
    bus = open_bus(Config(), world=World())
    with pytest.raises(ServoNotConnectedError):
        bus.move(HOME)


def test_starts_at_home_and_moves(config, model):
    """Before any move the arm is at home; a move realises the command within 0.05°."""
    bus = sim()
    assert bus.state is None
    np.testing.assert_allclose(bus.ee_cm, [-20.16, 34.91, 19.95], atol=0.01)
    target = (-0.40, 42.01, 12.76)
    joints = above(*target)
    bus.move(ArmCommand(joints, GRIP_DEG))
    assert bus.state.joints_deg == pytest.approx(joints)
    assert np.max(np.abs(bus.actual_joints_deg - joints)) <= 0.05 + 1e-9
    assert np.linalg.norm(bus.ee_cm - target) < 0.05
    np.testing.assert_allclose(bus.ee_cm, ee_from_joints_cm(model, bus.actual_joints_deg))


def test_limits_refused_in_sim():
    bus = sim()
    with pytest.raises(JointLimitError):
        bus.move(ArmCommand((10.0, 93.0, -132.0), 60.0))
    assert bus.state is None


def test_pick_within_tolerance_moves_the_object():
    """A pick 0.8 cm off in the plane grips the object; it leaves the rendered table."""
    bus = sim()
    world = bus.world
    m3 = next(o for o in world.objects if o.id == "red3")
    pick_at(bus, m3.x_cm + 0.8, m3.y_cm)
    assert bus.last_grip.success and bus.last_grip.object_id == "red3"
    assert bus.last_grip.distance_cm == pytest.approx(0.8, abs=0.05)
    assert world.held_object() is m3 and m3 not in world.table_objects()
    assert len(world.table_objects()) == 11


@pytest.mark.parametrize(("dx", "dz"), [(1.5, 0.0), (0.0, 1.6), (3.0, 3.0)])
def test_pick_outside_tolerance_fails(dx, dz):
    """Off by 1.5 cm in the plane or 1.6 cm in height: the pick fails, the object stays."""
    bus = sim()
    m3 = next(o for o in bus.world.objects if o.id == "red3")
    before = (m3.x_cm, m3.y_cm)
    pick_at(bus, m3.x_cm + dx, m3.y_cm, bus.config.robot.gripper.pick_height_cm + dz)
    assert not bus.last_grip.success
    assert bus.world.held_object() is None and m3.on_table and (m3.x_cm, m3.y_cm) == before
    # opening an empty gripper changes nothing
    bus.move(ArmCommand(bus.state.joints_deg, GRIP_DEG, False))
    assert len(bus.world.table_objects()) == 12


def test_tolerance_comes_from_config():
    """grip_tolerance_cm = 2 makes the 1.5 cm pick succeed."""
    bus = sim(grip_tolerance_cm=2.0)
    m3 = next(o for o in bus.world.objects if o.id == "red3")
    pick_at(bus, m3.x_cm + 1.5, m3.y_cm)
    assert bus.last_grip.success


def test_place_in_bin_and_on_table():
    """Opening over the green bin drops the object into it; far from bins, onto the table."""
    bus = sim()
    world = bus.world
    m3 = next(o for o in world.objects if o.id == "red3")
    pick_at(bus, m3.x_cm, m3.y_cm)
    joints = above(-20.0, 45.0, 20.0)
    bus.move(ArmCommand(joints, 30.0, True))
    bus.move(ArmCommand(joints, 30.0, False))
    assert m3.bin == "green" and world.in_bin("green") == [m3]
    assert bus.last_release.bin == "green"
    h2 = next(o for o in world.objects if o.id == "green2")
    pick_at(bus, h2.x_cm, h2.y_cm)
    far = above(10.0, 30.0, 15.0)
    bus.move(ArmCommand(far, 30.0, True))
    bus.move(ArmCommand(far, 30.0, False))
    assert h2.on_table and bus.last_release.bin is None
    assert (h2.x_cm, h2.y_cm) == pytest.approx((10.0, 30.0), abs=0.05)


def test_offset_and_noise():
    """A static offset shifts every realised joint; noise differs per new pose, seeded."""
    bus = sim(error_model={"quantization": "none", "offset_deg": [1.0, -0.5, 0.25]})
    bus.move(HOME)
    np.testing.assert_allclose(bus.actual_joints_deg, [121.0, 92.5, -131.75])
    noisy = [sim(error_model={"noise_std_deg": 0.5, "seed": 7}) for _ in range(2)]
    draws = []
    step = ArmCommand((121.0, 93.0, -132.0), 60.0, False)
    for bus in noisy:
        bus.move(HOME)
        first = bus.actual_joints_deg.copy()
        bus.move(ArmCommand(HOME.joints_deg, 30.0, True))  # joints held: no new error
        np.testing.assert_array_equal(bus.actual_joints_deg, first)
        bus.move(step)
        draws.append((first, bus.actual_joints_deg.copy() - [1.0, 0.0, 0.0]))
    assert not np.allclose(draws[0][0], draws[0][1])  # a new pose draws new noise
    np.testing.assert_array_equal(draws[0][0], draws[1][0])  # seeded
    assert 0 < np.max(np.abs(draws[0][0] - HOME.joints_deg)) < 3.0


def test_sim_does_not_pace_by_default():
    assert sim().paced is False
    assert sim(sim_realtime=True).paced is True


def test_quantization_error_degree_vs_microsecond(config):
    """SPEC §5: whole-degree commands cost a few mm of EE error, 1 µs pulses ~10x less.

    Measured over 1000 random reachable poses (same poses for both).
    """
    degree = quantization_ee_error_cm(config, "degree", n=1000, seed=1)
    micro = quantization_ee_error_cm(config, "microsecond", n=1000, seed=1)
    assert 0.2 < degree.mean() < 0.6  # "about 0.4 cm" (SPEC §5)
    assert degree.max() < 1.2  # never alone enough to miss a pick
    ratio = micro.mean() / degree.mean()
    assert 0.07 < ratio < 0.14
    assert quantization_ee_error_cm(config, "none", n=50).max() < 1e-9
