"""The kinematic simulator's jaws push aside an object they close beside; they do not enter it.

A grip that misses by more than ``servo.grip_tolerance_cm`` leaves the object on the
table; jaws closing 1.5 cm off its middle, low, used to end inside it, and the lift after
the miss, its servos' noise moving a pad a little further in, faulted as a collision (the
paper arm, 5 of 100 simulated trials stopped so). The closed jaws now shove it out of
their way, and on where they move into it while they stay closed; an object they were
never against is still a collision.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mearm.config import load_config
from mearm.exceptions import SimCollisionError
from mearm.hardware import ArmCommand
from mearm.kinematics import ArmModel, check_target, closed_form_for
from mearm.sim import World
from mearm.sim.kinematic.servo_bus import SimArm
from mearm.sim.table_collision import collision_model

#: The paper arm over the table at the grip height of its scene's red2.
PICK = {"base": 102.43, "shoulder": 56.0, "elbow": -103.0}
NOISELESS = ("servo.error_model.noise_std_deg=0", "servo.error_model.quantization=none")
#: The object's offset from the TCP, across the jaws' length: a miss (tolerance 1.2 cm).
OFF_CM = np.array([0.0, 1.5])


def _rig() -> tuple[SimArm, ArmModel, np.ndarray]:
    """The noiseless paper arm, a red object 1.5 cm off its TCP, the pose 0.6 cm low."""
    config = load_config("sim_paper_arm", [*NOISELESS, "task.scene=[]"])
    model = ArmModel(config.arm)
    tcp = model.fk_cm(model.chain.from_named(PICK))
    low = check_target(tcp - [0.0, 0.0, 0.6], config.arm, closed_form_for(config.arm))
    x, y = tcp[:2] + OFF_CM
    scene = f"task.scene=[{{color: red, x: {x}, y: {y}}}]"
    config = load_config("sim_paper_arm", [*NOISELESS, scene])
    bus = SimArm(config, World.from_config(config))
    bus.connect()
    return bus, model, low


def _send(bus: SimArm, model: ArmModel, q: np.ndarray, *, closed: bool) -> None:
    joints = model.chain.named_actuated(q)
    bus.move(ArmCommand(joints, ArmCommand.home(bus.config.arm).tool, closed))


def _toward(model: ArmModel, bus: SimArm, q: np.ndarray, cm: float, up_cm: float) -> np.ndarray:
    """The pose with the TCP ``cm`` toward the object and ``up_cm`` higher."""
    tcp = model.fk_cm(q)
    obj = bus.world.table_objects()[0]
    way = np.array([obj.x_cm, obj.y_cm]) - tcp[:2]
    goal = tcp + np.r_[cm * way / np.linalg.norm(way), up_cm]
    return check_target(goal, bus.config.arm, closed_form_for(bus.config.arm))


def _off_tcp_cm(bus: SimArm, model: ArmModel, q: np.ndarray) -> float:
    obj = bus.world.table_objects()[0]
    x, y, _ = model.fk_cm(q)
    return math.hypot(obj.x_cm - x, obj.y_cm - y)


def _touching(bus: SimArm, model: ArmModel, q: np.ndarray, opening_cm: float) -> list:
    check = collision_model(bus.config, model, clearance_cm=0.0)
    objects = [(o.id, o.color, o.x_cm, o.y_cm) for o in bus.world.table_objects()]
    check.set_world(objects, opening_cm=opening_cm)
    return check.touching(q)


def test_the_rig_closes_a_pad_into_the_object_it_misses():
    """The case itself: open, the jaws clear the object; closed where they are, a pad is in it."""
    bus, model, low = _rig()
    gripper = bus.config.arm.tool.gripper
    assert _touching(bus, model, low, gripper.open_cm) == []
    [(part, obstacle, distance)] = _touching(bus, model, low, gripper.closed_cm)
    assert "pad" in part and obstacle == "obj_red1" and distance < -0.2


def test_jaws_that_close_beside_an_object_push_it_out_of_their_way():
    bus, model, low = _rig()
    _send(bus, model, low, closed=False)
    before = _off_tcp_cm(bus, model, low)
    _send(bus, model, low, closed=True)
    assert bus.fault is None
    assert bus.last_grip is not None and not bus.last_grip.success  # missed: 1.5 cm off
    pushed = _off_tcp_cm(bus, model, low) - before
    assert 0.2 < pushed < 0.6, pushed  # out of the pad, no farther than a step past it
    assert _touching(bus, model, low, bus.config.arm.tool.gripper.closed_cm) == []


def test_closed_jaws_push_on_what_they_missed_where_they_move_into_it():
    """The lift after the miss, a pad moving sideways into the object: it is shoved on."""
    bus, model, low = _rig()
    _send(bus, model, low, closed=False)
    _send(bus, model, low, closed=True)
    before = _off_tcp_cm(bus, model, low)
    lift = _toward(model, bus, low, 0.3, 0.2)
    _send(bus, model, lift, closed=True)
    assert bus.fault is None
    assert _off_tcp_cm(bus, model, low) > before + 0.2


def test_open_jaws_moved_into_an_object_still_fault():
    """An object the jaws were never against is not pushed: running into it is a collision."""
    bus, model, low = _rig()
    _send(bus, model, low, closed=False)
    where = [(o.x_cm, o.y_cm) for o in bus.world.table_objects()]
    with pytest.raises(SimCollisionError, match="pad touches red1"):
        _send(bus, model, _toward(model, bus, low, -0.5, 0.0), closed=False)  # (a pad in it)
    assert [(o.x_cm, o.y_cm) for o in bus.world.table_objects()] == where
