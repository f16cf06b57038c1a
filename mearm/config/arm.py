r"""The arm as data: joints, their actuators or couplings, the tool, the target box.

An arm is an ordered list of joints, each one standard Denavit–Hartenberg row

.. math:: T_{i-1,i} = R_z(\theta_i)\,T_z(d_i)\,T_x(a_i)\,R_x(\alpha_i)

whose variable is θ (``revolute``, degrees) or d (``prismatic``, centimetres). A joint is
either *actuated* — it has a ``servo`` with its pulse calibration, its limits and its home
value — or *passive*: an affine function of the actuated joints,

.. math:: q_p = \sum_j c_{pj}\, q_j + c_p

(the paper's parallelogram: θ4 = −θ2 − θ3). The actuated joints are the chain's
independent coordinates. Each one's servo turns, by default, that joint alone; a servo
may instead turn a linear combination of actuated joints (its ``drives``),

.. math:: v_k = \sum_j a_{kj}\, q_j + a_k

(the MeArm's elbow servo sets the forearm's angle to the table: v = θ2 + θ3), and its
calibration maps v, not the joint's own value, to a pulse. The servos' combinations must
be independent — the square matrix :math:`A = (a_{kj})` invertible — so that the pulses
fix every actuated joint (:meth:`ArmDescription.servo_matrix`).

The tool sits on the last frame: the tool centre point (TCP), the axis it approaches
along, the gripper (a named actuator with its own calibration, open/closed settings and
jaw geometry) and any tool actuators that do not move the TCP (the paper's gripper-arm
servo).

Everything is checked when the config loads: names unique, couplings and servo
combinations naming actuated joints, the combinations independent, every limit and
setting inside its servo's pulse range (for a servo over several joints: its value at
home, since its pulse then depends on the pose), a chain that can move the TCP in three
directions.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Annotated, Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from mearm.config.base import (
    MAX_ANGLE_DEG,
    MAX_LENGTH_CM,
    Angle,
    Length,
    Name,
    NonNegativeLength,
    PositiveLength,
    Range,
    Strict,
    Vector3,
)

#: Pulse widths a calibration may name [µs]: a servo's zero may lie outside the pulses it
#: is allowed, but not absurdly far.
MAX_ZERO_US = 100_000.0
#: Largest play, either way, a servo calibration may compensate [µs]: 10° of a standard
#: servo's scale.
MAX_PLAY_US = 100.0
#: Pulse change per unit [µs/deg or µs/cm]: 0.1 lets one servo sweep 20 000 units, 10 000
#: moves 0.2 units over the whole pulse range.
US_PER_UNIT_RANGE = (0.1, 10_000.0)
#: Largest coupling coefficient [-].
MAX_COUPLING = 100.0
#: Jaws thinner or shorter than this cannot be drawn or gripped with [cm].
MIN_JAW_CM = 0.01
#: Pulse change per degree of a hobby servo's output shaft [µs/deg]: the nominal
#: 600–2400 µs over 180° these configs calibrate to (SG90, MG90S, MG996R alike).
US_PER_SERVO_DEG = 10.0
#: Speeds a servo may be given [s/60°]: the fastest hobby servos turn at about 0.04 s/60°,
#: sail-winch servos at about 1 s/60°.
SECONDS_PER_60DEG_RANGE = (0.01, 2.0)
#: Shaft accelerations a servo may be given [deg/s²].
ACCEL_DEG_S2_RANGE = (100.0, 1e6)

Coefficient = Annotated[float, Field(ge=-MAX_COUPLING, le=MAX_COUPLING, allow_inf_nan=False)]

JointType = Literal["revolute", "prismatic"]


class DHRow(Strict):
    r"""One standard DH row, :math:`R_z(\theta)\,T_z(d)\,T_x(a)\,R_x(\alpha)`.

    For a revolute joint the variable is added to ``theta_deg``; for a prismatic joint
    it is added to ``d_cm``.
    """

    a_cm: Length = 0.0
    alpha_deg: Angle = 0.0
    d_cm: Length = 0.0
    theta_deg: Angle = 0.0
    """Constant offset of θ [deg] (the joint variable of a revolute joint adds to it)."""

    def transform(self, value: float, joint_type: JointType = "revolute") -> np.ndarray:
        """The (4, 4) transform of this row at joint value ``value``.

        Args:
            value: θ [rad] for a revolute joint, d [cm] for a prismatic one.
            joint_type: ``revolute`` or ``prismatic``.

        Returns:
            The homogeneous transform, translation in cm.
        """
        theta = math.radians(self.theta_deg)
        d = self.d_cm
        if joint_type == "revolute":
            theta += value
        else:
            d += value
        ct, st = math.cos(theta), math.sin(theta)
        alpha = math.radians(self.alpha_deg)
        ca, sa = math.cos(alpha), math.sin(alpha)
        return np.array(
            [
                [ct, -ca * st, sa * st, self.a_cm * ct],
                [st, ca * ct, -sa * ct, self.a_cm * st],
                [0.0, sa, ca, d],
                [0.0, 0.0, 0.0, 1.0],
            ]
        )


class ServoCalibration(Strict):
    r"""One actuator's pulse calibration: value ↔ pulse width.

    .. math:: p = p_0 + s\,k\,v

    with ``zero_us`` = p0 [µs], ``direction`` = s (±1), ``us_per_unit`` = k [µs per deg,
    or per cm for a prismatic joint or a gripper opening] and v the value. A value whose
    pulse leaves [min_us, max_us] is refused, never clamped.
    """

    channel: int = Field(ge=0, le=31)
    zero_us: float = Field(default=1500.0, ge=-MAX_ZERO_US, le=MAX_ZERO_US, allow_inf_nan=False)
    """Pulse at value 0 [µs]; may lie outside [min_us, max_us]."""
    direction: Literal[1, -1] = 1
    us_per_unit: float = Field(
        default=10.0, ge=US_PER_UNIT_RANGE[0], le=US_PER_UNIT_RANGE[1], allow_inf_nan=False
    )
    """Pulse change per unit of the value [µs/deg or µs/cm]."""
    min_us: int = Field(default=600, ge=500, le=2500)
    """Lowest pulse this servo may get [µs] (the firmware and the SSC-32 allow 500–2500)."""
    max_us: int = Field(default=2400, ge=500, le=2500)
    """Highest pulse this servo may get [µs]."""
    seconds_per_60deg: float = Field(
        default=0.10,
        ge=SECONDS_PER_60DEG_RANGE[0],
        le=SECONDS_PER_60DEG_RANGE[1],
        allow_inf_nan=False,
    )
    """The servo's speed limit: how long its shaft takes to turn 60° [s/60°]. The default
    is the TowerPro SG90's and MG90S's datasheet no-load speed, 0.10 s/60° at 4.8 V (the
    MG996R's is 0.17, the paper's RDS3135 about 0.15 at 6.8 V:
    :mod:`mearm.config.servo_models`). Streamed trajectories never command a faster turn
    (:meth:`max_speed`)."""
    max_accel_deg_s2: float | None = Field(
        default=None, ge=ACCEL_DEG_S2_RANGE[0], le=ACCEL_DEG_S2_RANGE[1], allow_inf_nan=False
    )
    """The shaft's acceleration limit [deg/s²]; ``null``: not given (hobby servo
    datasheets give none): then only the speed limit bounds a move."""
    play_us: float = Field(default=0.0, ge=-MAX_PLAY_US, le=MAX_PLAY_US, allow_inf_nan=False)
    """How much farther the pulse must go to put the shaft at a value reached with the
    pulse rising than with it falling [µs], as ``mearm calibrate-servos --camera``
    measures it: positive where the shaft stops short the way it moved (the gears' play
    and the dead band), less or negative where a load pulls it through its play. Each
    pulse is sent half of it further the way the pulse last moved (backlash
    compensation), so the shaft stops where the calibration's line says from either
    side; never outside ``[min_us, max_us]``. ``0``: no compensation."""

    @model_validator(mode="after")
    def _pulse_range(self) -> ServoCalibration:
        if not self.min_us < self.max_us:
            raise ValueError(f"min_us ({self.min_us}) must be below max_us ({self.max_us})")
        return self

    def pulse_us(self, value: float) -> float:
        """Exact pulse for a value [µs]."""
        return self.zero_us + self.direction * self.us_per_unit * value

    def max_speed(self) -> float:
        r"""The fastest the value may change [deg/s or cm/s: the value's unit per second].

        .. math:: \dot v_{max} = \frac{60°}{t_{60}}\,\frac{k_s}{k}

        with :math:`t_{60}` = ``seconds_per_60deg``, :math:`k_s` =
        :data:`US_PER_SERVO_DEG` and :math:`k` = ``us_per_unit``.
        """
        return 60.0 / self.seconds_per_60deg * US_PER_SERVO_DEG / self.us_per_unit

    def max_accel(self) -> float | None:
        """The acceleration limit of the value [deg/s² or cm/s²], or ``None`` if not given."""
        if self.max_accel_deg_s2 is None:
            return None
        return self.max_accel_deg_s2 * US_PER_SERVO_DEG / self.us_per_unit

    def value_range(self) -> tuple[float, float]:
        """The values at ``min_us`` and ``max_us``, ascending."""
        a = (self.min_us - self.zero_us) / (self.direction * self.us_per_unit)
        b = (self.max_us - self.zero_us) / (self.direction * self.us_per_unit)
        return (min(a, b), max(a, b))

    def pulse_problem(self, value: float) -> str | None:
        """Why ``value``'s pulse leaves the range (one clause), or ``None`` if it does not."""
        p = self.pulse_us(value)
        if self.min_us - 1e-6 <= p <= self.max_us + 1e-6:
            return None
        lo, hi = self.value_range()
        return (
            f"needs a {p:.0f} µs pulse, outside the servo's [{self.min_us}, {self.max_us}] "
            f"µs, which allows [{lo:.4g}, {hi:.4g}]"
        )

    def check_value(self, value: float, what: str) -> None:
        """Raise ``ValueError`` naming ``what`` if ``value``'s pulse leaves the range."""
        problem = self.pulse_problem(value)
        if problem is not None:
            raise ValueError(f"@{what}: {value:g} {problem}")


class ServoDrives(Strict):
    r"""What a joint's servo turns when it is not that joint alone: a linear combination.

    .. math:: v = \sum_j a_j\, q_j + a_0

    ``terms`` maps actuated joint names to coefficients a_j [-; the servo's unit per the
    joint's, for a prismatic joint among revolute ones]; ``offset`` a_0 is in the unit of
    the joint the servo sits in (deg or cm). The servo's calibration maps v to a pulse. A
    MeArm's elbow servo sets the forearm's angle to the table, shoulder plus elbow in DH
    terms: ``terms: {shoulder: 1, elbow: 1}``. Without ``drives`` a servo turns its own
    joint: ``terms: {<its joint>: 1}``, ``offset: 0``.
    """

    terms: dict[Name, Coefficient] = Field(min_length=1, max_length=12)
    offset: Length = 0.0

    def text(self) -> str:
        """The combination as written: ``shoulder + elbow``, ``2·shoulder - elbow + 10``."""
        return combination_text(self.terms.items(), self.offset)


def combination_text(terms: Iterable[tuple[str, float]], offset: float = 0.0) -> str:
    """A linear combination in words: ``shoulder + elbow``, ``2·shoulder - elbow + 10``."""
    out = ""
    for name, c in terms:
        mag = "" if abs(c) == 1 else f"{abs(c):g}·"
        out += (
            f" {'-' if c < 0 else '+'} {mag}{name}" if out else f"{'-' if c < 0 else ''}{mag}{name}"
        )
    if offset:
        out += f" {'-' if offset < 0 else '+'} {abs(offset):g}"
    return out


class JointServo(ServoCalibration):
    r"""An actuated joint's servo: its pulse calibration and what it turns.

    .. math:: p = p_0 + s\,k\,v

    with ``zero_us`` = p0 [µs], ``direction`` = s (±1), ``us_per_unit`` = k [µs per deg,
    or per cm for a prismatic joint] and v the servo's value: the joint's own, unless
    ``drives`` names a combination of actuated joints (the MeArm's elbow servo turns
    shoulder + elbow). The joint's limits are checked on the joint, the pulse range on v;
    a value whose pulse leaves [min_us, max_us] is refused, never clamped.
    """

    drives: ServoDrives | None = None
    """The combination of actuated joints this servo turns (:class:`ServoDrives`);
    ``null``: the joint it sits in, alone."""

    def combination(self, joint: str) -> ServoDrives:
        """What this servo turns, sitting in joint ``joint``: its ``drives`` or ``joint`` alone."""
        return self.drives if self.drives is not None else ServoDrives(terms={joint: 1.0})

    def drives_only(self, joint: str) -> bool:
        """Whether its value depends on ``joint`` alone (so its limits can be checked alone)."""
        return self.drives is None or set(self.drives.terms) == {joint}


class Coupling(Strict):
    """A passive joint's value as an affine function of actuated joints.

    ``terms`` maps actuated joint names to coefficients [-]; ``offset`` is in the
    joint's unit (deg or cm). The paper arm's parallelogram: ``terms: {shoulder: -1,
    elbow: -1}``.
    """

    terms: dict[Name, Coefficient] = Field(min_length=1, max_length=12)
    offset: Length = 0.0


class Joint(Strict):
    """One joint of the chain: its DH row and either a servo (actuated) or a coupling."""

    name: Name
    type: JointType = "revolute"
    dh: DHRow = DHRow()
    limits: Range | None = None
    """[deg] or [cm]; required for an actuated joint; a passive joint's default is the
    range its coupling gives over the actuated joints' limits."""
    home: Length | None = None
    """Home value of an actuated joint [deg] or [cm]."""
    servo: JointServo | None = None
    coupling: Coupling | None = None

    @field_validator("servo", mode="before")
    @classmethod
    def _joint_servo(cls, value: object) -> object:
        """A plain :class:`ServoCalibration` given in code is a servo that turns its joint."""
        if isinstance(value, ServoCalibration) and not isinstance(value, JointServo):
            return value.model_dump()
        return value

    @model_validator(mode="after")
    def _actuated_or_passive(self) -> Joint:
        if (self.servo is None) == (self.coupling is None):
            raise ValueError(
                f"joint '{self.name}' needs exactly one of 'servo' (actuated) or "
                "'coupling' (passive)"
            )
        if self.type == "revolute" and self.limits is not None:
            for end in ("min", "max"):
                if abs(getattr(self.limits, end)) > MAX_ANGLE_DEG:
                    raise ValueError(
                        f"@limits.{end}: {getattr(self.limits, end):g} deg is more than a "
                        f"turn; a revolute joint's limits lie within ±{MAX_ANGLE_DEG:g} deg"
                    )
        if self.servo is not None:
            if self.limits is None:
                raise ValueError("@limits: required for an actuated joint")
            if self.home is None:
                raise ValueError("@home: required for an actuated joint")
            if not self.limits.contains(self.home):
                raise ValueError(
                    f"@home: {self.home:g} is outside the limits "
                    f"[{self.limits.min:g}, {self.limits.max:g}]"
                )
            self._check_servo(self.servo, self.limits)
        elif self.home is not None:
            raise ValueError("@home: a passive joint takes no home: its coupling gives it")
        elif self.type == "revolute" and self.coupling is not None:
            if abs(self.coupling.offset) > MAX_ANGLE_DEG:
                raise ValueError(
                    f"@coupling.offset: {self.coupling.offset:g} deg is more than a turn; a "
                    f"revolute joint's offset lies within ±{MAX_ANGLE_DEG:g} deg"
                )
        return self

    def _check_servo(self, servo: JointServo, limits: Range) -> None:
        """The servo's own checks: a combination that turns something, limits in range.

        A servo over this joint alone has its pulse range checked at both limits; one over
        several joints is checked where the arm is (:class:`ArmDescription`).
        """
        drives = servo.drives
        if drives is not None:
            if all(c == 0 for c in drives.terms.values()):
                raise ValueError(
                    "@servo.drives.terms: every coefficient is 0: the servo would turn "
                    "nothing; give at least one joint a non-zero coefficient"
                )
            if self.type == "revolute" and abs(drives.offset) > MAX_ANGLE_DEG:
                raise ValueError(
                    f"@servo.drives.offset: {drives.offset:g} deg is more than a turn; a "
                    f"revolute joint's servo offset lies within ±{MAX_ANGLE_DEG:g} deg"
                )
        if not servo.drives_only(self.name):
            return
        own = servo.combination(self.name)
        c = own.terms[self.name]
        for end in ("min", "max"):
            value = getattr(limits, end)
            if drives is None:
                servo.check_value(value, f"limits.{end}")
                continue
            v = c * value + own.offset
            problem = servo.pulse_problem(v)
            if problem is not None:
                raise ValueError(
                    f"@limits.{end}: {value:g} puts its servo's value {own.text()} at {v:g}, "
                    f"which {problem}"
                )

    @property
    def actuated(self) -> bool:
        """Whether a servo drives this joint."""
        return self.servo is not None

    @property
    def unit(self) -> str:
        """``deg`` or ``cm``."""
        return "deg" if self.type == "revolute" else "cm"


class ToolActuator(Strict):
    """A tool servo that does not move the TCP, set per phase of a pick.

    The paper's gripper arm (θ5) is one: 60° at home, 30° while travelling, −60° to grip.
    """

    name: Name
    servo: ServoCalibration
    limits: Range
    home: Angle
    travel: Angle
    grip: Angle

    @model_validator(mode="after")
    def _settings(self) -> ToolActuator:
        for end in ("min", "max"):
            if abs(getattr(self.limits, end)) > MAX_ANGLE_DEG:
                raise ValueError(
                    f"@limits.{end}: {getattr(self.limits, end):g} deg is more than a turn; "
                    f"a tool actuator's limits lie within ±{MAX_ANGLE_DEG:g} deg"
                )
        for end in ("min", "max"):
            self.servo.check_value(getattr(self.limits, end), f"limits.{end}")
        for key in ("home", "travel", "grip"):
            value = getattr(self, key)
            if not self.limits.contains(value):
                raise ValueError(
                    f"@{key}: {value:g} is outside the limits "
                    f"[{self.limits.min:g}, {self.limits.max:g}]"
                )
        return self

    def setting(self, phase: Literal["home", "travel", "grip"]) -> float:
        """The value for a phase of the pick [deg]."""
        return float(getattr(self, phase))


class Gripper(Strict):
    """The gripper: a named actuator that sets the opening between two parallel jaws.

    Its calibration maps the opening [cm] to a pulse. The URDF draws the jaws as two
    prismatic joints, the second a ``mimic`` of the first.
    """

    name: Name = "gripper"
    servo: ServoCalibration
    open_cm: PositiveLength
    """Opening between the jaws when open [cm]."""
    closed_cm: NonNegativeLength
    """Opening when closed on nothing [cm]."""
    jaw_length_cm: float = Field(default=3.0, ge=MIN_JAW_CM, le=MAX_LENGTH_CM, allow_inf_nan=False)
    """A jaw's length along the approach axis, measured from its root to its tip [cm]. The
    jaws sit where they grip: each ends in a pad centred on the grip point
    (``tcp_above_grip_cm`` beyond the TCP), so the tip is half a pad beyond it and the
    root this much before the tip; a mount bridges the TCP to the roots when they start
    beyond it."""
    jaw_thickness_cm: float = Field(
        default=0.5, ge=MIN_JAW_CM, le=MAX_LENGTH_CM, allow_inf_nan=False
    )
    """A jaw's thickness along the opening axis; its inner face is at half the opening [cm]."""

    @model_validator(mode="after")
    def _settings(self) -> Gripper:
        if not self.closed_cm < self.open_cm:
            raise ValueError(
                f"@closed_cm: {self.closed_cm:g} must be below open_cm ({self.open_cm:g})"
            )
        self.servo.check_value(self.open_cm, "open_cm")
        self.servo.check_value(self.closed_cm, "closed_cm")
        return self

    def opening_cm(self, closed: bool) -> float:
        """The opening for closed or open [cm]."""
        return self.closed_cm if closed else self.open_cm


class ClawMarker(Strict):
    """An ArUco marker fixed on the tool, so that the camera sees where the claw is.

    The marker is printed on a stiff plate (``mearm aruco-sheet`` prints it) whose face
    looks along :attr:`faces` (by default away from the jaws along the tool's approach
    axis: up, when the jaws hang down to pick). Its top edge points along the jaws' third
    axis (across the approach and the opening axes) or, where the face looks along that,
    along the approach axis.
    ``calibrate-servos --camera`` and the sort's picks that look
    (:mod:`mearm.task.claw_loop`) measure it with the calibrated camera.
    """

    id: int = Field(ge=0, le=999)
    """The marker's id in :attr:`dictionary`."""
    size_cm: PositiveLength
    """The printed side of the marker's black square [cm]."""
    dictionary: str = "DICT_4X4_50"
    """The ArUco dictionary it is printed from (OpenCV's name)."""
    faces: Vector3 | None = None
    """Where the marker's face looks, in the TCP frame; ``null``: against the approach axis."""
    centre_cm: Vector3 | None = None
    """The marker's centre in the TCP frame [cm]; ``null``: on the plate resting on the
    gripper's servo (and each tool actuator's) on the side :attr:`faces` names."""
    border_cm: NonNegativeLength = 0.5
    """The white plate's margin around the black square [cm]."""

    @model_validator(mode="after")
    def _face(self) -> ClawMarker:
        if self.faces is not None and math.hypot(*self.faces) < 1e-9:
            raise ValueError(f"@faces: must be a non-zero vector, got {list(self.faces)}")
        return self


class Tool(Strict):
    """What sits on the last frame of the chain."""

    tcp_cm: Vector3 = (0.0, 0.0, 0.0)
    """The tool centre point in the last DH frame [cm]: what IK targets move."""
    approach_axis: Vector3 = (0.0, 0.0, 1.0)
    """The tool's approach axis in the last DH frame (normalised when used)."""
    pick_approach: Vector3 | None = None
    """Direction (base frame) the approach axis must point in when picking and placing,
    e.g. ``[0, 0, -1]`` for a wrist that picks from above; ``null``: position only."""
    tcp_above_grip_cm: NonNegativeLength = 0.0
    """How far above the point where the jaws close the TCP is when picking [cm]."""
    settle_s: float = Field(default=0.1, ge=0, le=10, allow_inf_nan=False)
    """How long a tool setting (the gripper opening or closing, a tool actuator moving)
    is held after its servos' travel at their speed limit, before the arm moves on [s].
    The default, 0.1 s, is four times a micro servo motor's time constant (about 25 ms,
    :data:`mearm.config.servo_models.MOTOR_TIME_CONSTANT_S`): room for the jaws to stop
    and the grip to take hold."""
    gripper: Gripper
    actuators: list[ToolActuator] = Field(default_factory=list, max_length=12)
    marker: ClawMarker | None = None
    """An ArUco marker on the claw, for the camera to measure the arm (``null``: none)."""

    @model_validator(mode="after")
    def _axes(self) -> Tool:
        for key in ("approach_axis", "pick_approach"):
            v = getattr(self, key)
            if v is not None and math.hypot(*v) < 1e-9:
                raise ValueError(f"@{key}: must be a non-zero vector, got {list(v)}")
        return self


class TargetBox(Strict):
    """Where TCP targets may lie, base frame [cm] (the paper's Table 3 for its arm)."""

    x_cm: Range = Range(min=-40, max=40)
    y_cm: Range = Range(min=20, max=60)
    z_cm: Range = Range(min=10, max=60)


def _interval(terms: dict[str, float], offset: float, limits: dict[str, Range]) -> Range:
    lo = hi = offset
    for name, c in terms.items():
        a, b = c * limits[name].min, c * limits[name].max
        lo, hi = lo + min(a, b), hi + max(a, b)
    if not lo < hi:
        hi = lo + 1e-9
    return Range.model_construct(min=lo, max=hi)  # derived, may exceed a config's bounds


#: Seeded poses tried by the chain's rank check.
_RANK_POSES = 24


class ArmDescription(Strict):
    """The whole arm: the chain, the tool and the target box.

    Attributes:
        name: The arm's name (the URDF's robot name).
        joints: The chain, base first.
        tool: TCP, approach axis, gripper and tool actuators.
        target_box: Where targets may lie.
        closed_form: A registered closed-form IK plug-in for this arm, or ``null``.
    """

    name: Name
    joints: list[Joint] = Field(min_length=1, max_length=12)
    tool: Tool
    target_box: TargetBox = TargetBox()
    closed_form: Name | None = None

    @model_validator(mode="after")
    def _consistent(self) -> ArmDescription:
        names = [j.name for j in self.joints]
        tool_names = [a.name for a in self.tool.actuators] + [self.tool.gripper.name]
        seen: set[str] = set()
        for n in names + tool_names:
            if n in seen:
                raise ValueError(f"name '{n}' is used twice (joints and tool actuators)")
            seen.add(n)
        actuated = [j.name for j in self.joints if j.actuated]
        if not actuated:
            raise ValueError("@joints: no joint is actuated: give at least one a 'servo'")
        for j in self.joints:
            if j.coupling is None:
                continue
            for term in j.coupling.terms:
                if term not in actuated:
                    allowed = ", ".join(actuated)
                    raise ValueError(
                        f"@joints.{j.name}.coupling.terms: '{term}' is not an actuated joint of "
                        f"this arm (actuated: {allowed})"
                    )
        channels: dict[int, str] = {}
        servos: list[tuple[str, ServoCalibration]] = [
            (j.name, j.servo) for j in self.joints if j.servo is not None
        ]
        servos += [(a.name, a.servo) for a in self.tool.actuators]
        servos.append((self.tool.gripper.name, self.tool.gripper.servo))
        for name, servo in servos:
            if servo.channel in channels:
                raise ValueError(
                    f"@joints: {name} and {channels[servo.channel]} share servo channel "
                    f"{servo.channel}"
                )
            channels[servo.channel] = name
        self._check_drives()
        self._check_rank()
        return self

    def _check_drives(self) -> None:
        """Refuse servo combinations naming a missing or passive joint, or not independent.

        Also a servo over several joints whose value at home needs a pulse outside its
        range: the arm could not go home.
        """
        index = {j.name: i for i, j in enumerate(self.joints)}
        actuated = [j.name for j in self.joints if j.actuated]
        for j in self.joints:
            if j.servo is None or j.servo.drives is None:
                continue
            for term in j.servo.drives.terms:
                if term not in index:
                    raise ValueError(
                        f"@joints.{j.name}.servo.drives.terms: '{term}' is not a joint of this arm "
                        f"(its actuated joints: {', '.join(actuated)})"
                    )
                if term not in actuated:
                    raise ValueError(
                        f"@joints.{j.name}.servo.drives.terms: '{term}' is a passive joint (its "
                        "coupling sets it); a servo turns actuated joints: "
                        f"{', '.join(actuated)}"
                    )
        A, _ = self.servo_matrix()
        act = self.actuated_joints()
        scale = np.abs(A).max(axis=1, keepdims=True)
        rows = A / scale  # each row's largest coefficient 1: the rank test sees shapes
        for k in range(len(act)):
            if np.linalg.matrix_rank(rows[: k + 1], tol=1e-9) == k + 1:
                continue
            # the rows that depend on each other: a left null vector of rows[:k + 1]
            _, _, vt = np.linalg.svd(rows[: k + 1].T)
            involved = [r for r in range(k + 1) if abs(vt[-1, r]) > 1e-6]
            named = [r for r in involved if getattr(act[r].servo, "drives", None) is not None]
            blame = named[-1] if named else k
            joint = act[blame]
            assert joint.servo is not None
            others = [act[r].name for r in involved if r != blame]
            raise ValueError(
                f"@joints.{joint.name}.servo.drives: {joint.name}'s servo turns "
                f"{joint.servo.combination(joint.name).text()}, which depends on what the "
                f"servo{'s' if len(others) > 1 else ''} of {', '.join(others)} turn"
                f"{'' if len(others) > 1 else 's'}: the servos' combinations must be "
                "independent, or the pulses cannot set every actuated joint"
            )
        home = self.home()
        for j in self.joints:
            if j.servo is None or j.servo.drives_only(j.name):
                continue
            combo = j.servo.combination(j.name)
            v = combo.offset + sum(c * home[n] for n, c in combo.terms.items())
            p = j.servo.pulse_us(v)
            if not j.servo.min_us - 1e-6 <= p <= j.servo.max_us + 1e-6:
                lo, hi = j.servo.value_range()
                raise ValueError(
                    f"@joints.{j.name}.servo.drives: at home its servo's value {combo.text()} is "
                    f"{v:g}, which needs a {p:.0f} µs pulse, outside the servo's "
                    f"[{j.servo.min_us}, {j.servo.max_us}] µs, which allows [{lo:.4g}, {hi:.4g}]"
                )

    # ----------------------------------------------------------------- derived

    def actuated_joints(self) -> list[Joint]:
        """The actuated joints, in chain order."""
        return [j for j in self.joints if j.actuated]

    def joint_limits(self) -> dict[str, Range]:
        """Every joint's limits; a passive joint without its own, from its coupling."""
        limits = {j.name: j.limits for j in self.joints if j.limits is not None}
        out: dict[str, Range] = {}
        for j in self.joints:
            if j.limits is not None:
                out[j.name] = j.limits
            else:
                assert j.coupling is not None
                out[j.name] = _interval(j.coupling.terms, j.coupling.offset, limits)
        return out

    def full_values(self, actuated: dict[str, float]) -> dict[str, float]:
        """Every joint's value from the actuated ones [deg or cm]."""
        out: dict[str, float] = {}
        for j in self.joints:
            if j.coupling is None:
                out[j.name] = float(actuated[j.name])
            else:
                out[j.name] = j.coupling.offset + sum(
                    c * float(actuated[n]) for n, c in j.coupling.terms.items()
                )
        return out

    def servo_matrix(self) -> tuple[np.ndarray, np.ndarray]:
        r"""What the actuated joints' servos turn: :math:`v = A\,q_a + a`, config units.

        Returns:
            ``A`` (m, m): row k is the combination the servo of the k-th actuated joint
            turns, columns the actuated joints in chain order (the identity when every
            servo turns its own joint); ``a`` (m,): the offsets.
        """
        act = self.actuated_joints()
        col = {j.name: k for k, j in enumerate(act)}
        A = np.zeros((len(act), len(act)))
        a = np.zeros(len(act))
        for k, j in enumerate(act):
            assert j.servo is not None
            combo = j.servo.combination(j.name)
            for name, c in combo.terms.items():
                if name in col:  # a name outside them is refused by the validator
                    A[k, col[name]] = c
            a[k] = combo.offset
        return A, a

    def home(self) -> dict[str, float]:
        """Home of the actuated joints [deg or cm]."""
        return {j.name: float(j.home) for j in self.joints if j.home is not None}

    def tcp_cm(self, values: dict[str, float]) -> np.ndarray:
        """TCP position [cm], (3,), by the DH product (values of every joint, deg or cm)."""
        T = np.eye(4)
        for j in self.joints:
            v = values[j.name]
            T = T @ j.dh.transform(math.radians(v) if j.type == "revolute" else v, j.type)
        return (T @ np.array([*self.tool.tcp_cm, 1.0]))[:3]

    def _check_rank(self) -> None:
        """Refuse a chain that cannot move the TCP in three independent directions."""
        act = self.actuated_joints()
        limits = {j.name: j.limits for j in act}
        rng = np.random.default_rng(0)
        need = min(3, len(act))
        best = 0
        for k in range(_RANK_POSES):
            if k == 0:
                base = self.home()
            else:
                base = {
                    n: float(rng.uniform(r.min, r.max)) for n, r in limits.items() if r is not None
                }
            p0 = self.tcp_cm(self.full_values(base))
            cols = []
            for n in base:
                h = 1e-4
                moved = dict(base)
                moved[n] += h
                cols.append((self.tcp_cm(self.full_values(moved)) - p0) / h)
            rank = int(np.linalg.matrix_rank(np.stack(cols, axis=1), tol=1e-6))
            best = max(best, rank)
            if best >= need:
                return
        raise ValueError(
            f"@joints: singular chain: the TCP moves in at most {best} independent direction(s) "
            f"at {_RANK_POSES} poses within the limits; a sorting arm needs {need}"
            " (check the DH rows: lengths a_cm/d_cm and twists alpha_deg)"
        )
