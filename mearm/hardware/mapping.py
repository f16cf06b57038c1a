r"""Value ↔ servo pulse for each named actuator, and the checks that refuse a command first.

Every actuator of the arm — each actuated joint, each tool actuator and the gripper — has
a servo channel that maps its servo's value linearly to a pulse (its ``servo``
calibration in the arm description):

.. math:: p = p_0 + s\,k\,v \qquad v = (p - p_0) / (s\,k)

with v in degrees (revolute joint, tool actuator) or centimetres (prismatic joint, the
gripper's opening). A joint's servo turns, by default, that joint alone: v is the joint's
value. A servo may instead turn a linear combination of the actuated joints (its
``drives``, :class:`~mearm.config.ServoDrives`), so that over every joint servo

.. math:: v = A\,q_a + a \qquad q_a = A^{-1}(v - a)

with A square and invertible (the config refuses anything else): the MeArm's elbow servo
turns the forearm's angle to the table, shoulder plus elbow. :class:`ServoMap` goes both
ways — joints to pulses (:meth:`ServoMap.pulses_us`) and pulses to joints
(:meth:`ServoMap.joints_from_pulses`).

A command is refused, never clamped, when a joint leaves its limits (checked on the joint,
as the planner checks it) or when a servo's pulse leaves the channel's
``[min_us, max_us]`` (checked on the servo's value: for a servo over several joints the
pulse range depends on the pose, not on one joint's limits); a command is refused when it
misses an actuator or names one the arm does not have. Every check runs before anything
is sent.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
import numpy.typing as npt

from mearm.config import ArmDescription, JointServo, Range, ServoCalibration
from mearm.config.arm import combination_text
from mearm.hardware.errors import InvalidCommandError, PulseRangeError
from mearm.kinematics.errors import JointLimitError

if TYPE_CHECKING:
    from mearm.hardware.command import ArmCommand

#: How a servo realises a command: ``microsecond`` (the integer-µs pulse the serial
#: backends send), ``degree`` (a whole degree of ``Servo.write``'s 0–180° scale) or
#: ``none`` (exactly).
Quantization = Literal["none", "degree", "microsecond"]

#: ``Servo.write`` takes whole degrees of a 0–180° scale spanning [min_us, max_us].
SERVO_SCALE_DEG = 180
_LIMIT_TOL = 1e-9


@dataclass(frozen=True)
class ActuatorMap:
    r"""One actuator's servo channel: pulse mapping, pulse range and limits.

    The pulse methods (:meth:`pulse_us`, :meth:`value_of`, :meth:`command_us`, …) take
    and give the servo's value: the actuator's own value, or for a joint servo that
    turns a combination (``terms``) the combination :meth:`servo_value`.

    Attributes:
        name: The actuator's name in the arm description.
        channel: Servo channel number.
        zero_us: Pulse at value 0 [µs].
        direction: +1 or −1.
        us_per_unit: Pulse change per unit of the value [µs/deg or µs/cm].
        min_us: Lowest allowed pulse [µs].
        max_us: Highest allowed pulse [µs].
        lower: Lower limit of the actuator's own value [unit].
        upper: Upper limit [unit].
        unit: ``deg`` or ``cm``.
        terms: What a joint's servo turns: (actuated joint, coefficient) pairs of
            :math:`v = \sum_j a_j q_j + a_0`; empty: the actuator's own value.
        offset: :math:`a_0` [unit] (with ``terms``).
        play_us: The pulse a value needs reached rising less the one it needs reached
            falling [µs] (:attr:`~mearm.config.ServoCalibration.play_us`;
            :class:`PlayCompensation`).
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
    terms: tuple[tuple[str, float], ...] = ()
    offset: float = 0.0
    play_us: float = 0.0

    @classmethod
    def from_calibration(
        cls, name: str, servo: ServoCalibration, limits: Range, unit: str = "deg"
    ) -> ActuatorMap:
        """Build from an actuator's servo calibration and its limits.

        A joint servo's ``drives`` (:class:`~mearm.config.JointServo`) become ``terms``
        and ``offset``; a servo over its joint alone has none.
        """
        terms: tuple[tuple[str, float], ...] = ()
        offset = 0.0
        if isinstance(servo, JointServo) and servo.drives is not None:
            terms = tuple((n, float(c)) for n, c in servo.drives.terms.items())
            offset = float(servo.drives.offset)
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
            terms=terms,
            offset=offset,
            play_us=servo.play_us,
        )

    @property
    def combined(self) -> bool:
        """Whether the servo's value is something other than the actuator's own value."""
        return bool(self.terms) and (self.terms != ((self.name, 1.0),) or self.offset != 0.0)

    @property
    def combination_text(self) -> str:
        """What the servo turns: the actuator's name, or its combination (``shoulder + elbow``)."""
        if not self.combined:
            return self.name
        return combination_text(self.terms, self.offset)

    @property
    def servo_text(self) -> str:
        """The servo in words: the name, or ``elbow's servo (shoulder + elbow)``."""
        if not self.combined:
            return self.name
        return f"{self.name}'s servo ({self.combination_text})"

    def servo_value(self, values: Mapping[str, float]) -> float:
        """The servo's value for the actuated joints' ``values`` [unit]: its combination."""
        if not self.terms:
            return float(values[self.name])
        return self.offset + sum(c * float(values[n]) for n, c in self.terms)

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
        """Refuse a value outside the limits or the pulse range (a servo over its own value).

        Raises:
            JointLimitError: outside ``[lower, upper]`` (or not finite).
            PulseRangeError: its pulse leaves ``[min_us, max_us]``.
        """
        self.check_limits(value)
        self.check_pulse(value)

    def check_limits(self, value: float) -> None:
        """Refuse an actuator value outside ``[lower, upper]`` (or not finite).

        Raises:
            JointLimitError: naming the actuator, the value, the limits and the unit.
        """
        if not (self.lower - _LIMIT_TOL <= value <= self.upper + _LIMIT_TOL):
            raise JointLimitError(self.name, value, self.lower, self.upper, unit=self.unit)

    def check_pulse(self, servo_value: float) -> None:
        """Refuse a servo value whose pulse leaves ``[min_us, max_us]``.

        Raises:
            PulseRangeError: naming the servo (:attr:`servo_text`), its value, the values
                the pulse range allows, the channel and the pulse.
        """
        pulse = self.pulse_us(servo_value)
        if not (self.min_us - 1e-6 <= pulse <= self.max_us + 1e-6):
            raise PulseViolation(0, self, servo_value).error()

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

        The pulse's grid (whole µs, or whole servo degrees) is applied without the range's
        clamp: a value inside the pulse range (the only kind the bus sends) is realised
        exactly as the backends send it. Given the value of one joint of a servo that
        turns several, this is that joint on its servo's grid with the other joints'
        share left out — the same step, not the same phase; :meth:`ServoMap.realised`
        realises a whole command exactly.

        Args:
            value: Commanded value [unit], within the limits.
            mode: ``none``, ``microsecond`` (integer-µs pulse) or ``degree``
                (``Servo.write``'s whole servo degrees).
        """
        if mode == "none":
            return float(value)
        if mode == "microsecond":
            return self.value_of(math.floor(self.pulse_us(value) + 0.5))
        if mode == "degree":
            s = round((self.pulse_us(value) - self.min_us) / self.servo_step_us)
            return self.value_of(self.servo_degree_us(s))
        raise ValueError(f"quantization must be none, degree or microsecond, got {mode!r}")


@dataclass(frozen=True)
class PulseViolation:
    """A pose whose joint servo's value needs a pulse outside its channel's range.

    Attributes:
        pose: The pose's row among those checked (0 for a single pose).
        servo: The servo's channel map.
        value: The servo's value at that pose [deg or cm] (a combination's value for a
            servo over several joints).
    """

    pose: int
    servo: ActuatorMap
    value: float

    @property
    def pulse_us(self) -> float:
        """The pulse the value needs [µs]."""
        return self.servo.pulse_us(self.value)

    def error(self) -> PulseRangeError:
        """The error that refuses it: the servo, its value and pulse, the range allowed."""
        s = self.servo
        lo, hi = s.pulse_limits
        return PulseRangeError(
            s.servo_text,
            self.value,
            lo,
            hi,
            channel=s.channel,
            pulse_us=self.pulse_us,
            min_us=s.min_us,
            max_us=s.max_us,
            unit=s.unit,
        )


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
        """Channels, calibrations, the joint servos' combinations and limits from an arm."""
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

    def without_play(self) -> ServoMap:
        """The same map with no servo's play compensated (what calibration measures by)."""

        def bare(a: ActuatorMap) -> ActuatorMap:
            return dataclasses.replace(a, play_us=0.0)

        return ServoMap(
            tuple(map(bare, self.joints)),
            tuple(map(bare, self.tool)),
            bare(self.gripper),
            self.gripper_open_cm,
            self.gripper_closed_cm,
        )

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Names of the actuated joints, in chain order."""
        return tuple(j.name for j in self.joints)

    # ----------------------------------------------------------------- joints ↔ servos

    @functools.cached_property
    def _matrix(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """(A, a, A⁻¹) of the joint servos, or ``None`` when every one turns its own joint."""
        if not any(j.combined for j in self.joints):
            return None
        col = {n: k for k, n in enumerate(self.joint_names)}
        A = np.zeros((len(self.joints), len(self.joints)))
        a = np.zeros(len(self.joints))
        for k, j in enumerate(self.joints):
            for n, c in j.terms or ((j.name, 1.0),):
                A[k, col[n]] = c
            a[k] = j.offset
        return A, a, np.linalg.inv(A)

    @property
    def combination(self) -> tuple[np.ndarray, np.ndarray] | None:
        r"""(A, a): the joint servos' values :math:`v = A q_a + a`, or ``None``.

        Over the actuated joints in config units, chain order; ``None`` when each servo
        turns its own joint.
        """
        m = self._matrix
        return None if m is None else (m[0], m[1])

    def servo_values(self, joints: Mapping[str, float]) -> dict[str, float]:
        r"""Each joint servo's value for the actuated joints, :math:`v = A q_a + a`.

        Args:
            joints: Every actuated joint, name → deg or cm.

        Returns:
            Joint servo (named by the joint it sits in) → its value [deg or cm].
        """
        return {j.name: j.servo_value(joints) for j in self.joints}

    def joints_of(self, servo_values: Mapping[str, float]) -> dict[str, float]:
        r"""The actuated joints that give the joint servos these values, :math:`A^{-1}(v - a)`.

        Args:
            servo_values: Every joint servo (by its joint's name) → its value.

        Returns:
            Actuated joint name → deg or cm, in chain order.
        """
        v = np.array([float(servo_values[n]) for n in self.joint_names])
        if self._matrix is None:
            return dict(zip(self.joint_names, v.tolist(), strict=True))
        _, a, inv = self._matrix
        return dict(zip(self.joint_names, (inv @ (v - a)).tolist(), strict=True))

    def joints_from_pulses(self, pulses_us: Mapping[int, float]) -> dict[str, float]:
        """The actuated joints a set of joint-servo pulses puts the arm at.

        Args:
            pulses_us: Channel → pulse [µs]; every joint servo's channel (others ignored).

        Raises:
            KeyError: a joint servo's channel is missing.
        """
        return self.joints_of({j.name: j.value_of(pulses_us[j.channel]) for j in self.joints})

    def realised(self, joints: Mapping[str, float], mode: Quantization) -> dict[str, float]:
        """The actuated joints the servos realise for commanded ones, after quantisation.

        Each joint servo's value is quantised on its pulse grid (:meth:`ActuatorMap.realised`)
        and the joints are solved back from those values: exact for servos that turn a
        combination (the MeArm's elbow joint carries its own servo's step and the
        shoulder's), and the same as each joint's own realisation otherwise. With ``none``
        the joints are realised as commanded, bit for bit (solving a combination back
        would leave them a rounding off).
        """
        if mode == "none":
            return {n: float(joints[n]) for n in self.joint_names}
        servo = self.servo_values(joints)
        return self.joints_of({j.name: j.realised(servo[j.name], mode) for j in self.joints})

    def outside_pulse_range(self, q_actuated: npt.ArrayLike) -> PulseViolation | None:
        """The first servo over a combination of joints that poses put past its pulse range.

        A servo that turns its joint alone stays within its pulse range inside the joint's
        limits (the config is checked so); one that turns a combination (the MeArm's
        elbow servo: shoulder + elbow) can leave it there. The one check of this for every
        caller: the planner's before anything is sent, ``mearm ik`` on its solution and
        ``mearm fk`` on the joints it is given.

        Args:
            q_actuated: The actuated joints in config units (deg or cm), chain order, (m,)
                for one pose or (k, m) for k poses.

        Returns:
            The first such servo (in chain order) and the first pose that puts it out of
            range, or ``None`` when every pose is within every pulse range.
        """
        combination = self.combination
        if combination is None:
            return None
        A, a = combination
        values = np.atleast_2d(np.asarray(q_actuated, dtype=float)) @ A.T + a  # (poses, servos)
        for k, servo in enumerate(self.joints):
            if not servo.combined:
                continue
            lo, hi = servo.pulse_limits
            # NaN fails both comparisons: a pose of NaN is not refused here but by the limits
            out = np.flatnonzero((values[:, k] < lo - 1e-9) | (values[:, k] > hi + 1e-9))
            if out.size:
                i = int(out[0])
                return PulseViolation(i, servo, float(values[i, k]))
        return None

    def servo_range(self, name: str) -> tuple[float, float]:
        r"""The values a joint servo takes over the joints' limits, ascending [unit].

        Its own limits for a servo that turns its joint alone; for a combination, the
        range of :math:`\sum_j a_j q_j + a_0` with each joint anywhere within its limits.
        """
        j = self[name]
        if not j.terms:
            return (j.lower, j.upper)
        limits = {a.name: (a.lower, a.upper) for a in self.joints}
        lo = hi = j.offset
        for n, c in j.terms:
            ends = (c * limits[n][0], c * limits[n][1])
            lo, hi = lo + min(ends), hi + max(ends)
        return (lo, hi)

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

    def gripper_opening_cm(self, *, closed: bool) -> float:
        """The jaw opening for closed or open [cm]."""
        return self.gripper_closed_cm if closed else self.gripper_open_cm

    def check(self, command: ArmCommand) -> None:
        """Refuse a command that misses or misnames an actuator, or has a value out of range.

        Each joint in chain order is checked on its limits, then its servo's value (the
        joint's, or the combination it turns) on the pulse range; then the tool actuators.

        Raises:
            InvalidCommandError: a missing or unknown joint or tool actuator; the message
                names them and lists the arm's.
            JointLimitError: the first value (joints, then tool) outside its limits.
            PulseRangeError: the first servo value whose pulse leaves its channel's range.
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
            j.check_limits(command.joints[j.name])
            j.check_pulse(j.servo_value(command.joints))
        for a in self.tool:
            a.check(command.tool[a.name])

    def pulses_us(self, command: ArmCommand) -> dict[int, int]:
        """Checked integer pulses of a command, channel → µs, ascending channels."""
        self.check(command)
        pulses = {j.channel: j.command_us(j.servo_value(command.joints)) for j in self.joints}
        pulses.update({a.channel: a.command_us(command.tool[a.name]) for a in self.tool})
        g = self.gripper
        pulses[g.channel] = g.command_us(self.gripper_opening_cm(closed=command.gripper_closed))
        return dict(sorted(pulses.items()))

    def limit_pulses_us(self, command: ArmCommand) -> dict[int, tuple[float, float]]:
        r"""Each channel's pulses that keep every actuator within its limits, the others held.

        The bounds :class:`PlayCompensation` keeps a compensated pulse within: a joint
        servo's pulse may move only as far as keeps every joint it turns within its limits
        while the other servos keep their values (:math:`\delta q = A^{-1} e_k\,\delta v_k`:
        the MeArm's elbow servo moves the elbow joint alone), a tool actuator's within its
        limits; all within ``[min_us, max_us]``, the gripper's pulse range alone (open and
        closed are where its jaws are sent, compensated like any servo, not limits).

        Args:
            command: A command :meth:`check` passes.

        Returns:
            Channel → (lowest, highest) pulse [µs], exact (not rounded).
        """
        bounds: dict[int, tuple[float, float]] = {}
        names = self.joint_names
        q = np.array([float(command.joints[n]) for n in names])
        lower = np.array([j.lower for j in self.joints])
        upper = np.array([j.upper for j in self.joints])
        m = self._matrix
        inv = np.eye(len(names)) if m is None else m[2]
        servo = self.servo_values(command.joints)
        for k, j in enumerate(self.joints):
            lo, hi = -math.inf, math.inf  # how far the servo's value may move [unit]
            for r, c in enumerate(inv[:, k]):
                if abs(c) > 1e-12:
                    a, b = sorted(((lower[r] - q[r]) / c, (upper[r] - q[r]) / c))
                    lo, hi = max(lo, a), min(hi, b)
            bounds[j.channel] = _pulse_bounds(j, servo[j.name] + lo, servo[j.name] + hi)
        for t in self.tool:
            bounds[t.channel] = _pulse_bounds(t, t.lower, t.upper)
        g = self.gripper  # open and closed are where its jaws go, not limits to keep
        bounds[g.channel] = (float(g.min_us), float(g.max_us))
        return bounds


def _pulse_bounds(a: ActuatorMap, v0: float, v1: float) -> tuple[float, float]:
    """The pulses of values ``v0`` … ``v1`` of ``a``'s servo, within ``[min_us, max_us]``."""
    p0, p1 = sorted((a.pulse_us(v0), a.pulse_us(v1)))
    return (max(float(a.min_us), p0), min(float(a.max_us), p1))


class PlayCompensation:
    """Backlash compensation: each pulse sent half a servo's play further the way it moved.

    A hobby servo stops short of its pulse on the side it came from, by half its gears'
    backlash and dead band; a load can pull it through its play instead.
    :attr:`ActuatorMap.play_us` is the pulse a value needs reached rising less the one
    it needs reached falling, and the calibration's line is midway between the two; so a
    pulse moved up is sent ``play_us / 2`` higher and one moved down as much lower (the
    other way where ``play_us`` is negative); a pulse that does not change keeps the
    offset of its last move, and one never moved yet has none. The offset never takes a
    pulse past its bounds (:meth:`ServoMap.limit_pulses_us`: the pulses of the limits,
    inside ``[min_us, max_us]``): a play in the calibration larger than the servo's own,
    a file from another servo, would otherwise turn a joint commanded to its limit past
    it; at a limit the shaft stops short by its play instead, inside.
    """

    def __init__(self, servo_map: ServoMap):
        self._half = {a.channel: a.play_us / 2.0 for a in servo_map.actuators if a.play_us}
        self._range = {a.channel: (a.min_us, a.max_us) for a in servo_map.actuators}
        self._last: dict[int, int] = {}
        self._side: dict[int, int] = {}

    @property
    def active(self) -> bool:
        """Whether any servo has play to compensate."""
        return bool(self._half)

    def reset(self) -> None:
        """Forget the last moves (a new connection: the shafts' sides are unknown)."""
        self._last.clear()
        self._side.clear()

    def apply(
        self, pulses_us: Mapping[int, int], bounds_us: Mapping[int, tuple[float, float]]
    ) -> dict[int, int]:
        """The pulses to send for the calibrated ``pulses_us`` (channel → µs).

        Args:
            pulses_us: The command's pulses (:meth:`ServoMap.pulses_us`).
            bounds_us: How far each channel's pulse may go for this command
                (:meth:`ServoMap.limit_pulses_us`): the offset takes no pulse past them,
                nor past ``[min_us, max_us]``, unless the command's own pulse lies there
                (its rounding to the µs), which is then sent as it is.
        """
        out = dict(pulses_us)
        for channel, half in self._half.items():
            pulse = pulses_us[channel]
            last = self._last.get(channel)
            if last is not None and pulse != last:
                self._side[channel] = 1 if pulse > last else -1
            self._last[channel] = pulse
            lo, hi = self._range[channel]
            low, high = bounds_us[channel]
            lo = min(pulse, max(lo, math.ceil(low - 1e-6)))
            hi = max(pulse, min(hi, math.floor(high + 1e-6)))
            shifted = math.floor(pulse + self._side.get(channel, 0) * half + 0.5)
            out[channel] = min(hi, max(lo, shifted))
        return out
