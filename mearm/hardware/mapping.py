r"""DH angle ↔ servo pulse for each joint, and the checks that refuse a command first.

Each joint's servo channel maps its DH angle linearly to a pulse (issue 5):

.. math:: p = p_0 + s\,k\,\theta \qquad \theta = (p - p_0) / (s\,k)

An angle is refused, never clamped, when it leaves the joint's limits
(``robot.joint_limits_deg``, ``robot.gripper.gripper_arm_limits_deg``) or when its pulse
leaves the channel's ``[min_us, max_us]``. Both checks run before anything is sent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from mearm.config import ACTUATED_JOINTS, Config, GripperServo, Range, ServoChannel
from mearm.exceptions import JointLimitError, PulseRangeError

if TYPE_CHECKING:
    from mearm.hardware.bus import ArmCommand

#: The gripper arm (θ5, SPEC §2) is "joint5" in the servo config.
GRIPPER_ARM_JOINT = "joint5"
#: ``Servo.write`` takes whole degrees of a 0–180° scale spanning [min_us, max_us].
SERVO_SCALE_DEG = 180
_LIMIT_TOL_DEG = 1e-9


@dataclass(frozen=True)
class JointMap:
    """One joint's servo channel: pulse mapping, pulse range and joint limits.

    Attributes:
        name: ``joint1``, ``joint2``, ``joint3`` or ``joint5``.
        channel: Servo channel number.
        zero_us: Pulse at DH angle 0 [µs].
        direction: +1 or −1.
        us_per_deg: Pulse change per DH degree [µs/deg].
        min_us: Lowest allowed pulse [µs].
        max_us: Highest allowed pulse [µs].
        lower_deg: Lower joint limit [deg].
        upper_deg: Upper joint limit [deg].
    """

    name: str
    channel: int
    zero_us: float
    direction: int
    us_per_deg: float
    min_us: int
    max_us: int
    lower_deg: float
    upper_deg: float

    @classmethod
    def from_config(cls, name: str, servo: ServoChannel, limits: Range) -> JointMap:
        """Build from a channel of ``servo.joints`` and the joint's limits."""
        return cls(
            name=name,
            channel=servo.channel,
            zero_us=servo.zero_us,
            direction=servo.direction,
            us_per_deg=servo.us_per_deg,
            min_us=servo.min_us,
            max_us=servo.max_us,
            lower_deg=limits.min,
            upper_deg=limits.max,
        )

    def pulse_us(self, angle_deg: float) -> float:
        """Exact pulse for a DH angle [µs]."""
        return self.zero_us + self.direction * self.us_per_deg * angle_deg

    def angle_deg(self, pulse_us: float) -> float:
        """DH angle a pulse produces [deg] (the inverse of :meth:`pulse_us`)."""
        return (pulse_us - self.zero_us) / (self.direction * self.us_per_deg)

    @property
    def pulse_limits_deg(self) -> tuple[float, float]:
        """The DH angles at ``min_us`` and ``max_us``, ascending [deg]."""
        a, b = self.angle_deg(self.min_us), self.angle_deg(self.max_us)
        return (min(a, b), max(a, b))

    def check(self, angle_deg: float) -> None:
        """Refuse an angle outside the joint limits or the pulse range.

        Raises:
            JointLimitError: outside ``[lower_deg, upper_deg]`` (or not finite).
            PulseRangeError: its pulse leaves ``[min_us, max_us]``.
        """
        tol = _LIMIT_TOL_DEG
        if not (self.lower_deg - tol <= angle_deg <= self.upper_deg + tol):
            raise JointLimitError(self.name, angle_deg, self.lower_deg, self.upper_deg)
        pulse = self.pulse_us(angle_deg)
        if not (self.min_us - 1e-6 <= pulse <= self.max_us + 1e-6):
            lo, hi = self.pulse_limits_deg
            raise PulseRangeError(
                self.name,
                angle_deg,
                lo,
                hi,
                channel=self.channel,
                pulse_us=pulse,
                min_us=self.min_us,
                max_us=self.max_us,
            )

    def command_us(self, angle_deg: float) -> int:
        """The integer pulse the serial backends send: nearest µs, kept in range [µs]."""
        pulse = math.floor(self.pulse_us(angle_deg) + 0.5)
        return min(self.max_us, max(self.min_us, pulse))

    @property
    def servo_step_us(self) -> float:
        """One degree of the servo's own 0–180° scale [µs]."""
        return (self.max_us - self.min_us) / SERVO_SCALE_DEG

    def servo_degree(self, angle_deg: float) -> int:
        """The whole servo degree a ``Servo.write`` host would send for a DH angle."""
        s = round((self.pulse_us(angle_deg) - self.min_us) / self.servo_step_us)
        return min(SERVO_SCALE_DEG, max(0, s))

    def servo_degree_us(self, servo_deg: int) -> int:
        """The pulse ``Servo.write(servo_deg)`` produces: Arduino's integer ``map()`` [µs]."""
        return self.min_us + (servo_deg * (self.max_us - self.min_us)) // SERVO_SCALE_DEG


@dataclass(frozen=True)
class ServoMap:
    """All channels of the arm: θ1–θ3, the gripper arm θ5 and the gripper.

    Attributes:
        joints: Maps of θ1, θ2, θ3, in order.
        gripper_arm: Map of θ5.
        gripper: The gripper servo's channel and open/closed pulses.
    """

    joints: tuple[JointMap, JointMap, JointMap]
    gripper_arm: JointMap
    gripper: GripperServo

    @classmethod
    def from_config(cls, config: Config) -> ServoMap:
        """Channels from ``config.servo``, limits from ``config.robot``."""
        servo, robot = config.servo, config.robot
        limits = robot.joint_limits_deg
        j1, j2, j3 = (
            JointMap.from_config(name, servo.joints[name], getattr(limits, name))
            for name in ACTUATED_JOINTS
        )
        arm = JointMap.from_config(
            GRIPPER_ARM_JOINT,
            servo.joints[GRIPPER_ARM_JOINT],
            robot.gripper.gripper_arm_limits_deg,
        )
        return cls(joints=(j1, j2, j3), gripper_arm=arm, gripper=servo.gripper)

    @property
    def all_joints(self) -> tuple[JointMap, ...]:
        """θ1, θ2, θ3 and θ5."""
        return (*self.joints, self.gripper_arm)

    @property
    def channels(self) -> tuple[int, ...]:
        """Every channel in use, ascending."""
        return tuple(sorted([j.channel for j in self.all_joints] + [self.gripper.channel]))

    def check(self, command: ArmCommand) -> None:
        """Refuse a command with any angle outside its limits or pulse range.

        Raises:
            JointLimitError: the first joint (θ1, θ2, θ3, θ5 order) outside its limits.
            PulseRangeError: the first joint whose pulse leaves its channel's range.
        """
        for jmap, angle in zip(self.all_joints, command.angles_deg, strict=True):
            jmap.check(angle)

    def pulses_us(self, command: ArmCommand) -> dict[int, int]:
        """Checked integer pulses of a command, channel → µs."""
        self.check(command)
        pulses = {
            j.channel: j.command_us(a)
            for j, a in zip(self.all_joints, command.angles_deg, strict=True)
        }
        g = self.gripper
        pulses[g.channel] = g.closed_us if command.gripper_closed else g.open_us
        return dict(sorted(pulses.items()))
