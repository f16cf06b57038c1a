"""The servo bus driven in pulses while their calibration is measured."""

from __future__ import annotations

import dataclasses
import math
from typing import Protocol, runtime_checkable

from mearm.backends import open_bus
from mearm.config import Config
from mearm.hardware import ActuatorMap, ArmCommand, ServoBus, ServoMap
from mearm.hardware.bus import MeasuresJoints, MeasuresPulses, MeasuresTool


@runtime_checkable
class HasOwnServos(Protocol):
    """A simulated board whose servos turn its pulses by their own calibration.

    ``own_servos``: the rig's servos, whatever map the host sends by (the virtual Uno's,
    :attr:`~mearm.sim.virtual_uno.VirtualUnoBus.own_servos`: the arm's calibration before
    the config's servo calibration file).
    """

    @property
    def own_servos(self) -> ServoMap: ...  # noqa: D102


class PulseSession:
    """Drives a servo bus in pulses: each actuator holds a pulse [µs] the keys change.

    The bus's map is replaced by one whose limits are each actuator's whole pulse range
    (its calibration is what is being measured), so any pulse in ``[min_us, max_us]`` can
    be commanded and nothing outside can. A pulse is sent as the value the present
    calibration gives it, which the bus turns back into the same integer pulse; the
    joints are solved from the joint servos' values (:meth:`ServoMap.joints_of`: a servo
    that turns a combination of joints is set by that combination, the joint it sits in
    left free of its limits); the gripper, commanded open or closed, gets a map whose
    "open" is the pulse.

    Args:
        config: The whole configuration (the present calibration).
        bus: The servo bus, connected.
    """

    def __init__(self, config: Config, bus: ServoBus):
        self.config = config
        self.bus = bus
        original = ServoMap.from_arm(config.arm)
        self._original = original

        def widened(a: ActuatorMap) -> ActuatorMap:
            # no play compensated: the references are taken from both sides
            if a.combined:  # its pulse range bounds the combination, not this joint
                return dataclasses.replace(a, lower=-math.inf, upper=math.inf, play_us=0.0)
            lo, hi = a.pulse_limits
            return dataclasses.replace(a, lower=lo, upper=hi, play_us=0.0)

        self._joints = tuple(widened(a) for a in original.joints)
        self._tool = tuple(widened(a) for a in original.tool)
        home = original.servo_values(config.arm.home())
        tool_home = {t.name: t.home for t in config.arm.tool.actuators}
        self.home_values = home
        self.pulses_us: dict[str, int] = {
            j.name: j.command_us(home[j.name]) for j in original.joints
        }
        self.pulses_us.update({t.name: t.command_us(tool_home[t.name]) for t in original.tool})
        g = original.gripper
        self.pulses_us[g.name] = g.command_us(original.gripper_open_cm)

    @property
    def servo_map(self) -> ServoMap:
        """The arm's servos under the present calibration (not the widened ones sent)."""
        return self._original

    def joint_values(self) -> dict[str, float]:
        """Each joint servo's value now: its pulse under the present calibration [unit]."""
        return {a.name: a.value_of(self.pulses_us[a.name]) for a in self._original.joints}

    def actuator_values(self) -> dict[str, float]:
        """Every actuator's value now under the present calibration [deg or cm].

        Each actuated joint (solved from the joint servos' values: the MeArm v1's elbow
        servo moves the elbow joint, shoulder + elbow being what it sets), each tool
        actuator, and the gripper's opening.
        """
        smap = self._original
        values = smap.joints_of(self.joint_values())
        values.update(
            {a.name: a.value_of(self.pulses_us[a.name]) for a in (*smap.tool, smap.gripper)}
        )
        return values

    def limits_us(self, name: str) -> tuple[int, int]:
        """The pulse range of an actuator [µs]."""
        a = self._original[name]
        return (a.min_us, a.max_us)

    def set_pulse(self, name: str, pulse_us: int) -> int:
        """Send ``pulse_us`` (kept inside the actuator's range) to one actuator; return it."""
        lo, hi = self.limits_us(name)
        pulse = min(hi, max(lo, int(pulse_us)))
        previous = self.pulses_us[name]
        self.pulses_us[name] = pulse
        try:
            self.send()
        except BaseException:
            self.pulses_us[name] = previous
            raise
        return pulse

    def send(self) -> None:
        """Send every actuator's present pulse in one command."""
        g0 = self._original.gripper
        p = self.pulses_us[g0.name]
        open_cm = self._original.gripper_open_cm
        gripper = dataclasses.replace(g0, zero_us=p - g0.direction * g0.us_per_unit * open_cm)
        smap = ServoMap(
            self._joints, self._tool, gripper, open_cm, self._original.gripper_closed_cm
        )
        self.bus.servo_map = smap
        joints = smap.joints_of({a.name: a.value_of(self.pulses_us[a.name]) for a in self._joints})
        tool = {a.name: a.value_of(self.pulses_us[a.name]) for a in self._tool}
        self.bus.move(ArmCommand(joints, tool, gripper_closed=False))

    @property
    def simulated(self) -> bool:
        """Whether the bus is a simulated arm (:class:`~mearm.hardware.bus.MeasuresJoints`)."""
        return isinstance(self.bus, MeasuresJoints)

    def simulated_value(self, name: str) -> float | None:
        """What a simulated arm realised for an actuator's servo, else ``None``.

        A joint servo's value: the joint's, or the combination it turns
        (:class:`~mearm.hardware.bus.MeasuresJoints`). A bus that measures its board's
        pins (:class:`~mearm.hardware.bus.MeasuresPulses`: the virtual Uno) gives a tool
        actuator's or the gripper's value as its measured pulse turned by the rig's own
        servo (:class:`HasOwnServos`; a board that has none of its own, by the present
        calibration), as its joints are turned; one that reports its tool actuators
        (:class:`~mearm.hardware.bus.MeasuresTool`: the kinematic simulator) gives
        theirs. The kinematic simulator's gripper is only open or closed: no value
        (:attr:`simulated` tells it from a real board's).
        """
        actuator = self._original[name]
        if name in self._original.joint_names and isinstance(self.bus, MeasuresJoints):
            try:
                return actuator.servo_value(self.bus.actual_joints)
            except KeyError:  # a joint the simulator does not report
                return None
        if isinstance(self.bus, MeasuresPulses):  # the virtual Uno: every pin measured
            measured = self.bus.measured_pulses_us()
            if actuator.channel not in measured:  # a silent pin: nothing to read
                return None
            # the rig's servo turns the pulse, not the host's map (a fitted file's): the
            # screen reads where the arm is, as its joints are read
            servo = self.bus.own_servos[name] if isinstance(self.bus, HasOwnServos) else actuator
            return servo.value_of(measured[actuator.channel])
        if isinstance(self.bus, MeasuresTool):
            value = self.bus.actual_tool.get(name)
            return None if value is None else float(value)
        return None


def open_arm_bus(config: Config, port: str | None = None) -> ServoBus:
    """The config's servo bus, not connected; a simulated arm gets a cleared table.

    Calibration turns each servo alone across its range, where the arm's body may sweep
    low over the table: it is done with the table cleared (no bins, no objects), and the
    simulated arm, which faults on whatever it touches, stands on a cleared table too —
    the ``sim`` backend's and the virtual Uno's, which would otherwise lay out the
    config's bins (the paper arm's shoulder at its 50° reference, the base at 130°, put
    the gripper into the red bin's wall).
    """
    world = None
    if config.servo.backend in ("sim", "virtual_uno"):
        from mearm.sim import World

        world = World()
    return open_bus(config, world, port=port)
