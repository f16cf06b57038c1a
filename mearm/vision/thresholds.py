"""Colour thresholds: each class's hue bands and the saturation/value floors (paper §4).

A pixel is class *c* when its saturation and value are at least the floors and its hue
lies in one of *c*'s bands. Hue is in degrees [0, 360) as the paper states it
(MATLAB ``rgb2hsv`` × 360), S and V in [0, 1]; a band with ``lo > hi`` wraps through 0.
Classes are tried in the order listed, so a hue in the bands of two classes goes to
the first.

The bands come from the classes (``task.classes``), the floors from ``vision``. Classes
are grouped by colour: classes with the same bands (a red cube and a red cylinder) are
one colour, named after the first of them, and the classes without bands (a shape of
any colour) are one colour, tried last, whose band is every hue
(:func:`colour_groups`); the shape tells the classes of a colour apart
(:mod:`mearm.vision.shapes`). The
built-in classes (:func:`mearm.config.defaults.default_classes`) have bands chosen for
real objects, with a margin to what they must ignore (wood, paper, highlights, shadows);
:func:`mearm.config.defaults.paper_classes` has the bands as the paper printed them,
whose floors were S, V ≥ 0.1.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from mearm.config import ColorClass, VisionConfig
from mearm.config.classes import LearnedColour
from mearm.errors import ConfigError

#: Class codes are 1..MAX_CLASSES (0 is no class); the fast classifier keeps a flag in
#: the top bit of its 8-bit codes.
MAX_CLASSES = 127

Band = tuple[float, float]


@dataclass(frozen=True)
class Thresholds:
    """Hue bands per class (in class order) and the floors on saturation and value.

    Attributes:
        bands_deg: Per class name, its hue intervals ``(lo, hi)`` [deg]; ``lo > hi``
            wraps through 0. Its order is the class order: class *i* has code *i* + 1.
        saturation_min: Floor on S [-], in [0, 1].
        value_min: Floor on V [-], in [0, 1].
        learned: Per colour taught from camera frames (``learned_colour``), its model;
            such a colour has no hue bands (its entry in ``bands_deg`` is empty) and is
            classified by :class:`mearm.vision.learned.LearnedClassifier`.
    """

    bands_deg: dict[str, tuple[Band, ...]]
    saturation_min: float
    value_min: float
    learned: dict[str, LearnedColour] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.bands_deg:
            raise ConfigError(None, ["task.classes: no classes; give at least one"])
        if len(self.bands_deg) > MAX_CLASSES:
            raise ConfigError(
                None,
                [
                    f"task.classes: {len(self.bands_deg)} colours (classes with the same "
                    f"hue bands are one), the detector handles at most {MAX_CLASSES}"
                ],
            )

    @classmethod
    def from_config(cls, classes: Sequence[ColorClass], vision: VisionConfig) -> Thresholds:
        """The colours of ``classes`` (``task.classes``) and the floors of ``vision``.

        One entry per colour (:func:`colour_groups`), named after its first class.

        Raises:
            ConfigError: no classes, more than :data:`MAX_CLASSES`, or a name listed twice.
        """
        names: set[str] = set()
        for c in classes:
            if c.name in names:
                raise ConfigError(None, [f"task.classes: '{c.name}' is listed twice"])
            names.add(c.name)
        groups = colour_groups(classes)
        by_name = {c.name: c for c in classes}
        return cls(
            bands_deg={name: bands for name, (bands, _) in groups.items()},
            saturation_min=float(vision.saturation_min),
            value_min=float(vision.value_min),
            learned={
                name: model
                for name in groups
                if (model := by_name[name].learned_colour) is not None
            },
        )

    @property
    def class_names(self) -> tuple[str, ...]:
        """Class names in class order."""
        return tuple(self.bands_deg)

    @property
    def codes(self) -> dict[str, int]:
        """Class name → its code in a class map (*i* + 1 for class *i*; 0 is no class)."""
        return {name: i + 1 for i, name in enumerate(self.bands_deg)}


#: The band of a colour that is any hue [deg].
ANY_HUE: tuple[Band, ...] = ((0.0, 360.0),)


def class_bands(color_class: ColorClass) -> tuple[Band, ...] | None:
    """A class's hue bands ``(lo, hi)`` [deg], or ``None`` for a class of any colour.

    A class with a learned colour has none: ``()``.
    """
    if color_class.learned_colour is not None:
        return ()
    if color_class.hue_bands_deg is None:
        return None
    return tuple((float(b.lo_deg), float(b.hi_deg)) for b in color_class.hue_bands_deg)


def colour_groups(
    classes: Sequence[ColorClass],
) -> dict[str, tuple[tuple[Band, ...], tuple[str, ...]]]:
    """The colours of ``classes``: per colour's name, its bands and its classes' names.

    Classes with equal bands (or equal learned colours) are one colour, named after the
    first; the classes of any
    colour (no bands) are one more, last, with the band :data:`ANY_HUE` (it gets only the
    pixels no other colour takes). Without shapes and with distinct bands (the paper's
    classes) every class is its own colour, under its own name.
    """
    groups: dict[tuple[Band, ...] | LearnedColour, list[str]] = {}
    anyhue: list[str] = []
    for c in classes:
        bands = class_bands(c)
        if bands is None:
            anyhue.append(c.name)
        else:
            groups.setdefault(c.learned_colour or bands, []).append(c.name)
    out = {
        names[0]: (() if isinstance(key, LearnedColour) else key, tuple(names))
        for key, names in groups.items()
    }
    if anyhue:
        out[anyhue[0]] = (ANY_HUE, tuple(anyhue))
    return out


def in_band(hue_deg: float, band: Band) -> bool:
    """Whether ``hue_deg`` lies in the closed band ``(lo, hi)`` (wrapping when lo > hi)."""
    lo, hi = band
    if lo <= hi:
        return lo <= hue_deg <= hi
    return hue_deg >= lo or hue_deg <= hi
