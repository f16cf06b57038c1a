r"""Value ↔ servo pulse for each named actuator, and the checks that refuse a command first.

Every actuator of the arm — each actuated joint, each tool actuator and the gripper — has
a servo channel that maps its value linearly to a pulse (its ``servo`` calibration in the
arm description):

.. math:: p = p_0 + s\,k\,v \qquad v = (p - p_0) / (s\,k)

with v in degrees (revolute joint, tool actuator) or centimetres (prismatic joint, the
gripper's opening). A value is refused, never clamped, when it leaves the actuator's
limits or when its pulse leaves the channel's ``[min_us, max_us]``; a command is refused
when it misses an actuator or names one the arm does not have. Every check runs before
anything is sent.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from mearm.config import ArmDescription, Config, Range, ServoCalibration
from mearm.exceptions import InvalidCommandError, JointLimitError, PulseRangeError

if TYPE_CHECKING:
    from mearm.hardware.bus import ArmCommand

#: How a servo realises a command: ``microsecond`` (the integer-µs pulse the serial
#: backends send), ``degree`` (a whole degree of ``Servo.write``'s 0–180° scale) or
#: ``none`` (exactly).
Quantization = Literal["none", "degree", "microsecond"]

#: ``Servo.write`` takes whole degrees of a 0–180° scale spanning [min_us, max_us].
SERVO_SCALE_DEG = 180
_LIMIT_TOL = 1e-9


@dataclass(frozen=True)
class ActuatorMap:
    """One actuator's servo channel: pulse mapping, pulse range and limits.

    Attributes:
        name: The actuator's name in the arm description.
        channel: Servo channel number.
        zero_us: Pulse at value 0 [µs].
        direction: +1 or −1.
        us_per_unit: Pulse change per unit of the value [µs/deg or µs/cm].
        min_us: Lowest allowed pulse [µs].
        max_us: Highest allowed pulse [µs].
        lower: Lower limit [unit].
        upper: Upper limit [unit].
        unit: ``deg`` or ``cm``.
    """

    name: str
    channel: int
    zero_us: float
    direction: int
    us_per_unit: float
    min_us: int
    max_us: int
    lower: float
    upper: float
    unit: str = "deg"

    @classmethod
    def from_calibration(
        cls, name: str, servo: ServoCalibration, limits: Range, unit: str = "deg"
    ) -> ActuatorMap:
        """Build from an actuator's servo calibration and its limits."""
        return cls(
            name=name,
            channel=servo.channel,
            zero_us=servo.zero_us,
            direction=servo.direction,
            us_per_unit=servo.us_per_unit,
            min_us=servo.min_us,
            max_us=servo.max_us,
            lower=limits.min,
            upper=limits.max,
            unit=unit,
        )

    def pulse_us(self, value: float) -> float:
        """Exact pulse for a value [µs]."""
        return self.zero_us + self.direction * self.us_per_unit * value

    def value_of(self, pulse_us: float) -> float:
        """The value a pulse produces [unit] (the inverse of :meth:`pulse_us`)."""
        return (pulse_us - self.zero_us) / (self.direction * self.us_per_unit)

    @property
    def pulse_limits(self) -> tuple[float, float]:
        """The values at ``min_us`` and ``max_us``, ascending [unit]."""
        a, b = self.value_of(self.min_us), self.value_of(self.max_us)
        return (min(a, b), max(a, b))

    def check(self, value: float) -> None:
        """Refuse a value outside the limits or the pulse range.

        Raises:
            JointLimitError: outside ``[lower, upper]`` (or not finite).
            PulseRangeError: its pulse leaves ``[min_us, max_us]``.
        """
        if not (self.lower - _LIMIT_TOL <= value <= self.upper + _LIMIT_TOL):
            raise JointLimitError(self.name, value, self.lower, self.upper, unit=self.unit)
        pulse = self.pulse_us(value)
        if not (self.min_us - 1e-6 <= pulse <= self.max_us + 1e-6):
            lo, hi = self.pulse_limits
            raise PulseRangeError(
                self.name,
                value,
                lo,
                hi,
                channel=self.channel,
                pulse_us=pulse,
                min_us=self.min_us,
                max_us=self.max_us,
                unit=self.unit,
            )

    def command_us(self, value: float) -> int:
        """The integer pulse the serial backends send: nearest µs, kept in range [µs]."""
        pulse = math.floor(self.pulse_us(value) + 0.5)
        return min(self.max_us, max(self.min_us, pulse))

    @property
    def servo_step_us(self) -> float:
        """One degree of the servo's own 0–180° scale [µs]."""
        return (self.max_us - self.min_us) / SERVO_SCALE_DEG

    def servo_degree(self, value: float) -> int:
        """The whole servo degree a ``Servo.write`` host would send for a value."""
        s = round((self.pulse_us(value) - self.min_us) / self.servo_step_us)
        return min(SERVO_SCALE_DEG, max(0, s))

    def servo_degree_us(self, servo_deg: int) -> int:
        """The pulse ``Servo.write(servo_deg)`` produces: Arduino's integer ``map()`` [µs]."""
        return self.min_us + (servo_deg * (self.max_us - self.min_us)) // SERVO_SCALE_DEG

    def realised(self, value: float, mode: Quantization) -> float:
        """The value a servo realises for a commanded one after command quantisation.

        Args:
            value: Commanded value [unit], within the limits.
            mode: ``none``, ``microsecond`` (integer-µs pulse) or ``degree``
                (``Servo.write``'s whole servo degrees).
        """
        if mode == "none":
            return float(value)
        if mode == "microsecond":
            return self.value_of(self.command_us(value))
        if mode == "degree":
            return self.value_of(self.servo_degree_us(self.servo_degree(value)))
        raise ValueError(f"quantization must be none, degree or microsecond, got {mode!r}")


def _names_problem(kind: str, given: Iterable[str], expected: tuple[str, ...]) -> str | None:
    given = list(given)
    missing = [n for n in expected if n not in given]
    unknown = [n for n in given if n not in expected]
    if not missing and not unknown:
        return None
    what = []
    if missing:
        what.append(f"misses {', '.join(missing)}")
    if unknown:
        what.append(f"names unknown {', '.join(unknown)}")
    allowed = ", ".join(expected) if expected else "none"
    return f"{kind} {' and '.join(what)} (this arm's {kind}: {allowed})"


@dataclass(frozen=True)
class ServoMap:
    """Every channel of an arm, keyed by actuator name.

    Attributes:
        joints: Maps of the actuated joints, in chain order.
        tool: Maps of the tool actuators, in the description's order.
        gripper: Map of the gripper (its value is the jaw opening [cm]).
        gripper_open_cm: Opening when open [cm].
        gripper_closed_cm: Opening when closed [cm].
    """

    joints: tuple[ActuatorMap, ...]
    tool: tuple[ActuatorMap, ...]
    gripper: ActuatorMap
    gripper_open_cm: float
    gripper_closed_cm: float

    @classmethod
    def from_arm(cls, arm: ArmDescription) -> ServoMap:
        """Channels, calibrations and limits from an arm description."""
        joints = tuple(
            ActuatorMap.from_calibration(j.name, j.servo, j.limits, j.unit)
            for j in arm.actuated_joints()
            if j.servo is not None and j.limits is not None
        )
        tool = tuple(
            ActuatorMap.from_calibration(a.name, a.servo, a.limits) for a in arm.tool.actuators
        )
        g = arm.tool.gripper
        opening = Range(min=g.closed_cm, max=g.open_cm)
        gripper = ActuatorMap.from_calibration(g.name, g.servo, opening, "cm")
        return cls(joints, tool, gripper, g.open_cm, g.closed_cm)

    @classmethod
    def from_config(cls, config: Config) -> ServoMap:
        """:meth:`from_arm` of ``config.arm``."""
        return cls.from_arm(config.arm)

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Names of the actuated joints, in chain order."""
        return tuple(j.name for j in self.joints)

    @property
    def tool_names(self) -> tuple[str, ...]:
        """Names of the tool actuators."""
        return tuple(a.name for a in self.tool)

    @property
    def actuators(self) -> tuple[ActuatorMap, ...]:
        """Every actuator: joints, tool actuators, then the gripper."""
        return (*self.joints, *self.tool, self.gripper)

    def __getitem__(self, name: str) -> ActuatorMap:
        """The map of the actuator called ``name``.

        Raises:
            KeyError: no such actuator; the message lists the arm's.
        """
        for a in self.actuators:
            if a.name == name:
                return a
        raise KeyError(
            f"no actuator {name!r}; this arm's: {', '.join(a.name for a in self.actuators)}"
        )

    @property
    def channels(self) -> tuple[int, ...]:
        """Every channel in use, ascending."""
        return tuple(sorted(a.channel for a in self.actuators))

    def gripper_opening_cm(self, closed: bool) -> float:
        """The jaw opening for closed or open [cm]."""
        return self.gripper_closed_cm if closed else self.gripper_open_cm

    def check(self, command: ArmCommand) -> None:
        """Refuse a command that misses or misnames an actuator, or has a value out of range.

        Raises:
            InvalidCommandError: a missing or unknown joint or tool actuator; the message
                names them and lists the arm's.
            JointLimitError: the first value (joints, then tool) outside its limits.
            PulseRangeError: the first value whose pulse leaves its channel's range.
        """
        problems = [
            p
            for p in (
                _names_problem("joints", command.joints, self.joint_names),
                _names_problem("tool actuators", command.tool, self.tool_names),
            )
            if p is not None
        ]
        if problems:
            raise InvalidCommandError(
                f"command {'; '.join(problems)}: name every actuated joint and tool "
                "actuator, and only those"
            )
        for j in self.joints:
            j.check(command.joints[j.name])
        for a in self.tool:
            a.check(command.tool[a.name])

    def pulses_us(self, command: ArmCommand) -> dict[int, int]:
        """Checked integer pulses of a command, channel → µs, ascending channels."""
        self.check(command)
        pulses = {j.channel: j.command_us(command.joints[j.name]) for j in self.joints}
        pulses.update({a.channel: a.command_us(command.tool[a.name]) for a in self.tool})
        g = self.gripper
        pulses[g.channel] = g.command_us(self.gripper_opening_cm(command.gripper_closed))
        return dict(sorted(pulses.items()))
