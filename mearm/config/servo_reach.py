r"""What a fitted servo must reach: the values it spans, the checks, and the limits it narrows.

A fit (:class:`~mearm.config.servo_file.ActuatorFit`) maps the servo's value v to a pulse,
:math:`p = p_0 + s\,k\,v`, and the servo takes pulses in ``[min_us, max_us]`` only. Its
span (:func:`fit_span`) is what that map must put inside the range: the joint's limits
or, for a servo that turns a combination of joints (the MeArm's elbow servo: shoulder +
elbow), the combination over the joint's limits with the other joints at home.

Where a fitted servo cannot reach a joint's whole limits inside its pulse range — a
unit a little steeper than the arm file's, on a joint whose nominal map fills the range
(the 5-DOF arm's base and wrist) — :func:`narrowed` narrows the joint's limits to what it
reaches (always safer: no joint command is then outside what the servo can do), and the
file keeps them (``limits`` in its entry). A fit far from the datasheet is refused
(:func:`check_fit`): its µs per unit more than :data:`MAX_SLOPE_DEVIATION` off the
arm's, or its limits narrowed by more than :data:`MAX_NARROWING` of their span.
"""

from __future__ import annotations

import math
from typing import Protocol, Self, TypeVar

from mearm.config.arm import (
    US_PER_SERVO_DEG,
    ArmDescription,
    JointServo,
    ServoCalibration,
    ServoDrives,
)
from mearm.config.errors import ServoCalibrationError
from mearm.config.servo_calibration import NEUTRAL_US


class _Fit(Protocol):
    """What the checks read of a fit (:class:`~mearm.config.servo_file.ActuatorFit`)."""

    @property
    def name(self) -> str: ...
    @property
    def unit(self) -> str: ...
    @property
    def servo(self) -> ServoCalibration: ...
    @property
    def limits(self) -> tuple[float, float] | None: ...
    def with_limits(self, limits: tuple[float, float] | None) -> Self: ...


F = TypeVar("F", bound=_Fit)

#: Largest share a fit's µs/unit may differ from the arm's: real units span −19…+15 % (servo_kit).
MAX_SLOPE_DEVIATION = 0.30
#: Largest share of a joint's span a fit may leave unreached. A unit at the datasheets'
#: extremes (+15 % µs per degree, its zero 2° off) leaves about 15 % of a span its nominal
#: map fills; more is a misread reference or another servo.
MAX_NARROWING = 0.25
#: Largest distance a fit's zero may lie from the arm's, at the neutral pulse [deg of
#: shaft]: a unit's potentiometer centring (2°, servo_kit) and a horn put on the nearest
#: of an SG90's 20 spline teeth (half a tooth, 9°); more is a misread reference.
MAX_ZERO_OFF_DEG = 12.0
#: Narrowed limits are rounded inwards to this many decimals [deg or cm].
LIMIT_DECIMALS = 2


def turns(servo: ServoCalibration, name: str) -> ServoDrives:
    """What a servo turns, as written: its ``drives``, or ``name`` alone."""
    if isinstance(servo, JointServo):
        return servo.combination(name)
    return ServoDrives(terms={name: 1.0})


def fit_span(
    arm: ArmDescription, name: str, limits: tuple[float, float] | None = None
) -> tuple[str, float, float]:
    """What an actuator's calibration must put inside its pulse range: (what, lo, hi).

    Its limits (the gripper's: closed to open); for a joint servo that turns a
    combination, the values the combination takes as the joint sweeps its limits with the
    other joints at home — where the config checks such a servo (its pulse range
    depends on the pose).

    Args:
        arm: The arm.
        name: The actuator.
        limits: The joint's limits to take instead of the arm's (a fit's narrowed ones).
    """
    home = arm.home()
    for j in arm.actuated_joints():
        if j.name != name or j.servo is None or j.limits is None:
            continue
        lo, hi = (j.limits.min, j.limits.max) if limits is None else limits
        combo = turns(j.servo, name)
        if combo == ServoDrives(terms={name: 1.0}):
            return (f"{name}'s limits", lo, hi)
        c = combo.terms.get(name, 0.0)
        rest = combo.offset + sum(k * home[n] for n, k in combo.terms.items() if n != name)
        a, b = rest + c * lo, rest + c * hi
        what = f"{name}'s servo ({combo.text()}) over {name}'s limits, the other joints at home"
        return (what, min(a, b), max(a, b))
    for t in arm.tool.actuators:
        if t.name == name:
            return (f"{name}'s limits", t.limits.min, t.limits.max)
    g = arm.tool.gripper
    return (f"{g.name}'s opening, closed to open", g.closed_cm, g.open_cm)


def reach(arm: ArmDescription, fit: _Fit) -> tuple[float, float] | None:
    """The joint's limits the fitted servo reaches inside its pulse range, or ``None``.

    ``None``: it reaches all of them, or the actuator is no joint (a tool's actuator or
    the gripper is never narrowed). A servo that turns a combination is taken with the
    other joints at home, as :func:`fit_span` takes it. The ends are rounded inwards to
    :data:`LIMIT_DECIMALS`; an empty reach is ``(nan, nan)``.
    """
    joint = next((j for j in arm.actuated_joints() if j.name == fit.name), None)
    if joint is None or joint.servo is None or joint.limits is None:
        return None
    combo = turns(fit.servo, fit.name)
    c = combo.terms.get(fit.name, 0.0)
    if c == 0:
        return None
    home = arm.home()
    rest = combo.offset + sum(k * home[n] for n, k in combo.terms.items() if n != fit.name)
    v_lo, v_hi = fit.servo.value_range()
    a, b = sorted(((v_lo - rest) / c, (v_hi - rest) / c))
    lo, hi = max(a, joint.limits.min), min(b, joint.limits.max)
    if lo <= joint.limits.min and hi >= joint.limits.max:
        return None
    step = 10.0**-LIMIT_DECIMALS
    lo = math.ceil(lo / step - 1e-9) * step if lo > joint.limits.min else joint.limits.min
    hi = math.floor(hi / step + 1e-9) * step if hi < joint.limits.max else joint.limits.max
    if not lo < hi:
        return (math.nan, math.nan)
    return (round(lo, LIMIT_DECIMALS), round(hi, LIMIT_DECIMALS))


def narrowed(arm: ArmDescription, fit: F) -> F:
    """``fit`` with its joint's limits narrowed to what the servo reaches (:func:`reach`).

    Raises:
        ServoCalibrationError: it reaches less than ``1 -`` :data:`MAX_NARROWING` of the
            joint's span, or not the joint's home.
    """
    got = reach(arm, fit)
    if got is None:
        return fit.with_limits(None)
    joint = next(j for j in arm.actuated_joints() if j.name == fit.name)
    assert joint.limits is not None and joint.home is not None  # an actuated joint
    lo, hi = joint.limits.min, joint.limits.max
    what, s = f"{fit.name}'s limits [{lo:g}, {hi:g}] {fit.unit}", fit.servo
    inside = f"inside the servo's [{s.min_us}, {s.max_us}] µs"
    if math.isnan(got[0]) or (got[1] - got[0]) < (1.0 - MAX_NARROWING) * (hi - lo):
        reached = "none" if math.isnan(got[0]) else f"only [{got[0]:g}, {got[1]:g}]"
        raise ServoCalibrationError(
            f"{fit.name}: the fit reaches {reached} of {what} {inside}; a servo within its "
            f"datasheet leaves at most {MAX_NARROWING:.0%} of them: redo the references, or "
            "check the channel and the arm's zero_us and us_per_unit"
        )
    if not got[0] <= joint.home <= got[1]:
        raise ServoCalibrationError(
            f"{fit.name}: the fit reaches [{got[0]:g}, {got[1]:g}] of {what} {inside}, "
            f"without its home {joint.home:g}: redo the references, or move the servo's horn"
        )
    return fit.with_limits(got)


def narrowing_text(arm: ArmDescription, fit: _Fit) -> str | None:
    """A fit's narrowed limits in words, or ``None`` when it keeps the arm's."""
    if fit.limits is None:
        return None
    joint = next(j for j in arm.actuated_joints() if j.name == fit.name)
    assert joint.limits is not None  # narrowed() narrows actuated joints only
    s = fit.servo
    return (
        f"{fit.name}: limits narrowed from [{joint.limits.min:g}, {joint.limits.max:g}] to "
        f"[{fit.limits[0]:g}, {fit.limits[1]:g}] {fit.unit}: its servo, as fitted, reaches "
        f"no farther inside [{s.min_us}, {s.max_us}] µs"
    )


def zero_off_deg(fit: _Fit, nominal: ServoCalibration) -> float:
    r"""How far the fit's shaft is from the nominal's at the neutral pulse [deg of shaft].

    .. math:: \Delta = (p_n(v_f(1500)) - 1500) / k_s

    with :math:`v_f` the fit's value at the pulse, :math:`p_n` the nominal's pulse for it
    and :math:`k_s` = :data:`~mearm.config.arm.US_PER_SERVO_DEG`: a servo's scale error
    pivots at the neutral pulse, so there only its zero tells.
    """
    s = fit.servo
    value = (NEUTRAL_US - s.zero_us) / (s.direction * s.us_per_unit)
    return (nominal.pulse_us(value) - NEUTRAL_US) / US_PER_SERVO_DEG


def check_fit(
    arm: ArmDescription, fit: _Fit, nominal: ServoCalibration, *, zero: bool = True
) -> None:
    """Refuse a fit far from the arm's nominal servo, or that cannot reach its limits.

    Args:
        arm: The arm (its limits, home and combinations).
        fit: The fit of one of its actuators; its limits are its own where
            :func:`narrowed` narrowed them.
        nominal: The actuator's calibration in the arm's own file (before any servo
            calibration file), which the fit's µs per unit and zero are compared with.
        zero: Whether to check the zero (a fit of the zeros alone, its scale the
            nominal's, moves its zero to where the pulses were: not checked).

    Raises:
        ServoCalibrationError: µs per unit more than :data:`MAX_SLOPE_DEVIATION` off the
            nominal, its zero more than :data:`MAX_ZERO_OFF_DEG` (:func:`zero_off_deg`),
            or :func:`fit_span` putting a pulse outside ``[min_us, max_us]``; the message
            says which, by how much, and what to do.
    """
    s, unit = fit.servo, fit.unit
    off = s.us_per_unit / nominal.us_per_unit - 1.0
    if abs(off) > MAX_SLOPE_DEVIATION:
        raise ServoCalibrationError(
            f"{fit.name}: the fit gives {s.us_per_unit:.3f} µs/{unit}, {off:+.0%} off the "
            f"arm's {nominal.us_per_unit:.3f} µs/{unit} (real servos differ by at most "
            f"±{MAX_SLOPE_DEVIATION:.0%}): a reference was misread or not reached; redo "
            "the references, or check the channel and the arm's us_per_unit"
        )
    shaft = zero_off_deg(fit, nominal)
    if zero and abs(shaft) > MAX_ZERO_OFF_DEG:
        raise ServoCalibrationError(
            f"{fit.name}: the fit puts the shaft {shaft:+.1f}° off the arm's at the "
            f"neutral {NEUTRAL_US:.0f} µs (a unit's centring and a horn on its nearest "
            f"tooth: at most {MAX_ZERO_OFF_DEG:g}°): a reference was misread, or the horn "
            "sits a tooth off; redo the references, or remount the horn centred"
        )
    what, lo, hi = fit_span(arm, fit.name, fit.limits)
    p_lo, p_hi = s.pulse_us(lo), s.pulse_us(hi)
    if not all(s.min_us - 1e-6 <= p <= s.max_us + 1e-6 for p in (p_lo, p_hi)):
        raise ServoCalibrationError(
            f"{fit.name}: the fit puts {what}, [{lo:.4g}, {hi:.4g}] {unit}, at "
            f"[{p_lo:.0f}, {p_hi:.0f}] µs, outside the servo's [{s.min_us}, {s.max_us}] µs: "
            "redo the references; if the fit is right, the servo cannot turn that far: "
            "narrow the limits, or widen min_us/max_us as far as its datasheet allows"
        )
