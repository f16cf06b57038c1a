r"""Shapes seen from above, and the class of a region by its colour and its shape.

:func:`measure_shape` reads one region's outline (its mask's outer contour): its fill of
the smallest circle around it, :math:`f = A_c / (\pi r^2)` with :math:`A_c` the area
inside the outline, names the shape whose band holds it
(:attr:`mearm.config.shape_catalogue.ShapeSpec.fill_band`), and for a square takes the yaw of its
sides from the smallest rectangle around the outline (``cv2.minAreaRect``).

:class:`ClassMatcher` turns (colour, shape) into a class: the first class, in the
configured order, whose colour is the region's (or which is of any colour) and whose
shape is the region's (or which is of any shape). A region whose shape cannot be told
(cut by the image border, merged with a neighbour) goes to the first class of its
colour, and its shape is ``None``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from mearm.config import ColorClass
from mearm.config.shape_catalogue import SHAPES
from mearm.vision.thresholds import class_bands, colour_groups


@dataclass(frozen=True)
class ShapeMeasure:
    """What one region's outline says.

    Attributes:
        fill: Its area over its smallest enclosing circle's [-].
        shape: The catalogue's shape whose band holds ``fill``.
        yaw_px_deg: A square's side's direction in the image, from the u axis towards
            +v, in [0, 90) [deg]; ``None`` for the other shapes.
    """

    fill: float
    shape: str
    yaw_px_deg: float | None = None


def outline(region: np.ndarray) -> np.ndarray:
    """The largest outer contour of a 0/1 (or 0/255) uint8 mask, (N, 1, 2) int32 [px]."""
    contours, _ = cv2.findContours(region, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    return max(contours, key=cv2.contourArea)


def shape_of_fill(fill: float) -> str:
    """The catalogue's shape whose fill band holds ``fill``."""
    for spec in SHAPES.values():
        lo, hi = spec.fill_band
        if lo <= fill < hi:
            return spec.name
    raise AssertionError(f"the catalogue's fill bands miss {fill}")  # they cover [0, inf)


def measure_shape(region: np.ndarray) -> ShapeMeasure:
    """The shape of a region, 0/1 uint8 mask of its box (see the module docstring)."""
    # findContours pads the image by one pixel itself; the offset gives the points of a
    # mask padded by one (the same points, so the same fill and yaw, without the copy)
    contours, _ = cv2.findContours(region, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE, offset=(1, 1))
    contour = contours[0] if len(contours) == 1 else max(contours, key=cv2.contourArea)
    return shape_of_outline(contour)


def shape_of_outline(contour: np.ndarray) -> ShapeMeasure:
    """The shape of a region by its outline, (M, 1, 2) int32 [px] (:func:`measure_shape`)."""
    _, radius = cv2.minEnclosingCircle(contour)
    fill = cv2.contourArea(contour) / (math.pi * radius * radius) if radius > 0 else 0.0
    shape = shape_of_fill(fill)
    yaw = None
    if SHAPES[shape].footprint == "square":
        _, _, angle = cv2.minAreaRect(contour)
        yaw = float(angle) % 90.0
    return ShapeMeasure(float(fill), shape, yaw)


def shapes_of_outlines(contours: Sequence[np.ndarray]) -> list[ShapeMeasure]:
    """:func:`shape_of_outline` of each outline, the fills and shapes taken at once.

    The same values, bit for bit (each fill is the same float operations), for fewer
    Python steps per region.
    """
    if not contours:
        return []
    radius = np.array([cv2.minEnclosingCircle(c)[1] for c in contours])
    area = np.array([cv2.contourArea(c) for c in contours])
    with np.errstate(divide="ignore", invalid="ignore"):
        fill = np.where(radius > 0, area / (math.pi * radius * radius), 0.0)
    names = np.full(len(fill), "", dtype=object)
    for spec in reversed(list(SHAPES.values())):  # the first band that holds it wins
        lo, hi = spec.fill_band
        names[(lo <= fill) & (fill < hi)] = spec.name
    out = []
    for c, f, name in zip(contours, fill.tolist(), names.tolist(), strict=True):
        if not name:
            raise AssertionError(f"the catalogue's fill bands miss {f}")
        yaw = None
        if SHAPES[name].footprint == "square":
            yaw = float(cv2.minAreaRect(c)[2]) % 90.0
        out.append(_shape_measure(f, name, yaw))
    return out


def _shape_measure(fill: float, shape: str, yaw_px_deg: float | None) -> ShapeMeasure:
    """A :class:`ShapeMeasure` of values already checked (without the generated ``__init__``)."""
    new = object.__new__(ShapeMeasure)
    new.__dict__.update(fill=fill, shape=shape, yaw_px_deg=yaw_px_deg)
    return new


def table_yaw_deg(
    pixel_to_table: object, centre_px: npt.ArrayLike, yaw_px_deg: float, symmetry_deg: float = 90.0
) -> float:
    """A direction seen in the image as the same direction on the table [deg].

    Maps the centre and a point one pixel along ``yaw_px_deg`` through the calibration
    (``pixel_to_table``, a callable on (N, 2) pixels), and gives the table direction
    modulo ``symmetry_deg`` (a square's 90°), in [0, ``symmetry_deg``).
    """
    c = np.asarray(centre_px, dtype=float).reshape(2)
    a = math.radians(yaw_px_deg)
    pts = np.array([c, c + (math.cos(a), math.sin(a))])
    xy = np.asarray(pixel_to_table(pts))  # type: ignore[operator]
    dx, dy = xy[1] - xy[0]
    return math.degrees(math.atan2(dy, dx)) % symmetry_deg


class ClassMatcher:
    """The class of a region by its colour and its shape (the module docstring).

    Args:
        classes: The classes (``task.classes``), in their order.
    """

    def __init__(self, classes: Sequence[ColorClass]):
        self.classes = tuple(classes)
        #: Per colour's name, its bands and its classes (:func:`colour_groups`).
        self.groups = colour_groups(self.classes)
        by_name = {c.name: c for c in self.classes}
        anyhue = tuple(c.name for c in self.classes if class_bands(c) is None)
        #: Per colour's name, the classes a region of it may be of, in order: its own,
        #: and those of any colour.
        self.candidates: dict[str, tuple[str, ...]] = {}
        for colour, (_, members) in self.groups.items():
            if class_bands(by_name[colour]) is None:
                self.candidates[colour] = anyhue
            else:
                own = set(members) | set(anyhue)
                self.candidates[colour] = tuple(c.name for c in self.classes if c.name in own)
        self._shape = {c.name: c.shape for c in self.classes}
        self._matched: dict[tuple[str, str | None], str | None] = {}  # asked once a frame each

    def match(self, colour: str, shape: str | None) -> str | None:
        """The class of a region of ``colour`` (a colour's name) and ``shape``.

        ``shape`` ``None`` (not told): the colour's first class. ``None`` when no class
        has both its colour and its shape (it is no object of the task).
        """
        key = (colour, shape)
        if key not in self._matched:
            names = self.candidates[colour]
            self._matched[key] = (
                names[0]
                if shape is None
                else next((n for n in names if self._shape[n] in (None, shape)), None)
            )
        return self._matched[key]


def touches_border(bbox_px: tuple[int, int, int, int], width_px: int, height_px: int) -> bool:
    """Whether a region's box (x, y, w, h) touches the image border: only part of it is seen."""
    x, y, w, h = bbox_px
    return x <= 0 or y <= 0 or x + w >= width_px or y + h >= height_px
