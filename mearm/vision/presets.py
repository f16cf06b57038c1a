"""Colour thresholds: the ``paper`` preset as printed and the ``default`` preset (SPEC §4).

A pixel is colour *c* when its saturation and value are at least the floors and its hue
lies in one of *c*'s bands. Hue is in degrees [0, 360) as the paper states it
(MATLAB ``rgb2hsv`` × 360), S and V in [0, 1]; a band with ``lo > hi`` wraps through 0.

The printed bands cannot be right for real objects in standard HSV (green sits near
120°, blue near 240°, and H ≥ 280° is magenta), so the ``default`` preset has bands of
its own, chosen with a margin to what it must ignore:

======== ============= ===========================================================
colour   hue [deg]     nearest hue it must ignore
======== ============= ===========================================================
red      330 … 15      orange ≈ 25–35, wood ≈ 20–40, purple/magenta ≈ 280–310
green    75 … 165      yellow ≈ 50–60, cyan ≈ 180
blue     190 … 255     cyan ≈ 180, purple ≈ 270–290
======== ============= ===========================================================

S ≥ 0.4 rejects white paper, a grey table and specular highlights (all S < 0.15);
V ≥ 0.25 rejects deep shadows and dark noise where the hue is meaningless.
"""

from __future__ import annotations

from dataclasses import dataclass

from mearm.config import COLORS, Color, HueBand, VisionConfig


@dataclass(frozen=True)
class Thresholds:
    """Resolved thresholds of a preset plus the overrides of a :class:`VisionConfig`.

    Attributes:
        bands_deg: Per colour, its hue intervals ``(lo, hi)`` [deg]; ``lo > hi`` wraps.
        saturation_min: Floor on S [-], in [0, 1].
        value_min: Floor on V [-], in [0, 1].
    """

    bands_deg: dict[Color, tuple[tuple[float, float], ...]]
    saturation_min: float
    value_min: float


#: SPEC §4 as printed: red H ≤ 20 or H ≥ 280, blue 90 … 120, green 130 … 160; S, V ≥ 0.1.
PAPER = Thresholds(
    bands_deg={"red": ((280.0, 20.0),), "green": ((130.0, 160.0),), "blue": ((90.0, 120.0),)},
    saturation_min=0.1,
    value_min=0.1,
)

#: Real red, green and blue objects; see the module docstring for the margins.
DEFAULT = Thresholds(
    bands_deg={"red": ((330.0, 15.0),), "green": ((75.0, 165.0),), "blue": ((190.0, 255.0),)},
    saturation_min=0.4,
    value_min=0.25,
)

PRESETS: dict[str, Thresholds] = {"paper": PAPER, "default": DEFAULT}


def _band(b: HueBand) -> tuple[float, float]:
    return (float(b.lo_deg), float(b.hi_deg))


def resolve_thresholds(vision: VisionConfig) -> Thresholds:
    """The preset named by ``vision.preset`` with the fields ``vision`` sets overriding it.

    ``vision.bands`` overrides colour by colour: a colour it does not name keeps the
    preset's bands.
    """
    base = PRESETS[vision.preset]
    bands = dict(base.bands_deg)
    for color, given in (vision.bands or {}).items():
        bands[color] = tuple(_band(b) for b in given)
    return Thresholds(
        bands_deg={c: bands[c] for c in COLORS},
        saturation_min=base.saturation_min
        if vision.saturation_min is None
        else float(vision.saturation_min),
        value_min=base.value_min if vision.value_min is None else float(vision.value_min),
    )


def in_band(hue_deg: float, band: tuple[float, float]) -> bool:
    """Whether ``hue_deg`` lies in the closed band ``(lo, hi)`` (wrapping when lo > hi)."""
    lo, hi = band
    if lo <= hi:
        return lo <= hue_deg <= hi
    return hue_deg >= lo or hue_deg <= hi
