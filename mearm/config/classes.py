"""Object classes as data: what to look for, how to draw it, where it goes.

Any number of named classes; each is a colour (its hue band(s); a band with ``lo > hi``
wraps through 0°, as red does), a shape of the catalogue (:mod:`mearm.config.shape_catalogue`),
or both: "red", "cube", "red cube". Each has the colour its objects are drawn in
(simulated camera, 3-D view, plots), its bin, and the size of its objects. The sort
takes the classes in the order listed; a region the camera sees goes to the first class
whose colour and shape it has.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Annotated

from pydantic import Field, field_validator, model_validator

from mearm.config.base import Name, NonNegativeLength, Strict, Vector3
from mearm.config.shape_catalogue import DEFAULT_SHAPE, SHAPE_NAMES, ShapeSpec, shape_named

#: Object sizes [cm]: from a 1 mm bead to a 1 m box.
OBJECT_SIZE_CM = (0.1, 100.0)
#: A bin's default inner width, in object diameters.
BIN_DIAMETERS = 3.0
#: Most hue bands per class.
MAX_HUE_BANDS = 8

ObjectSize = Annotated[
    float, Field(ge=OBJECT_SIZE_CM[0], le=OBJECT_SIZE_CM[1], allow_inf_nan=False)
]

Rgb = tuple[
    Annotated[int, Field(ge=0, le=255)],
    Annotated[int, Field(ge=0, le=255)],
    Annotated[int, Field(ge=0, le=255)],
]


class HueBand(Strict):
    """A hue interval in degrees [0, 360]; ``lo > hi`` wraps through 0."""

    lo_deg: Annotated[float, Field(ge=0, le=360, allow_inf_nan=False)]
    hi_deg: Annotated[float, Field(ge=0, le=360, allow_inf_nan=False)]


def _arcs(band: HueBand) -> list[tuple[float, float]]:
    """The band as arcs of [0, 360] that do not wrap."""
    lo, hi = band.lo_deg, band.hi_deg
    return [(lo, hi)] if lo <= hi else [(lo, 360.0), (0.0, hi)]


def hues_shared(a: Sequence[HueBand], b: Sequence[HueBand]) -> tuple[float, float] | None:
    """An arc of hue [deg] both band lists hold (more than a point), or ``None``."""
    for x in a:
        for y in b:
            for x0, x1 in _arcs(x):
                for y0, y1 in _arcs(y):
                    if max(x0, y0) < min(x1, y1):
                        return max(x0, y0), min(x1, y1)
    return None


Lightness = Annotated[float, Field(ge=0, le=100, allow_inf_nan=False)]
Opponent = Annotated[float, Field(ge=-128, le=128, allow_inf_nan=False)]


class LearnedColour(Strict):
    """A colour taught from pixels of a camera's frames: an ellipse in CIELAB's a*b* plane.

    A pixel (L*, a*, b*) of the white-balanced frame (:mod:`mearm.vision.learned`) is of
    this colour when its chroma c = (a*, b*) lies within ``max_distance`` of the ellipse's
    centre μ in Mahalanobis distance, (c − μ)ᵀ Σ⁻¹ (c − μ) ≤ ``max_distance``², its
    lightness lies in ``lightness`` and its chroma √(a*² + b*²) reaches
    ``chroma_min`` (shadows and glare on a white table are faintly coloured, never as
    much as an object); with ``chroma_lightness`` L₀ the floor is ``chroma_min`` ·
    (L* + 16) / (L₀ + 16), the chroma at equal lightness (a*, b* and L* + 16 scale
    together with the light), and c is taken to L₀ before its distance is measured,
    c · (L₀ + 16) / (L* + 16) (not when L* > L₀ and a channel of the pixel is clipped,
    ≥ 252). A chroma c more coloured than μ is measured at μ's chroma, along its own hue
    (c · |μ| / |c|; when |μ| ≥ 12, a colour with a hue): the ellipse is open outwards.
    Written by ``mearm learn-colours``.

    Attributes:
        ab_mean: The ellipse's centre (a*, b*) [-], CIELAB, D65.
        ab_cov: Its covariance (σ_aa, σ_ab, σ_bb) [-²].
        lightness: The lightness L* it accepts, (lo, hi) [0–100].
        max_distance: The Mahalanobis radius of the ellipse [-].
        chroma_min: The least chroma it accepts [-] (at ``chroma_lightness``, if given).
        chroma_lightness: The lightness L* at which ``chroma_min`` holds and the
            ellipse's distances are measured [0–100]; ``None``: the same floor at every
            lightness, each pixel measured at its own.
    """

    ab_mean: tuple[Opponent, Opponent]
    ab_cov: tuple[
        Annotated[float, Field(gt=0, le=1e4, allow_inf_nan=False)],
        Annotated[float, Field(ge=-1e4, le=1e4, allow_inf_nan=False)],
        Annotated[float, Field(gt=0, le=1e4, allow_inf_nan=False)],
    ]
    lightness: tuple[Lightness, Lightness]
    max_distance: Annotated[float, Field(gt=0, le=20, allow_inf_nan=False)] = 3.0
    chroma_min: Annotated[float, Field(ge=0, le=200, allow_inf_nan=False)] = 0.0
    chroma_lightness: Lightness | None = None

    @model_validator(mode="after")
    def _proper(self) -> LearnedColour:
        saa, sab, sbb = self.ab_cov
        if saa * sbb - sab * sab <= 0:
            raise ValueError(
                f"@ab_cov: {list(self.ab_cov)} is not a covariance (positive definite)"
            )
        if self.lightness[0] >= self.lightness[1]:
            raise ValueError(f"@lightness: {list(self.lightness)}: lo must be below hi")
        return self


class ColorClass(Strict):
    """One class of objects to sort: a colour, a shape, or both.

    Attributes:
        name: The class's name (used in logs, scenes and the CLI).
        hue_bands_deg: Hue intervals a pixel of this class falls in; ``None``: any
            colour (every pixel that passes the saturation and value floors and no band
            of another class).
        shape: The shape of its objects, a name of the catalogue
            (:data:`~mearm.config.shape_catalogue.SHAPE_NAMES`); ``None``: any shape (the
            simulators make its objects cylinders, the paper's).
        draw_rgb: The colour its objects are drawn in (sim camera, view, plots), 0–255.
        bin_cm: Where the TCP goes to drop an object of this class, base frame [cm].
        diameter_cm: The objects' size [cm]: a cylinder's diameter, a cube's side, a
            prism's side.
        height_cm: The objects' height [cm].
        grip_height_cm: Height above the table at which the jaws close on one [cm]
            (default: half the height).
        bin_width_cm: Inner width of the class's square bin, centred under ``bin_cm``
            [cm] (default: three diameters). A camera that sees the bins counts what lies
            inside one as sorted, not as on the table.
        bin_height_cm: Height of the bin's walls [cm] (default: tall enough to hold the
            table's objects of the class stacked, and one more, at least 2 cm: the
            simulators build them so). The planner keeps the arm clear of walls this tall:
            give a real rig's bins their measured height.
        learned_colour: Its colour as taught from camera frames (``mearm learn-colours``);
            when set it stands for ``hue_bands_deg``.
    """

    name: Name
    hue_bands_deg: (
        Annotated[list[HueBand], Field(min_length=1, max_length=MAX_HUE_BANDS)] | None
    ) = None
    shape: str | None = None
    draw_rgb: Rgb
    bin_cm: Vector3
    diameter_cm: ObjectSize = 2.0
    height_cm: ObjectSize = 1.0
    grip_height_cm: NonNegativeLength | None = None
    bin_width_cm: ObjectSize | None = None
    bin_height_cm: ObjectSize | None = None
    learned_colour: LearnedColour | None = None

    @field_validator("shape")
    @classmethod
    def _in_catalogue(cls, name: str | None) -> str | None:
        if name is not None:
            shape_named(name)
        return name

    @model_validator(mode="after")
    def _colour_or_shape(self) -> ColorClass:
        if self.hue_bands_deg is None and self.shape is None and self.learned_colour is None:
            raise ValueError(
                f"class '{self.name}' has neither a colour nor a shape: give it "
                f"hue_bands_deg, a shape ({', '.join(SHAPE_NAMES)}), or both"
            )
        return self

    @property
    def object_shape(self) -> ShapeSpec:
        """The shape of this class's objects: its ``shape``, else a cylinder."""
        return shape_named(self.shape or DEFAULT_SHAPE)

    @property
    def footprint_radius_cm(self) -> float:
        """The radius of the smallest circle around one object's footprint [cm]."""
        return self.object_shape.enclosing_radius_cm(self.diameter_cm)

    @property
    def bin_inner_width_cm(self) -> float:
        """Inner width of the bin [cm]: ``bin_width_cm``, else :data:`BIN_DIAMETERS` diameters."""
        return BIN_DIAMETERS * self.diameter_cm if self.bin_width_cm is None else self.bin_width_cm

    def in_bin(self, x_cm: float, y_cm: float, beyond_cm: float = 0.0) -> bool:
        """Whether a table point lies inside the bin's inner square (plane).

        ``beyond_cm``: the square grown by this much on each side (its walls' thickness:
        within the walls).
        """
        half = self.bin_inner_width_cm / 2 + beyond_cm
        return abs(x_cm - self.bin_cm[0]) <= half and abs(y_cm - self.bin_cm[1]) <= half

    @property
    def grip_z_cm(self) -> float:
        """Height above the table at which the jaws close [cm]."""
        return self.height_cm / 2 if self.grip_height_cm is None else self.grip_height_cm


def class_named(classes: Iterable[ColorClass], name: str) -> ColorClass:
    """The class called ``name`` among ``classes``.

    Raises:
        KeyError: no such class.
    """
    for c in classes:
        if c.name == name:
            return c
    raise KeyError(name)
