r"""Whether a coloured region can be objects of the task: their size and shape.

A region of a class's colour is one object, or several touching, only if its outline is
one a few objects of the class's size could make. Everything here follows from the
objects' geometry, the class's shapes (:mod:`mearm.config.shape_catalogue`) and the
calibration's scale at the region's place, never from scored photos.

Let *s* be the calibration's scale there [px/cm], *w*\ :sub:`n` the footprint's
narrowest width and *w*\ :sub:`x` its widest (a disc's diameter both; a square's side and
diagonal; a triangle's height and side) over the shapes the colour's classes may have (a
class of no shape may be any shape of the catalogue), *A* the flat footprint's area at
that place [px] and ``E1`` one object's largest elongation there (1 seen from straight
above; more in perspective, :func:`~mearm.vision.perspective_detection.object_image_bounds`).
With the region's smallest rectangle (``cv2.minAreaRect``) of sides *L* ≥ *S*:

- **thickness**: *S* ≥ ½·*s*·*w*\ :sub:`n`. Every object that is seen shows at least half
  of its width in colour (a shaded side, a blown-out top or a jaw over it takes less than
  half), and touching objects are no thinner than one of them. Glare along a frame, a
  cable, a robot's edge are thinner.
- **length**: *L* ≤ *n*·*s*·*w*\ :sub:`x`·``E1`` with *n* = max(1, area / (½·*A*)): at most
  *n* objects showing at least half their footprint each fit in its area, and *n*
  objects in a row are at most *n* widest widths long. A long strip of colour with the
  area of two objects is not five objects in a row.

A region touching the frame's border is only partly seen, so it is kept: its width and
length are not the object's.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import cv2
import numpy as np

from mearm.config import ColorClass
from mearm.config.shape_catalogue import SHAPES, ShapeSpec

#: The least part of an object's width (and footprint) that a seen object shows in its
#: colour [-]: a shaded face, a blown-out top or a jaw takes at most half of it.
LEAST_SEEN = 0.5


def narrowest_cm(spec: ShapeSpec, size_cm: float) -> float:
    """The footprint's smallest width over every direction [cm] (a triangle's height)."""
    if spec.footprint == "triangle":
        return size_cm * math.sqrt(3) / 2
    return size_cm


def widths_cm(classes: Iterable[ColorClass]) -> tuple[float, float]:
    """``(narrowest, widest)`` footprint widths over the classes' objects [cm].

    A class that names no shape may be any shape of the catalogue (it matches any).
    """
    lo, hi = math.inf, 0.0
    for c in classes:
        specs = [c.object_shape] if c.shape is not None else list(SHAPES.values())
        for spec in specs:
            lo = min(lo, narrowest_cm(spec, c.diameter_cm))
            hi = max(hi, spec.widest_cm(c.diameter_cm))
    return lo, hi


def rectangle_sides_px(region: np.ndarray) -> tuple[float, float]:
    """``(L, S)``: the long and short sides of a 0/1 mask's smallest rectangle [px].

    The rectangle is around the pixels' squares (their centres' rectangle grown by one
    pixel), so one row of pixels is one pixel thick.
    """
    points = cv2.findNonZero(region)
    if points is None:
        return 0.0, 0.0
    _, (a, b), _ = cv2.minAreaRect(points)
    return max(a, b) + 1.0, min(a, b) + 1.0


def surely_plausible(
    area_px: np.ndarray,
    box_w_px: np.ndarray,
    box_h_px: np.ndarray,
    scale_px_per_cm: np.ndarray,
    footprint_px: np.ndarray,
    widths: np.ndarray,
    elongation: np.ndarray,
) -> np.ndarray:
    """Regions that pass :func:`plausible` by their area and box alone, (N,) bool.

    The smallest rectangle's long side is at most the box's diagonal *D*, and its area
    holds every pixel (*L*·*S* ≥ area), so *S* ≥ area / *D*: when that is thick enough and
    *D* short enough, the rectangle need not be found (most regions, fast). Arguments as
    :func:`plausible`'s, one per region; ``widths`` (N, 2).
    """
    diagonal = np.hypot(box_w_px, box_h_px)
    thick = area_px / diagonal >= LEAST_SEEN * scale_px_per_cm * widths[:, 0]
    most = np.maximum(1.0, area_px / (LEAST_SEEN * footprint_px))
    return np.asarray(thick & (diagonal <= most * scale_px_per_cm * widths[:, 1] * elongation))


def plausible(
    region: np.ndarray,
    area_px: float,
    scale_px_per_cm: float,
    footprint_px: float,
    widths: tuple[float, float],
    elongation: float,
) -> bool:
    """Whether a region can be one object or a few touching (the module docstring).

    Args:
        region: Its 0/1 uint8 mask over its box.
        area_px: Its area [px].
        scale_px_per_cm: The calibration's scale at its place [px/cm].
        footprint_px: One object's flat footprint's area there, *A* [px].
        widths: ``(narrowest, widest)`` footprint widths of its colour's objects [cm].
        elongation: One object's largest principal-axis ratio there, ``E1`` [-].
    """
    long_px, short_px = rectangle_sides_px(region)
    narrow, wide = widths
    if short_px < LEAST_SEEN * scale_px_per_cm * narrow:
        return False
    most = max(1.0, area_px / (LEAST_SEEN * footprint_px))
    return long_px <= most * scale_px_per_cm * wide * elongation


def may_hold_two(
    areas_px: np.ndarray,
    flat_px: np.ndarray,
    boxes_px: Iterable[tuple[int, int, int, int]],
    exclude: np.ndarray | None,
) -> np.ndarray:
    """Whether each region may be touching objects by its area, (N,) bool.

    Two objects seen show at least :data:`LEAST_SEEN` of a footprint each, so a region of
    less than one object's flat footprint (``flat_px``, at its place) is one object, seen
    in part or lying on its side (a disc tipped over shows a rectangle, its diameter by
    its height): however elongated, it is not two. Unless the arm's body (``exclude``,
    0/255) borders it: then the rest of it is hidden, and its centroid is not its centre.
    """
    two = np.asarray(areas_px, dtype=float) >= 2 * LEAST_SEEN * np.asarray(flat_px, float)
    if exclude is None or two.all():
        return two
    h, w = exclude.shape[:2]
    for k, (x, y, bw, bh) in enumerate(boxes_px):
        if not two[k]:  # a pixel round its box is the arm's: part of it may be hidden
            x0, y0, x1, y1 = max(x - 2, 0), max(y - 2, 0), min(x + bw + 2, w), min(y + bh + 2, h)
            two[k] = bool(exclude[y0:y1, x0:x1].any())
    return two
