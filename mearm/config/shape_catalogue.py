r"""Object shapes as data: what the simulators build and how the camera tells them apart.

A class (:class:`~mearm.config.classes.ColorClass`) may name a shape of this catalogue;
its objects then have that shape, and a region the camera sees is of the class only if
it has the shape too. Seen from straight above, an upright object shows its footprint:
a disc (cylinder), a square (cube) or an equilateral triangle (triangular prism). Every
shape's size is one number, ``diameter_cm`` of its class: the disc's diameter, the
square's side, the triangle's side.

The detector tells the footprints apart by their *fill* of the smallest circle around
them, :math:`f = A / (\pi r^2)`: 1 for a disc, :math:`2/\pi \approx 0.64` for a square,
:math:`3\sqrt{3}/(4\pi) \approx 0.41` for an equilateral triangle, at any size and any
turn. Circularity :math:`4\pi A/P^2` would not do: on pixels a small disc's outline is
long (0.81 at 6 px radius) and overlaps the squares' (0.67–0.785). Each shape owns one
band of the fill (:attr:`ShapeSpec.fill_band`); the bands meet between the ideal fills,
with room for the pixels' rounding and the median filter's cut corners
(:mod:`mearm.vision.shapes` measures it).

An upright cylinder and a ball both look like a disc from above: only one of them can be
told by the camera, and the catalogue has the cylinder (the paper's objects).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

Footprint = Literal["disc", "square", "triangle"]


@dataclass(frozen=True)
class ShapeSpec:
    """One shape of the catalogue.

    Attributes:
        name: What a class calls it (``shape: cube``).
        footprint: What the camera sees from above.
        fill_band: The fill of the smallest enclosing circle ``[lo, hi)`` a region of
            this shape has [-] (the module docstring).
        symmetry_deg: Its footprint looks the same turned by this [deg] (0: any turn).
        description: One line for the docs.
    """

    name: str
    footprint: Footprint
    fill_band: tuple[float, float]
    symmetry_deg: float
    description: str

    def area_cm2(self, size_cm: float) -> float:
        """The footprint's area [cm²] at ``size_cm`` (diameter or side)."""
        if self.footprint == "disc":
            return math.pi * size_cm**2 / 4
        if self.footprint == "square":
            return size_cm**2
        return math.sqrt(3) / 4 * size_cm**2

    def enclosing_radius_cm(self, size_cm: float) -> float:
        """The radius of the smallest circle around the footprint [cm]."""
        if self.footprint == "disc":
            return size_cm / 2
        if self.footprint == "square":
            return size_cm / math.sqrt(2)
        return size_cm / math.sqrt(3)

    def corners_cm(self, size_cm: float) -> list[tuple[float, float]] | None:
        """The footprint's corners around its centre at no turn [cm]; ``None`` for a disc.

        A square's (sides along x and y), a triangle's (its centroid at the centre, a
        corner along +y).
        """
        if self.footprint == "disc":
            return None
        if self.footprint == "square":
            h = size_cm / 2
            return [(-h, -h), (h, -h), (h, h), (-h, h)]
        r = size_cm / math.sqrt(3)
        return [
            (r * math.cos(math.radians(a)), r * math.sin(math.radians(a))) for a in (90, 210, 330)
        ]

    def widest_cm(self, size_cm: float) -> float:
        """The footprint's largest width in any direction [cm]: what open jaws must pass.

        A disc's diameter, a square's diagonal, a triangle's side.
        """
        if self.footprint == "square":
            return size_cm * math.sqrt(2)
        return size_cm


#: The fill between a triangle's and a square's. Measured on the simulated camera's
#: frames (`mearm shape-sweep --objects 2400`, sizes 1–3 cm, any yaw): prisms 0.431–0.526,
#: cubes 0.642–0.742 (the median filter rounds a small square's corners) [-].
TRIANGLE_SQUARE_FILL = 0.59
#: The fill between a square's (≤ 0.742 measured) and a disc's (≥ 0.876 measured) [-].
SQUARE_DISC_FILL = 0.80

SHAPES: dict[str, ShapeSpec] = {
    s.name: s
    for s in (
        ShapeSpec(
            "cylinder", "disc", (SQUARE_DISC_FILL, math.inf), 0.0,
            "an upright cylinder: a disc from above (the paper's objects)",
        ),
        ShapeSpec(
            "cube", "square", (TRIANGLE_SQUARE_FILL, SQUARE_DISC_FILL), 90.0,
            "a cube or an upright square box: a square from above",
        ),
        ShapeSpec(
            "prism", "triangle", (0.0, TRIANGLE_SQUARE_FILL), 120.0,
            "an upright triangular prism (equilateral): a triangle from above",
        ),
    )
}  # fmt: skip
#: The shapes' names, in catalogue order.
SHAPE_NAMES = tuple(SHAPES)
#: The shape of a class that names none (the paper's objects).
DEFAULT_SHAPE = "cylinder"


def shape_named(name: str) -> ShapeSpec:
    """The catalogue's shape ``name``.

    Raises:
        ValueError: no such shape; the message lists the catalogue.
    """
    try:
        return SHAPES[name]
    except KeyError:
        raise ValueError(
            f"no shape {name!r}; the catalogue has: {', '.join(SHAPE_NAMES)}"
        ) from None
