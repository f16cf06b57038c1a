r"""An actuator's pulse calibration, and the combination of joints a servo may turn.

.. math:: p = p_0 + s\,k\,v

maps a servo's value v (deg, or cm for a prismatic joint or a gripper opening) to its
pulse p [µs]; a joint's servo may turn a linear combination of actuated joints

.. math:: v_k = \sum_j a_{kj}\, q_j + a_k

instead of its own joint alone (the MeArm's elbow servo: v = θ2 + θ3).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Annotated, Literal

from pydantic import Field, model_validator

from mearm.config.base import Length, Name, Strict

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
#: Pulse change per degree of a hobby servo's output shaft [µs/deg]: the nominal
#: 600–2400 µs over 180° these configs calibrate to (SG90, MG90S, MG996R alike).
US_PER_SERVO_DEG = 10.0
#: The pulse at which a hobby servo is centred [µs]: its scale error pivots here.
NEUTRAL_US = 1500.0
#: The fields of a servo's line from value to pulse (each has a default, a guess).
CALIBRATION_FIELDS = ("zero_us", "direction", "us_per_unit")
#: Speeds a servo may be given [s/60°]: the fastest hobby servos turn at about 0.04 s/60°,
#: sail-winch servos at about 1 s/60°.
SECONDS_PER_60DEG_RANGE = (0.01, 2.0)
#: Shaft accelerations a servo may be given [deg/s²].
ACCEL_DEG_S2_RANGE = (100.0, 1e6)

Coefficient = Annotated[float, Field(ge=-MAX_COUPLING, le=MAX_COUPLING, allow_inf_nan=False)]


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
        return self.value_accel(self.max_accel_deg_s2)

    def value_accel(self, shaft_deg_s2: float) -> float:
        """The value's acceleration [deg/s² or cm/s²] when the shaft's is ``shaft_deg_s2``."""
        return shaft_deg_s2 * US_PER_SERVO_DEG / self.us_per_unit

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
        # a calibration field left out takes a default no servo was measured to have: say
        # so, or a forgotten zero_us reads as a wrong limit
        defaulted = [
            f"{k} {getattr(self, k):g}"
            for k in CALIBRATION_FIELDS
            if k not in self.model_fields_set
        ]
        given = f" ({', '.join(defaulted)}: not given, the defaults)" if defaulted else ""
        return (
            f"needs a {p:.0f} µs pulse, outside the servo's [{self.min_us}, {self.max_us}] "
            f"µs, which allows [{lo:.4g}, {hi:.4g}]{given}"
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
