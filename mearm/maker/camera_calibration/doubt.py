"""How far each joint servo may be from where its pulse is meant to put it."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mearm.hardware import ActuatorMap, ServoMap
from mearm.maker.camera_calibration.settings import (
    FIT_SCALE,
    FIT_ZERO_US,
    PLAY_US,
    SCALE_PRIOR,
    ZERO_PRIOR_US,
)
from mearm.task.claw_fit import ServoFit, Sighting


@dataclass
class ServoDoubt:
    r"""How far each joint servo may turn from where its pulse is meant to put it.

    Before any fit: the gears' play, a unit's zero, and its scale's error about the
    middle of its pulse range. After a fit of the zeros: the play, the fitted zero and
    the scale's error about the mean pulse sighted (the zero absorbed it there). After a
    fit of the scales too: the play and the fitted zero within the pulses sighted, and
    beyond them the fitted scale's error, which the play at the two ends of the pulses
    sighted bounds (:math:`2 \cdot` :data:`PLAY_US` over their spread), or the prior
    where that is less.

    The play is :data:`PLAY_US` until it is measured (:attr:`play_us`): the fit is made
    of arrivals from one side, and a move may end on the other, by the play.

    Attributes:
        scales: Whether the scales are fitted (``None``: nothing is).
        sighted: Each servo's pulses at the sightings the fit used [µs].
        scale_doubt: Each fitted scale's possible error, a share of it [-].
        play_us: Each servo's play as measured: how far its zero from below lies from
            its zero from above [µs].
    """

    scales: bool | None = None
    sighted: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    scale_doubt: dict[str, float] = dataclasses.field(default_factory=dict)
    play_us: dict[str, float] = dataclasses.field(default_factory=dict)

    def learn(self, fit: ServoFit, sightings: Sequence[Sighting], nominal: ServoMap) -> None:
        """Take the doubt a fit leaves (the fit is now the one the bus sends).

        Args:
            fit: The fit.
            sightings: The sightings it fitted.
            nominal: The calibration the prior's scale error is about.
        """
        self.scales = fit.scales
        self.sighted = {
            j.name: np.array([s.pulses_us[j.name] for s in sightings]) for j in fit.servos
        }
        for j in fit.servos:
            off = abs(j.us_per_unit / nominal[j.name].us_per_unit - 1.0)
            spread = float(np.ptp(self.sighted[j.name]))
            bound = 2.0 * PLAY_US / spread if spread > 0 else math.inf
            self.scale_doubt[j.name] = max(FIT_SCALE, min(bound, SCALE_PRIOR + off))

    def pulse_us(self, amap: ActuatorMap, pulse: float) -> float:
        """How far servo ``amap`` may be from where ``pulse`` is meant to put it [µs]."""
        if self.scales is None:
            middle = (amap.min_us + amap.max_us) / 2.0
            return PLAY_US + ZERO_PRIOR_US + SCALE_PRIOR * abs(pulse - middle)
        seen, play = self.sighted[amap.name], self.play_us.get(amap.name, PLAY_US)
        if not self.scales:
            return play + FIT_ZERO_US + SCALE_PRIOR * abs(pulse - float(seen.mean()))
        beyond = max(float(seen.min()) - pulse, pulse - float(seen.max()), 0.0)
        return play + FIT_ZERO_US + self.scale_doubt[amap.name] * beyond

    def servos(self, smap: ServoMap, named: dict[str, float]) -> np.ndarray:
        """Each joint servo's doubt at the joints ``named`` [deg or cm], chain order."""
        values = smap.servo_values(named)
        return np.array(
            [self.pulse_us(j, j.pulse_us(values[j.name])) / j.us_per_unit for j in smap.joints]
        )

    def joints(self, smap: ServoMap, named: dict[str, float]) -> np.ndarray:
        """Each actuated joint's doubt at the joints ``named`` [deg or cm], chain order.

        A servo that turns a combination of joints moves each joint of it by its share
        (:math:`|A^{-1}|` times the servos' doubts).
        """
        doubt = self.servos(smap, named)
        combo = smap.combination
        return doubt if combo is None else np.abs(np.linalg.inv(combo[0])) @ doubt
