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

import cv2
import numpy as np

from mearm.vision.detection import Detection, _made
from mearm.vision.regions import (
    STACKED_BOX_PX,
    _measure_regions,
    _region_mask,
    class_pieces,
    label_rows,
    region_outlines,
)
from mearm.vision.shapes import (
    ClassMatcher,
    ShapeMeasure,
    measure_shape,
    shapes_of_outlines,
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
    label_boxes: list[tuple[int, int, int, int]]  # in the label image [px]


class Found(NamedTuple):
    """A frame's regions as :func:`find_regions` measures them, one entry each."""

    codes: list[int]  # its class code
    areas: list[int]
    boxes: list[tuple[int, int, int, int]]  # in the frame [px]
    label_boxes: list[tuple[int, int, int, int]]  # in ``labels`` [px]
    elongations: list[float]
    sources: list[int | np.ndarray]  # its label, or a piece's own mask
    centroid: np.ndarray  # (N, 2) in the frame [px], read-only
    outlines: dict[int, np.ndarray]  # per label, its outline where traced
    labels: np.ndarray  # the label image (:func:`~mearm.vision.regions.label_rows`)


def find_regions(
    index: np.ndarray, origin: tuple[int, int], min_area: int, *, apart: bool = False
) -> Found:
    """The regions of a code image (the working box at ``origin`` (x, y) [px]), measured.

    In label order: each union region of one class (class code, area, boxes, centroid,
    elongation, its label); the pieces of regions where classes touch follow, each with
    its own mask (:func:`~mearm.vision.regions.class_pieces`). Regions under
    ``min_area`` [px] are dropped (smaller union regions hold smaller class regions).
    ``apart``: no two classes' pixels touch in ``index`` (every region is of one class).
    """
    ox, oy = origin
    lab = label_rows(index)
    stats, shift = lab.stats, lab.row_shift
    big = np.flatnonzero(stats[1 : lab.n_labels, cv2.CC_STAT_AREA] >= min_area) + 1
    measured = _measure_regions(lab.codes, lab.labels, stats, big, apart=apart)
    pure, region_code, elong, outlines = measured
    keep = big[pure]
    label_boxes = [(x, y, w, h) for x, y, w, h in stats[keep, :4].tolist()]
    moved = shift[keep].tolist()
    boxes = [(x + ox, y + oy + d, w, h) for (x, y, w, h), d in zip(label_boxes, moved, strict=True)]
    at = lab.centroids[keep]
    area = stats[keep, cv2.CC_STAT_AREA]
    if any(moved):  # the row sum (exact: an integer under 2**51) moved, then divided as OpenCV
        at = at.copy()
        at[:, 1] = (np.rint(at[:, 1] * area) + shift[keep] * area) / area
    centres = [at]
    codes: list[int] = region_code[pure].tolist()
    areas: list[int] = area.tolist()
    elongations: list[float] = elong[pure].tolist()
    sources: list[int | np.ndarray] = list(keep.tolist())
    for k in big[~pure].tolist():  # different classes touch: split them
        d = int(shift[k])  # the pieces' boxes and centroids are the image's
        for p in class_pieces(lab.codes, lab.labels, stats[k].tolist(), k, min_area, d):
            x, y, w, h = p.bbox_px
            codes.append(p.code)
            areas.append(p.area_px)
            boxes.append((x + ox, y + oy, w, h))
            label_boxes.append((x, y - d, w, h))
            centres.append(p.centroid_px[None, :])
            elongations.append(p.elongation)
            sources.append(p.mask)
    centroid = np.concatenate(centres) + (ox, oy)  # (N, 2) [px]
    centroid.setflags(write=False)  # its rows are the detections' own (read-only)
    return Found(codes, areas, boxes, label_boxes, elongations, sources, centroid, outlines,
                 lab.labels)  # fmt: skip


def region_shapes(r: Regions, seen: Sequence[int], labels: np.ndarray) -> dict[int, ShapeMeasure]:
    """The shapes of regions ``seen`` (indices into ``r``), each by its outline.

    A region of one label whose outline is traced (``r.outlines``, the small ones,
    traced together by :func:`~mearm.vision.regions._measure_regions`) is measured by it;
    the other small regions of one label are traced together (:func:`region_outlines`),
    the rest one by one (:func:`measure_shape` of the region's mask). ``labels``: the
    label image (``r.label_boxes`` are in its pixels).
    """
    out: dict[int, ShapeMeasure] = {}
    traced = r.outlines
    have = [(j, s) for j in seen if isinstance(s := r.sources[j], int) and s in traced]
    shapes = shapes_of_outlines([traced[s] for _, s in have])
    out.update(zip((j for j, _ in have), shapes, strict=True))
    stacked = [
        j
        for j in seen
        if j not in out
        and not isinstance(r.sources[j], np.ndarray)
        and max(r.boxes[j][2], r.boxes[j][3]) <= STACKED_BOX_PX
    ]
    if stacked:
        boxes = np.array([r.label_boxes[j] for j in stacked])
        own = np.array([r.sources[j] for j in stacked])
        outlines = region_outlines(labels, boxes, own)
        if outlines is not None:
            out.update(zip(stacked, shapes_of_outlines(outlines), strict=True))
    for j in seen:
        if j not in out:
            out[j] = measure_shape(_region_mask(r.sources[j], labels, r.label_boxes[j], 0, 0))
    return out


def seen_from_above(
    r: Regions,
    chosen: Sequence[int],
    labels: np.ndarray,
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
    shapes = region_shapes(r, seen, labels)
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
