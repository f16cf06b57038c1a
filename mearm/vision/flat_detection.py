"""A frame's detections seen from straight above, each made once (the detector's fast path).

Given the regions :meth:`~mearm.vision.detector.ColorDetector.detect` measured and the
ones that can be objects, each region's shape is read from its outline (the small
regions' outlines traced together, :func:`~mearm.vision.regions.region_outlines`), its
class matched, a cube's yaw turned onto the table, and each detection made once, in the
documented order: what the general path (``_classify_regions`` and the per-detection
updates) gives for a calibration of the objects' plane or none, in a few calls per frame
and a few µs per object.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple

import numpy as np

from mearm.vision.detection import Detection, _made
from mearm.vision.regions import STACKED_BOX_PX, _region_mask, region_outlines
from mearm.vision.shapes import (
    ClassMatcher,
    ShapeMeasure,
    measure_shape,
    shape_of_outline,
    table_yaw_deg,
    touches_border,
)


class Regions(NamedTuple):
    """A frame's regions, one entry each: what the detector measured."""

    colors: list[str]  # its colour's name
    centroid: np.ndarray  # (N, 2) [px], read-only
    areas: list[int]
    boxes: list[tuple[int, int, int, int]]  # in the frame [px]
    merged: list[bool]
    elongations: list[float]
    table: np.ndarray | None  # (N, 2) [cm], read-only
    sources: list[int | np.ndarray]  # its label, or a piece's own mask
    outlines: Mapping[int, np.ndarray]  # per label, its outline where already traced


def region_shapes(
    r: Regions, seen: Sequence[int], labels: np.ndarray, origin: tuple[int, int]
) -> dict[int, ShapeMeasure]:
    """The shapes of regions ``seen`` (indices into ``r``), each by its outline.

    A region of one label whose outline is traced (``r.outlines``, the small ones,
    traced together by :func:`~mearm.vision.regions._measure_regions`) is measured by it;
    the other small regions of one label are traced together (:func:`region_outlines`),
    the rest one by one (:func:`measure_shape` of the region's mask). ``labels``: the
    label image of the working box at ``origin`` (x, y) [px].
    """
    ox, oy = origin
    out: dict[int, ShapeMeasure] = {}
    for j in seen:
        source = r.sources[j]
        if not isinstance(source, np.ndarray) and source in r.outlines:
            out[j] = shape_of_outline(r.outlines[source])
    stacked = [
        j
        for j in seen
        if j not in out
        and not isinstance(r.sources[j], np.ndarray)
        and max(r.boxes[j][2], r.boxes[j][3]) <= STACKED_BOX_PX
    ]
    if stacked:
        boxes = np.array([r.boxes[j] for j in stacked]) - (ox, oy, 0, 0)
        own = np.array([r.sources[j] for j in stacked])
        outlines = region_outlines(labels, boxes, own)
        if outlines is not None:
            out.update((j, shape_of_outline(c)) for j, c in zip(stacked, outlines, strict=True))
    for j in seen:
        if j not in out:
            out[j] = measure_shape(_region_mask(r.sources[j], labels, r.boxes[j], ox, oy))
    return out


def seen_from_above(
    r: Regions,
    chosen: Sequence[int],
    labels: np.ndarray,
    origin: tuple[int, int],
    frame_shape: Sequence[int],
    matcher: ClassMatcher,
    rank: Mapping[str, int],
    pixel_to_table: Callable[[np.ndarray], np.ndarray] | None,
) -> list[Detection]:
    """The detections of regions ``chosen`` (indices into ``r``), in the documented order.

    Each region's shape (unless merged or cut by the frame's border) and class
    (``matcher``; regions of no class are dropped); a cube's yaw on the table through
    ``pixel_to_table`` where given. Ordered by class (``rank``, the classes' order),
    then row, then column of the centroid; ties keep the regions' order.
    """
    height, width = int(frame_shape[0]), int(frame_shape[1])
    seen = [j for j in chosen if not r.merged[j] and not touches_border(r.boxes[j], width, height)]
    shapes = region_shapes(r, seen, labels, origin)
    match = matcher.match
    out: list[Detection] = []
    rows: list[int] = []
    for j in chosen:
        measured = shapes.get(j)
        shape = None if measured is None else measured.shape
        name = match(r.colors[j], shape)
        if name is None:
            continue
        yaw = None if measured is None or shape != "cube" else measured.yaw_px_deg
        on_table = None
        if yaw is not None and pixel_to_table is not None:
            on_table = table_yaw_deg(pixel_to_table, r.centroid[j], yaw)
        at = None if r.table is None else r.table[j]
        out.append(_made(name, r.centroid[j], r.areas[j], r.boxes[j], merged=r.merged[j],
                         elongation=r.elongations[j], table_cm=at, shape=shape,
                         yaw_px_deg=yaw, yaw_deg=on_table))  # fmt: skip
        rows.append(j)
    at_px = r.centroid[rows]
    order = np.lexsort((at_px[:, 0], at_px[:, 1], np.array([rank[d.color] for d in out])))
    return [out[i] for i in order.tolist()]
