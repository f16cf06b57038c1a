"""The fit to the file: midway between the two arrivals, as the servo file's entries."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from mearm.config import Config
from mearm.config.arm import ArmDescription
from mearm.config.servo_file import (
    ActuatorFit,
    CalibrationPoint,
    fitted_servo,
    recorded_fit,
    servo_of,
)
from mearm.hardware import ActuatorMap
from mearm.task.claw_fit import ClawCamera, ServoFit, Sighting


@dataclass(frozen=True)
class CameraFit:
    """The calibration: the arrivals from above and from below, and midway between.

    Attributes:
        servos: Each joint servo's map, midway between the two arrivals' zeros.
        above: The fit of the arrivals from above (zeros and scales).
        below: The fit of the arrivals from below (zeros, the same scales), or ``None``
            when the marker was not seen from below.
        play_us: Each servo's zero from below less its zero from above [µs].
    """

    servos: tuple[ActuatorMap, ...]
    above: ServoFit
    below: ServoFit | None
    play_us: dict[str, float]


def midway(claw: ClawCamera, above: ServoFit, below: ServoFit | None) -> CameraFit:
    """The calibration midway between the arrivals from above and from below.

    Their scales are the same (``below`` fitted only its zeros): the zeros are averaged.
    """
    if below is None:
        return CameraFit(above.servos, above, None, {})
    za, zb = claw.params_of(above.servos)[0::2], claw.params_of(below.servos)[0::2]
    params = claw.params_of(above.servos)
    params[0::2] = (za + zb) / 2.0
    play = {n: float(b - a) for n, a, b in zip(claw.names, za, zb, strict=True)}
    return CameraFit(claw.servo_maps(params), above, below, play)


def actuator_fits(
    config: Config,
    servos: Sequence[ActuatorMap],
    replaces_arm: ArmDescription,
    points: dict[str, tuple[CalibrationPoint, ...]] | None = None,
    play_us: Mapping[str, float] | None = None,
) -> list[ActuatorFit]:
    """Joint servo maps as the servo file's entries, their limits narrowed where needed.

    Each joint's limits are narrowed to what its servo reaches of the arm's own
    (:func:`~mearm.config.servo_file.recorded_fit`).

    Args:
        config: The whole config (each servo's present calibration: its channel, pulse
            range, speed and combination are kept).
        servos: The fitted maps.
        replaces_arm: The arm's own description, before any servo calibration file:
            each entry records its calibration as replaced and is narrowed against its
            limits.
        points: Each servo's points (the value the camera saw it at, its pulse).
        play_us: Each servo's measured play, the pulse rising less falling [µs]
            (:meth:`CameraSession.rising_play_us`); none where not given.

    Raises:
        ServoCalibrationError: a fitted value the servo's calibration refuses, or limits
            it would narrow too far.
    """
    out = []
    for amap in servos:
        template = servo_of(config.arm, amap.name)
        slope = amap.direction * amap.us_per_unit
        play = (play_us or {}).get(amap.name, 0.0)
        servo = fitted_servo(template, amap.name, amap.zero_us, slope, play_us=play)
        seen = (points or {}).get(amap.name, ())
        residual = max((abs(servo.pulse_us(p.value) - p.pulse_us) for p in seen), default=0.0)
        fit = ActuatorFit(amap.name, amap.unit, servo, tuple(seen), residual)
        out.append(recorded_fit(config, fit, replaces_arm))
    return out


def seen_values(claw: ClawCamera, sighting: Sighting, params: np.ndarray) -> np.ndarray:
    """Each joint servo's value the camera saw at one sighting [unit], chain order.

    The values whose marker best explains that sighting's corners alone, from the
    fit's; how far they lie from the fitted lines is the file's ``residual_us``.
    """
    names = claw.names
    as_values = np.tile([0.0, 1.0], len(names))  # zero 0, 1 µs per unit: pulses are values
    p = np.array([sighting.pulses_us[n] for n in names])
    start = (p - params[0::2]) / params[1::2]

    def residual(v: np.ndarray) -> np.ndarray:
        q = claw.joints(dict(zip(names, v, strict=True)), as_values)
        return (claw.pixels(q) - sighting.corners_px).ravel()

    from scipy.optimize import least_squares  # lazy: scipy costs 0.7 s to import

    return least_squares(residual, start, method="lm").x


def seen_points(
    claw: ClawCamera, sightings: Sequence[Sighting], servos: Sequence[ActuatorMap]
) -> dict[str, tuple[CalibrationPoint, ...]]:
    """Each servo's points: per sighting, the value the camera saw and the pulse held."""
    params = claw.params_of(servos)
    values = np.array([seen_values(claw, s, params) for s in sightings])
    return {
        name: tuple(
            CalibrationPoint(round(float(values[i, k]), 3), int(round(s.pulses_us[name])))
            for i, s in enumerate(sightings)
        )
        for k, name in enumerate(claw.names)
    }
