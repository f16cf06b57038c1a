r"""Parts of objects: fragments of one object joined, strips longer than one dropped.

A region of a class's colour is one object, a few touching, or a part of one object
(a shaded side, a blown-out top or a jaw hides the rest; :mod:`mearm.vision.plausible`).
Two rules follow from the objects' geometry alone, never from scored photos. Let *s* be
the calibration's scale at a detection [px/cm], *w*\ :sub:`n` and *w*\ :sub:`x` the
narrowest and widest footprint widths of its colour's objects (a class of no shape may
be any shape of the catalogue), *A* one object's flat footprint there (the largest of
the colour's shapes, as :mod:`mearm.vision.plausible` takes it) and ``E1`` one object's
largest elongation there (1 seen from straight above).

- **Fragments of one object are one object.** Two objects of a class cannot stand closer,
  centre to centre, than *w*\ :sub:`n`, and each one seen shows at least half of its
  footprint (:data:`~mearm.vision.plausible.LEAST_SEEN`), so two objects together show at
  least *A*. Two detections of one class whose centroids are closer than *s*·*w*\ :sub:`n`
  and whose areas together are under *A* are one object cut in two (a blown-out top
  between its edges): one detection, the union's area, box and centroid (the
  area-weighted mean), not ``merged``, the larger fragment's shape and yaw.
- **A part is no longer than the whole.** A region thinner than one object can only be
  an object seen in part (touching objects, each seen whole across, are no thinner than
  one), so it is no longer than one object. With the region's equivalent rectangle (of
  its area *a* and principal-axis ratio *e*: sides √(*a*·*e*) and √(*a*/*e*), the
  rectangle of the same area and second moments), one with √(*a*/*e*) < *s*·*w*\ :sub:`n`
  and √(*a*·*e*) > *s*·*w*\ :sub:`x`·``E1`` is no object: glare along a frame's edge,
  wider than half an object and longer than one. A region cut by the frame's
  border is kept (its length is not the object's).

Both need a calibration (the objects' size in pixels); without one nothing changes.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from mearm.config import ColorClass
from mearm.vision.calibration import CameraGeometry
from mearm.vision.detection import Detection
from mearm.vision.perspective_detection import _disc_diameter_cm
from mearm.vision.plausible import LEAST_SEEN, widths_cm
from mearm.vision.shapes import touches_border
from mearm.vision.thresholds import colour_groups


class ObjectBounds(Protocol):
    """What the rules need of a detector: its calibration, classes and one object's bounds."""

    calibration: CameraGeometry | None
    classes: tuple[ColorClass, ...]

    def one_object_bounds(
        self, centroids_px: np.ndarray, colors: Sequence[str], frame_shape: Sequence[int]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One object's flat area [px], largest area [px] and elongation ``E1`` at each."""
        ...


def fragment_pairs(
    centroids_px: np.ndarray,
    areas_px: np.ndarray,
    classes: Sequence[str],
    narrowest_px: np.ndarray,
    footprint_px: np.ndarray,
) -> list[tuple[int, int]]:
    """Pairs ``(i, j)``, i < j, of detections that are fragments of one object.

    Args:
        centroids_px: Their centroids (u, v) [px], (N, 2).
        areas_px: Their areas [px], (N,).
        classes: Their class names, (N,).
        narrowest_px: One object's narrowest width at each [px], (N,).
        footprint_px: One object's flat footprint at each [px], (N,).
    """
    code = {n: k for k, n in enumerate(dict.fromkeys(classes))}
    names = np.array([code[n] for n in classes])
    at = np.asarray(centroids_px, dtype=float)
    gap = np.hypot(at[:, None, 0] - at[None, :, 0], at[:, None, 1] - at[None, :, 1])
    # the smaller of the two places' objects: the stricter bound
    narrow = np.minimum(narrowest_px[:, None], narrowest_px[None, :])
    # two objects show >= LEAST_SEEN of a footprint each: one footprint together
    least = 2 * LEAST_SEEN * np.minimum(footprint_px[:, None], footprint_px[None, :])
    pair = (names[:, None] == names[None, :]) & (gap < narrow)
    pair &= areas_px[:, None] + areas_px[None, :] < least
    i, j = np.nonzero(np.triu(pair, 1))
    return list(zip(i.tolist(), j.tolist(), strict=True))


def joined(a: Detection, b: Detection) -> Detection:
    """One detection of two fragments: the union's area, box and centroid (see module)."""
    area = a.area_px + b.area_px
    centroid = (a.area_px * a.centroid_px + b.area_px * b.centroid_px) / area
    x0 = min(a.bbox_px[0], b.bbox_px[0])
    y0 = min(a.bbox_px[1], b.bbox_px[1])
    x1 = max(a.bbox_px[0] + a.bbox_px[2], b.bbox_px[0] + b.bbox_px[2])
    y1 = max(a.bbox_px[1] + a.bbox_px[3], b.bbox_px[1] + b.bbox_px[3])
    big = a if a.area_px >= b.area_px else b
    table = None
    if a.table_cm is not None and b.table_cm is not None:
        table = (a.area_px * a.table_cm + b.area_px * b.table_cm) / area
    return big.evolve(
        centroid_px=centroid,
        area_px=area,
        bbox_px=(x0, y0, x1 - x0, y1 - y0),
        merged=False,
        table_cm=table,
    )


@dataclass(frozen=True)
class _Sizes:
    """Per class name: its colour, and the colour's widths and disc diameter [cm]."""

    colour: dict[str, str]
    narrow_cm: dict[str, float]
    wide_cm: dict[str, float]
    diameter_cm: dict[str, float]
    rank: dict[str, int]


# per detector, made once: its classes never change
_SIZES: weakref.WeakKeyDictionary[ObjectBounds, _Sizes] = weakref.WeakKeyDictionary()


def _sizes(detector: ObjectBounds) -> _Sizes:
    """The classes' sizes, as the detector and :mod:`mearm.vision.plausible` take them."""
    known = _SIZES.get(detector)
    if known is None:
        classes = detector.classes
        size = {c.name: c for c in classes}
        colour, narrow, wide, diameter = {}, {}, {}, {}
        for g, (_, members) in colour_groups(classes).items():
            lo, hi = widths_cm(size[m] for m in members)
            d = max(_disc_diameter_cm(size[m]) for m in members)
            for m in members:
                colour[m], narrow[m], wide[m], diameter[m] = g, lo, hi, d
        rank = {c.name: k for k, c in enumerate(classes)}
        known = _SIZES.setdefault(detector, _Sizes(colour, narrow, wide, diameter, rank))
    return known


def _bounds_px(
    found: Sequence[Detection], detector: ObjectBounds, frame_shape: Sequence[int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""At each detection: one footprint, *s*·*w*\ :sub:`n`, *s*·*w*\ :sub:`x`·``E1`` [px]."""
    sizes = _sizes(detector)
    names = [d.color for d in found]
    centroids = np.array([d.centroid_px for d in found])
    footprint, _, stretch = detector.one_object_bounds(
        centroids, [sizes.colour[n] for n in names], frame_shape
    )
    diameter = np.array([sizes.diameter_cm[n] for n in names])
    scale = np.sqrt(footprint / (np.pi * diameter**2 / 4.0))  # [px/cm]
    narrow = scale * np.array([sizes.narrow_cm[n] for n in names])
    wide = scale * np.array([sizes.wide_cm[n] for n in names]) * stretch
    return footprint, narrow, wide


def narrowest_px(
    found: Sequence[Detection], detector: ObjectBounds, frame_shape: Sequence[int]
) -> np.ndarray:
    r"""Each detection's object's narrowest width there, *s*·*w*\ :sub:`n` [px], (N,).

    Needs the detector's calibration.
    """
    return _bounds_px(found, detector, frame_shape)[1]


def colours_of(found: Sequence[Detection], detector: ObjectBounds) -> list[str]:
    """Each detection's colour: the colour group its class is classified in."""
    colour = _sizes(detector).colour
    return [colour[d.color] for d in found]


def whole_objects(
    found: list[Detection], detector: ObjectBounds, frame_shape: Sequence[int]
) -> list[Detection]:
    """``found`` without parts longer than one object, fragments of one object joined.

    Args:
        found: A frame's detections, in the detector's order (class, row, column), kept.
        detector: The detector that found them (its calibration, classes and bounds).
        frame_shape: The frame's (H, W, ...).
    """
    return whole_objects_and_widths(found, detector, frame_shape)[0]


def whole_objects_and_widths(
    found: list[Detection], detector: ObjectBounds, frame_shape: Sequence[int]
) -> tuple[list[Detection], np.ndarray | None]:
    """:func:`whole_objects`, and each one's :func:`narrowest_px` when already known.

    ``None`` for the widths without a calibration or when fragments were joined.
    """
    if detector.calibration is None or not found:
        return found, None
    sizes = _sizes(detector)
    names = [d.color for d in found]
    centroids = np.array([d.centroid_px for d in found])
    footprint, narrow, wide = _bounds_px(found, detector, frame_shape)
    areas = np.array([d.area_px for d in found], dtype=float)
    e = np.array([d.elongation for d in found])
    long_part = (np.sqrt(areas / e) < narrow) & (np.sqrt(areas * e) > wide)
    if long_part.any():
        height, width = int(frame_shape[0]), int(frame_shape[1])
        keep = np.array(
            [
                not bad or touches_border(d.bbox_px, width, height)
                for d, bad in zip(found, long_part.tolist(), strict=True)
            ]
        )
        found = [d for d, k in zip(found, keep.tolist(), strict=True) if k]
        names = [d.color for d in found]
        centroids, areas = centroids[keep], areas[keep]
        narrow, footprint = narrow[keep], footprint[keep]
    if len(found) < 2:
        return found, narrow
    # a fragment is under one footprint less the other fragment: most detections are not
    small = np.flatnonzero(areas < 2 * LEAST_SEEN * footprint - areas.min())
    if len(small) < 2:
        return found, narrow
    pairs = fragment_pairs(
        centroids[small], areas[small], [names[k] for k in small], narrow[small], footprint[small]
    )
    if not pairs:
        return found, narrow
    joined_ = _join(found, [(int(small[i]), int(small[j])) for i, j in pairs], centroids)
    order = sorted(joined_, key=lambda d: (sizes.rank[d.color], d.centroid_px[1], d.centroid_px[0]))
    return order, None


def _join(
    found: list[Detection], pairs: list[tuple[int, int]], centroids_px: np.ndarray
) -> list[Detection]:
    """``found`` with each of ``pairs`` joined, the nearest first, each detection once."""
    pairs.sort(key=lambda p: float(np.hypot(*(centroids_px[p[0]] - centroids_px[p[1]]))))
    out: dict[int, Detection] = dict(enumerate(found))
    used: set[int] = set()
    for i, j in pairs:
        if i in used or j in used:
            continue
        used |= {i, j}
        out[i] = joined(found[i], found[j])
        del out[j]
    return list(out.values())
