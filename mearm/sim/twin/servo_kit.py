r"""A kit of servos: real hobby servos differ unit by unit, and the twin can draw its own.

Without a kit (``twin.kit: null``) every servo of the twin is the datasheet's nominal one:
the pulse the bus sends turns its shaft exactly as the arm's calibration says. With one
(``twin.kit: {seed: 7}``) each servo — every joint's and the gripper's — is a
:class:`ServoUnit` drawn from :data:`KIT_RANGES`, the spread of real units that datasheets
and published measurements give. The bus still converts values to pulses through the
arm's (nominal) calibration; the unit turns by its own mapping:

.. math:: \theta = (p - p_n)/k_u + \theta_0

(:math:`p_n` = :data:`NEUTRAL_US`, :math:`k_u` its µs per shaft degree, :math:`\theta_0`
its zero offset), where the nominal servo has :math:`k = 10` µs/° and no offset. The
twin puts that into the pulse the nominal mapping would need for the same shaft angle
(:meth:`ServoUnit.nominal_pulse`). The unit's backlash (the play a reversal must take up
before the shaft moves back) and its dead band replace the datasheet's.

Each value is drawn uniformly over its range: the sources give ranges (a few units, a
calibration table), no distribution. ``twin.kit.spread`` multiplies the calibration errors
(zero offset, scale deviation from nominal); it is the one factor a prediction may fit
(docs/twin.md). Sag under load is not drawn: the twin's servo holds a load through its
position loop and stall torque (:mod:`mearm.sim.twin.mjcf`), the same for every unit.

Plain data and NumPy; the config holds only the seed, whether a trial draws its own kit,
and the spread (:class:`~mearm.config.root.ServoKitConfig`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mearm.config.arm import US_PER_SERVO_DEG

#: Largest spread: the slowest unit's scale stays positive (10 − 5 × 1.9 µs/°).
MAX_SPREAD = 5.0
#: The pulse at which a hobby servo is centred; its scale error pivots here [µs].
NEUTRAL_US = 1500.0


@dataclass(frozen=True)
class UnitRange:
    """The range real units of a per-unit figure span, and where it comes from.

    Attributes:
        name: The :class:`ServoUnit` field it draws.
        low: Lower end [unit].
        high: Upper end [unit].
        unit: Its unit.
        nominal: The datasheet's nominal servo's value (``None``: the servo model's own,
            as for the dead band).
        source: Where the range comes from.
    """

    name: str
    low: float
    high: float
    unit: str
    nominal: float | None
    source: str


#: The per-unit ranges, with their sources.
KIT_RANGES: dict[str, UnitRange] = {
    r.name: r
    for r in (
        UnitRange(
            "zero_offset_deg",
            -2.0,
            2.0,
            "deg of shaft",
            0.0,
            "estimate, no measurement found: where a unit's shaft is at the neutral pulse "
            "once its horn is on (potentiometer centring and horn mounting); ±1–2° is the "
            "figure commonly quoted for this class; 2° is the upper end",
        ),
        UnitRange(
            "us_per_deg",
            8.1,
            11.5,
            "µs per deg of shaft",
            US_PER_SERVO_DEG,
            "measured: MeArm Pi's software calibrates each servo at 8.1–10.9 µs/° "
            "(mimeindustries/MeArmPi, MeArmPi.js); one SG90 measured 11.5 µs/° "
            "(forum.arduino.cc topic 930978), another 9.6 µs/° and ≈15° short mid-range on "
            "the library defaults (leap.tardate.com, LEAP #042); nominal 10 µs/°",
        ),
        UnitRange(
            "backlash_deg",
            0.5,
            2.0,
            "deg of shaft",
            0.5,
            "measured: an SG90 needs about 3° of command after a reversal before the shaft "
            "moves back (forum.arduino.cc topic 930978), of which its 10 µs (1°) dead band "
            "leaves ≈2° of play; a bus servo (STS3215, SO-100 arm) measured ≈1° against a "
            "≤0.5° spec (github.com/TheRobotStudio/SO-ARM100 issue 134); 0.5° is the "
            "twin's nominal",
        ),
        UnitRange(
            "deadband_us",
            0.0,
            10.0,
            "µs",
            None,
            "datasheets: SG90 10 µs, MG90S and MG996R 5 µs (TowerPro); a unit's effective "
            "smallest step measured ≈5 µs, ≈426 positions over ≈190° (forum.arduino.cc "
            "topic 107001): drawn from the model's datasheet value up to 10 µs",
        ),
    )
}


@dataclass(frozen=True)
class ServoUnit:
    """One real servo of a kit.

    Attributes:
        zero_offset_deg: Its shaft's angle at :data:`NEUTRAL_US` [deg].
        us_per_deg: Its pulse change per shaft degree [µs/deg].
        backlash_deg: Its gear play at the shaft [deg].
        deadband_us: Its dead band [µs].
    """

    zero_offset_deg: float
    us_per_deg: float
    backlash_deg: float
    deadband_us: float

    def nominal_pulse(self, pulse_us: float) -> float:
        """The pulse that turns the nominal servo where this unit turns for ``pulse_us`` [µs]."""
        shaft_deg = (pulse_us - NEUTRAL_US) / self.us_per_deg + self.zero_offset_deg
        return NEUTRAL_US + shaft_deg * US_PER_SERVO_DEG


def kit_seed(seed: int, trial_seed: int | None) -> int:
    """The seed of a kit: ``seed``, or with ``trial_seed`` one distinct per (seed, trial)."""
    if trial_seed is None:
        return seed
    return int(np.random.SeedSequence([seed, trial_seed]).generate_state(1)[0])


def draw_kit(
    datasheet_deadband_us: list[float] | tuple[float, ...], seed: int, spread: float = 1.0
) -> tuple[ServoUnit, ...]:
    """A kit: one :class:`ServoUnit` per servo, drawn from :data:`KIT_RANGES`.

    Args:
        datasheet_deadband_us: Each servo's datasheet dead band [µs], in the twin's servo
            order (joints, then the gripper); the unit's is drawn from it up to the range's
            top (no lower than it).
        seed: The draw's seed.
        spread: Factor on the zero offset and on the scale's deviation from nominal.

    Raises:
        ValueError: a spread that is negative, not finite, or so large that a unit's scale
            could reach zero.
    """
    if not (np.isfinite(spread) and 0 <= spread <= MAX_SPREAD):
        raise ValueError(f"a kit's spread must be a number in [0, {MAX_SPREAD:g}], got {spread!r}")
    rng = np.random.default_rng(seed)
    off, scale = KIT_RANGES["zero_offset_deg"], KIT_RANGES["us_per_deg"]
    play, band = KIT_RANGES["backlash_deg"], KIT_RANGES["deadband_us"]
    assert scale.nominal is not None
    units = []
    for datasheet in datasheet_deadband_us:
        u = rng.uniform(size=4)  # four draws per servo, in this order, whatever the ranges
        k = scale.low + u[1] * (scale.high - scale.low)
        top = max(band.high, datasheet)
        units.append(
            ServoUnit(
                zero_offset_deg=float(spread * (off.low + u[0] * (off.high - off.low))),
                us_per_deg=float(scale.nominal + spread * (k - scale.nominal)),
                backlash_deg=float(play.low + u[2] * (play.high - play.low)),
                deadband_us=float(datasheet + u[3] * (top - datasheet)),
            )
        )
    return tuple(units)


def unit_calibration(
    unit: ServoUnit, zero_us: float, direction: int, us_per_unit: float
) -> tuple[float, int, float]:
    r"""The calibration that is exact for ``unit``, given the nominal servo's.

    The nominal calibration :math:`p_n = z + s\,k\,v` holds for the nominal servo; the
    unit turns for a pulse p where the nominal one turns for
    :math:`p_n = a p + b` (:meth:`ServoUnit.nominal_pulse`, :math:`a = 10/k_u`), so the
    unit's own is :math:`p = (z - b)/a + s\,(k/a)\,v`.

    Returns:
        ``(zero_us, direction, us_per_unit)`` of the unit.
    """
    b = unit.nominal_pulse(0.0)
    a = unit.nominal_pulse(1.0) - b
    return ((zero_us - b) / a, direction, us_per_unit / a)
