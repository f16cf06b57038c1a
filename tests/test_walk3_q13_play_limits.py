"""Backlash compensation never sends a pulse past an actuator's limits.

The bus sends each pulse half a servo's ``play_us`` further the way it moved. A play in
the calibration larger than the servo's own (a file from another servo, a hand-edited
one: up to 100 µs is accepted) turned a joint commanded to its limit past it: the paper
arm's base at its 160° limit got 2230 µs, 163° (the virtual Uno's arm went there). The
offset is now bounded by the pulses of the limits (:meth:`ServoMap.limit_pulses_us`).
"""

from __future__ import annotations

from conftest import ROOT

from mearm.config import load_config
from mearm.hardware import ArmCommand, ServoBus


class RecordingBus(ServoBus):
    """A board that takes every move: the pulses the bus sends, recorded (no hardware)."""

    def __init__(self, config):
        super().__init__(config.arm, config.servo, paced=False)
        self.sent: list[dict[int, int]] = []

    def _connect(self) -> None:
        pass

    def _send_move(self, command, pulses_us) -> None:
        self.sent.append(dict(pulses_us))

    def _stop(self) -> None:
        pass

    def _close(self) -> None:
        pass


def _moves(config, commands):
    with RecordingBus(config) as bus:
        for command in commands:
            bus.move(command)
        return bus, bus.sent


def test_a_joint_at_its_limit_gets_no_pulse_past_it():
    """Base 150 → 160 (its upper limit, 2200 µs) with 60 µs of play: 2200, not 2230."""
    config = load_config(ROOT / "configs" / "sim.yaml", ["arm.joints.base.servo.play_us=60"])
    home = ArmCommand.home(config.arm)
    at = [ArmCommand({**home.joints, "base": v}, home.tool) for v in (150, 160, 30, 20)]
    bus, sent = _moves(config, at)
    base = bus.servo_map["base"]
    assert sent[0][base.channel] == 2100  # 150° from below: nothing sent this way yet
    assert sent[1][base.channel] == 2200  # at the limit: the offset stops there
    assert sent[2][base.channel] == 900 - 30  # inside: compensated as before
    assert sent[3][base.channel] == 800  # the lower limit, from above


def test_a_servo_over_shoulder_plus_elbow_keeps_the_elbow_inside():
    """The MeArm v1's elbow servo (shoulder + elbow) moving its elbow to −20°, its limit:
    the pulses sent put the elbow at −20° at most, not 2.4° past it."""
    config = load_config(
        ROOT / "configs" / "sim_mearm_v1.yaml", ["arm.joints.elbow.servo.play_us=60"]
    )
    home = ArmCommand.home(config.arm)
    at = [ArmCommand({**home.joints, "shoulder": 80, "elbow": e}, home.tool) for e in (-30, -20)]
    bus, sent = _moves(config, at)
    joints = bus.servo_map.joints_from_pulses(sent[-1])
    rounding = {n: 0.5 / bus.servo_map[n].us_per_unit + 1e-9 for n in ("shoulder", "elbow")}
    assert joints["elbow"] <= -20 + rounding["elbow"] + rounding["shoulder"]  # the pulses' µs
    assert abs(joints["shoulder"] - 80) <= rounding["shoulder"]  # untouched by the elbow's


def test_the_gripper_is_still_compensated_inside_its_pulse_range():
    """Open and closed are where the jaws go, not limits: the gripper keeps its offset."""
    config = load_config(ROOT / "configs" / "sim.yaml", ["arm.tool.gripper.servo.play_us=60"])
    home = ArmCommand.home(config.arm)
    closed = ArmCommand(home.joints, home.tool, gripper_closed=True)
    bus, sent = _moves(config, [home, closed, home])
    g = bus.servo_map.gripper
    smap = bus.servo_map
    opened, shut = g.command_us(smap.gripper_open_cm), g.command_us(smap.gripper_closed_cm)
    way = 1 if shut > opened else -1
    assert sent[1][g.channel] == shut + way * 30  # closing: half the play further
    assert sent[2][g.channel] == opened - way * 30  # opening: as far the other way
