"""The simulated servo bus: error model, picks within tolerance, places into bins."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROOT
from hardware_helpers import HOME

from mearm.backends import open_bus
from mearm.config import Config, config_from_dict, load_config
from mearm.exceptions import (
    ConfigError,
    InvalidCommandError,
    JointLimitError,
    ServoNotConnectedError,
    WorldError,
)
from mearm.hardware import ArmCommand
from mearm.kinematics import ArmModel, closed_form_for
from mearm.sim import SimArm, World, WorldObject
from mearm.sim.kinematic.servo_bus import (
    ee_from_joints_cm,
    quantization_ee_error_cm,
    random_reachable_joints,
)

GRIP_DEG = -60.0
TRAVEL_DEG = 30.0
CONFIG = Config()
MODEL = ArmModel(CONFIG.arm)
IK = closed_form_for(CONFIG.arm)


def sim(world: World | None = None, config: Config | None = None, **servo) -> SimArm:
    cfg = (
        config
        if config is not None
        else (config_from_dict({"servo": servo}) if servo else Config())
    )
    bus = open_bus(cfg, world=world if world is not None else World.from_config(cfg))
    assert isinstance(bus, SimArm)
    bus.connect()
    return bus


def above(x: float, y: float, z: float) -> dict[str, float]:
    """The paper arm's actuated joints putting the TCP at (x, y, z), by the closed form."""
    return MODEL.chain.named_actuated(IK.solve((x, y, z)))


def grip_z(bus: SimArm, class_name: str = "red") -> float:
    """TCP height that grips an object of the class: its grip height + tcp_above_grip_cm."""
    cls = bus.config.task.class_named(class_name)
    return cls.grip_z_cm + bus.config.arm.tool.tcp_above_grip_cm


def pick_at(bus: SimArm, x: float, y: float, z: float | None = None) -> None:
    joints = above(x, y, grip_z(bus) if z is None else z)
    bus.move(ArmCommand(joints, {"gripper_arm": GRIP_DEG}, False))
    bus.move(ArmCommand(joints, {"gripper_arm": GRIP_DEG}, True))


def carry_to(bus: SimArm, x: float, y: float, z: float) -> None:
    """Move there closed, then open."""
    joints = above(x, y, z)
    bus.move(ArmCommand(joints, {"gripper_arm": TRAVEL_DEG}, True))
    bus.move(ArmCommand(joints, {"gripper_arm": TRAVEL_DEG}, False))


def obj(bus: SimArm, object_id: str) -> WorldObject:
    return next(o for o in bus.world.objects if o.id == object_id)


def test_open_bus_needs_world_for_sim():
    with pytest.raises(ConfigError, match="needs the simulated world"):
        open_bus(Config())


def test_not_connected():
    bus = open_bus(Config(), world=World())
    with pytest.raises(ServoNotConnectedError):
        bus.move(HOME)


def test_starts_at_home_and_moves():
    """Before any move the arm is at home; a move realises the command within 0.05°."""
    bus = sim()
    assert bus.state is None and bus.actual_joints == CONFIG.arm.home()
    assert bus.actual_tool == {"gripper_arm": 60.0}
    np.testing.assert_allclose(bus.ee_cm, [-20.16, 34.91, 19.95], atol=0.01)
    target = (-0.40, 42.01, 12.76)
    joints = above(*target)
    bus.move(ArmCommand(joints, {"gripper_arm": GRIP_DEG}))
    assert dict(bus.state.joints) == pytest.approx(joints)
    assert set(bus.actual_joints) == {"base", "shoulder", "elbow"}
    assert max(abs(bus.actual_joints[n] - v) for n, v in joints.items()) <= 0.05 + 1e-9
    assert bus.actual_tool == {"gripper_arm": GRIP_DEG}
    assert np.linalg.norm(bus.ee_cm - target) < 0.05
    np.testing.assert_allclose(bus.ee_cm, ee_from_joints_cm(MODEL, bus.actual_joints))


def test_stop_holds_the_confirmed_pose():
    """stop() changes neither the confirmed state nor the simulated arm's pose or grip."""
    bus = sim(error_model={"noise_std_deg": 0.5, "seed": 7})
    bus.move(ArmCommand(above(-0.40, 42.01, 12.76), {"gripper_arm": GRIP_DEG}, True))
    state, joints, tool = bus.state, dict(bus.actual_joints), dict(bus.actual_tool)
    bus.stop()
    assert bus.state == state and bus.actual_joints == joints and bus.actual_tool == tool
    assert bus.gripper_closed and bus.fault is None


def test_limits_refused_in_sim():
    bus = sim()
    with pytest.raises(JointLimitError):
        bus.move(
            ArmCommand({"base": 10.0, "shoulder": 93.0, "elbow": -132.0}, {"gripper_arm": 60.0})
        )
    assert bus.state is None


def test_misnamed_command_refused_in_sim():
    """The sim refuses what the serial backends refuse: a command missing a joint."""
    bus = sim()
    with pytest.raises(InvalidCommandError, match="misses elbow"):
        bus.move(ArmCommand({"base": 120.0, "shoulder": 93.0}, {"gripper_arm": 60.0}))
    assert bus.state is None and bus.actual_joints == CONFIG.arm.home()


def test_pick_within_tolerance_moves_the_object():
    """A pick 0.8 cm off in the plane grips the object; it leaves the rendered table."""
    bus = sim()
    world = bus.world
    m3 = obj(bus, "red3")
    pick_at(bus, m3.x_cm + 0.8, m3.y_cm)
    assert bus.last_grip.success and bus.last_grip.object_id == "red3"
    assert bus.last_grip.distance_cm == pytest.approx(0.8, abs=0.05)
    assert abs(bus.last_grip.dz_cm) < 0.05
    assert world.held_object() is m3 and m3 not in world.table_objects()
    assert len(world.table_objects()) == 11


@pytest.mark.parametrize(("dx", "dz"), [(1.5, 0.0), (0.0, 1.6), (3.0, 3.0)])
def test_pick_outside_tolerance_fails(dx, dz):
    """Off by 1.5 cm in the plane or 1.6 cm in height: the pick fails, the object stays."""
    bus = sim()
    m3 = obj(bus, "red3")
    before = (m3.x_cm, m3.y_cm)
    pick_at(bus, m3.x_cm + dx, m3.y_cm, grip_z(bus) + dz)
    assert not bus.last_grip.success
    assert bus.world.held_object() is None and m3.on_table and (m3.x_cm, m3.y_cm) == before
    # opening an empty gripper changes nothing
    bus.move(ArmCommand(bus.state.joints, {"gripper_arm": GRIP_DEG}, False))
    assert len(bus.world.table_objects()) == 12 and bus.last_release is None


def test_grip_height_is_per_class():
    """The grip height comes from the object's class: a taller class is gripped higher."""
    base = Config()
    classes = [c.model_dump() for c in base.task.classes]
    classes[0]["grip_height_cm"] = 3.0  # red objects are gripped 1.5 cm higher
    cfg = config_from_dict({"task": {"classes": classes}})
    bus = sim(config=cfg)
    assert grip_z(bus, "red") == pytest.approx(3.0 + 11.26)
    m3 = obj(bus, "red3")
    pick_at(bus, m3.x_cm, m3.y_cm, 12.76)  # the default height: 1.5 cm too low now
    assert not bus.last_grip.success and bus.last_grip.dz_cm == pytest.approx(-1.5, abs=0.05)
    pick_at(bus, m3.x_cm, m3.y_cm, 14.26)
    assert bus.last_grip.success


def test_empty_table_grip():
    bus = sim(world=World())
    bus.move(HOME)
    bus.move(ArmCommand(HOME.joints, HOME.tool, True))
    grip = bus.last_grip
    assert not grip.success and grip.object_id is None and grip.distance_cm == float("inf")


def test_unknown_class_on_the_table():
    """A world object whose class the config does not have is a WorldError naming it."""
    world = World(objects=[WorldObject("teal1", "teal", -0.40, 42.01)])
    bus = sim(world=world)
    with pytest.raises(WorldError, match=r"'teal' is not in task.classes \(red, green, blue\)"):
        pick_at(bus, -0.40, 42.01)


def test_tolerance_comes_from_config():
    """grip_tolerance_cm = 2 makes the 1.5 cm pick succeed."""
    bus = sim(grip_tolerance_cm=2.0)
    m3 = obj(bus, "red3")
    pick_at(bus, m3.x_cm + 1.5, m3.y_cm)
    assert bus.last_grip.success


def test_place_in_bin_and_on_table():
    """Opening over the green bin drops the object into it; far from bins, onto the table."""
    bus = sim()
    world = bus.world
    m3 = obj(bus, "red3")
    pick_at(bus, m3.x_cm, m3.y_cm)
    carry_to(bus, -20.0, 45.0, 20.0)
    assert m3.bin == "green" and world.in_bin("green") == [m3]
    assert bus.last_release.bin == "green" and bus.last_release.object_id == "red3"
    h2 = obj(bus, "green2")
    pick_at(bus, h2.x_cm, h2.y_cm)
    carry_to(bus, 10.0, 30.0, 15.0)
    assert h2.on_table and bus.last_release.bin is None
    assert (h2.x_cm, h2.y_cm) == pytest.approx((10.0, 30.0), abs=0.05)


def test_the_sim_says_what_its_gripper_holds():
    """Nothing before a grip, the class of what it closed on while carried, nothing after
    the release; an open with nothing held keeps the last release, which the place must
    not read alone (it reads the hold first)."""
    bus = sim()
    m3 = obj(bus, "red3")
    assert bus.held_classes() == frozenset()
    pick_at(bus, m3.x_cm, m3.y_cm)
    assert bus.held_classes() == frozenset({m3.color})
    carry_to(bus, -20.0, 45.0, 20.0)
    assert bus.held_classes() == frozenset()
    pick_at(bus, 10.0, 30.0)  # nothing there: the jaws close on air
    assert not bus.last_grip.success and bus.held_classes() == frozenset()
    carry_to(bus, -20.0, 45.0, 20.0)
    assert bus.last_release.object_id == "red3"  # stale: why the hold is read first


def test_offset_and_noise():
    """A static offset by joint name shifts that realised joint; noise differs per new
    pose, seeded; holding the joints draws no new error."""
    bus = sim(error_model={"quantization": "none", "offset_deg": {"base": 1.0, "elbow": 0.25}})
    bus.move(HOME)
    assert bus.actual_joints == {"base": 121.0, "shoulder": 93.0, "elbow": -131.75}
    noisy = [sim(error_model={"noise_std_deg": 0.5, "seed": 7}) for _ in range(2)]
    draws = []
    step = ArmCommand({**HOME.joints, "base": 121.0}, HOME.tool)
    for bus in noisy:
        bus.move(HOME)
        first = dict(bus.actual_joints)
        bus.move(ArmCommand(HOME.joints, {"gripper_arm": 30.0}, True))  # joints held
        assert bus.actual_joints == first
        bus.move(step)
        second = {**bus.actual_joints, "base": bus.actual_joints["base"] - 1.0}
        draws.append((first, second))
    assert draws[0][0] != pytest.approx(draws[0][1])  # a new pose draws new noise
    assert draws[0][0] == draws[1][0]  # seeded
    assert 0 < max(abs(draws[0][0][n] - v) for n, v in HOME.joints.items()) < 3.0


def test_offset_for_unknown_joint_refused_by_config():
    with pytest.raises(ConfigError, match="offset_deg.wrist: not an actuated joint"):
        config_from_dict({"servo": {"error_model": {"offset_deg": {"wrist": 1.0}}}})


def test_sim_does_not_pace_by_default():
    assert sim().paced is False
    assert sim(sim_realtime=True).paced is True


def test_quantization_error_degree_vs_microsecond(config):
    """paper §5: whole-degree commands cost a few mm of TCP error, 1 µs pulses ~10x less.

    Measured over 1000 random reachable poses (same poses for both).
    """
    degree = quantization_ee_error_cm(config, "degree", n=1000, seed=1)
    micro = quantization_ee_error_cm(config, "microsecond", n=1000, seed=1)
    assert 0.2 < degree.mean() < 0.6  # "about 0.4 cm" (paper §5)
    assert degree.max() < 1.2  # never alone enough to miss a pick
    ratio = micro.mean() / degree.mean()
    assert 0.07 < ratio < 0.14
    assert quantization_ee_error_cm(config, "none", n=50).max() < 1e-9


@pytest.mark.parametrize("name", ["sim.yaml", "sim_5dof.yaml", "sim_mearm_v1.yaml"])
def test_random_reachable_joints_any_arm(name):
    """Random poses are within the limits and put the TCP in the target box, for an arm
    with a closed form and arms without one; the same seed gives the same poses."""
    cfg = load_config(ROOT / "configs" / name)
    model = ArmModel(cfg.arm)
    poses = random_reachable_joints(cfg, 20, seed=3, model=model)
    assert poses.shape == (20, model.chain.m)
    np.testing.assert_array_equal(poses, random_reachable_joints(cfg, 20, seed=3, model=model))
    box = cfg.arm.target_box
    for values in poses:
        joints = dict(zip(model.chain.actuated, values.tolist(), strict=True))
        q = model.chain.from_named(joints)
        assert model.chain.within_limits(q, tol=1e-6)
        x, y, z = model.fk_cm(q)
        assert box.x_cm.contains(x) and box.y_cm.contains(y) and box.z_cm.contains(z)


def test_five_joint_arm_in_the_sim():
    """The 5-joint desk arm runs on the same sim: its home command, its TCP by name."""
    cfg = load_config(ROOT / "configs" / "sim_5dof.yaml")
    bus = sim(config=cfg)
    home = ArmCommand.home(cfg.arm)
    bus.move(home)
    assert set(bus.actual_joints) == set(home.joints) and bus.actual_tool == {}
    np.testing.assert_allclose(bus.ee_cm, ee_from_joints_cm(bus.model, bus.actual_joints))
