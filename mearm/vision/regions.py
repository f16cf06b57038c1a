"""Connected regions of the class masks: labels, moments, and touching objects split.

A union region holding several classes is cut into each class's pieces
(:func:`class_pieces`); a region holding several touching objects of one class is
split at its cores (:func:`split_region`, the detector module's docstring says when).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import cv2
import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from mearm.vision.classify import equal_mask

#: A region's core: its pixels at least this × one object's radius from its edge.
CORE_DEPTH = 0.6
#: A split's part must have at least this × one flat object's expected area.
MIN_PART = 0.5


def _label(mask: np.ndarray) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    try:  # 16-bit labels are ~3x faster; OpenCV raises if there are too many regions
        return cv2.connectedComponentsWithStats(mask, connectivity=8, ltype=cv2.CV_16U)
    except cv2.error:
        return cv2.connectedComponentsWithStats(mask, connectivity=8, ltype=cv2.CV_32S)


class Labelled(NamedTuple):
    """A class-code image's regions (:func:`label_rows`), in the kept rows' pixels."""

    n_labels: int  # the background's 0 among them
    labels: np.ndarray  # (h, W) label image of the kept rows
    stats: np.ndarray  # (n_labels, 5) OpenCV's stats, in the kept rows' pixels
    centroids: np.ndarray  # (n_labels, 2) likewise [px]
    codes: np.ndarray  # (h, W) the kept rows of the code image
    row_shift: np.ndarray  # (n_labels,) a region's rows in the image are its rows here + this


def label_rows(index: np.ndarray) -> Labelled:
    """The 8-connected regions of a code image (H, W), labelled on the rows that matter.

    Labelling costs per pixel, background included; most rows of a frame of a few
    objects hold none. The rows are taken in pairs (0–1, 2–3, …: OpenCV labels 2×2
    blocks, so its labels' order stays the image's): each run of pairs holding a pixel is
    kept with the empty pair after it (which keeps runs apart, as the empty rows between
    them did). The regions, their order, their shapes and their columns are the image's
    own, and a region's rows are consecutive there too (every one of them holds a pixel
    of it), so each region is only moved up by its ``row_shift``.
    """
    height = index.shape[0]
    filled = np.zeros(height + height % 2, bool)
    filled[:height] = cv2.reduce(index, 1, cv2.REDUCE_SUM, dtype=cv2.CV_32S).ravel() > 0
    pairs = np.logical_or(filled[0::2], filled[1::2])
    kept = pairs.copy()
    kept[1:] |= pairs[:-1]
    rows = (2 * np.flatnonzero(kept)[:, None] + (0, 1)).ravel()
    rows = rows[rows < height]
    if not len(rows) or 8 * len(rows) >= 7 * height:  # too few rows drop to pay the copy
        n, labels, stats, centroids = _label(index)
        return Labelled(n, labels, stats, centroids, index, np.zeros(n, np.intp))
    sub = index[rows]
    n, labels, stats, centroids = _label(sub)
    if n > 0xFFFF:  # 32-bit labels: OpenCV's parallel labelling, whose order may not keep
        n, labels, stats, centroids = _label(index)
        return Labelled(n, labels, stats, centroids, index, np.zeros(n, np.intp))
    top = stats[:, cv2.CC_STAT_TOP]
    return Labelled(n, labels, stats, centroids, sub, rows[top] - top)


def _elongation(region: np.ndarray) -> float:
    """Principal-axis ratio √(λ_max/λ_min) of a binary region's second central moments."""
    return _axis_ratio(cv2.moments(region, binaryImage=True))


#: Regions whose box is at most this many pixels on each side are measured together,
#: as one stack of windows; larger ones one by one [px].
STACKED_BOX_PX = 96


class Measured(NamedTuple):
    """What :func:`_measure_regions` finds of each region, each (N,) in ``big``'s order."""

    pure: np.ndarray  # bool: every pixel has one class code
    code: np.ndarray  # int: its class code (the largest, if not pure)
    elongation: np.ndarray  # float [-]
    outlines: dict[int, np.ndarray]  # per small region's label: its outline (region_outlines)


def _measure_regions(
    index: np.ndarray,
    labels: np.ndarray,
    stats: np.ndarray,
    big: np.ndarray,
    *,
    apart: bool = False,
) -> Measured:
    """Each region's purity, class code, elongation, and the small ones' outlines.

    Pure: every pixel of the region has one class code (then ``code`` is it); every
    region is when ``apart`` (no two classes' pixels touch in ``index``), and its code
    is then read at one of its pixels. The small regions (boxes up to
    :data:`STACKED_BOX_PX`) are read as one stack of equal windows over the label
    image, each at its region's box (moved inwards at the image's edge), so their
    moments are a few array operations per frame, not a call per region; the second
    moments are exact (integer sums). The same stack gives their outlines, as
    :func:`region_outlines` does (none if it cannot).
    """
    count = len(big)
    pure, code, elong = np.zeros(count, bool), np.zeros(count, int), np.ones(count)
    outlines: dict[int, np.ndarray] = {}
    if not count:
        return Measured(pure, code, elong, outlines)
    x, y, w, h, area = stats[big].T
    small = np.flatnonzero((w <= STACKED_BOX_PX) & (h <= STACKED_BOX_PX))
    if len(small):
        ww, hh = int(w[small].max()), int(h[small].max())
        y0 = np.minimum(y[small], labels.shape[0] - hh)
        x0 = np.minimum(x[small], labels.shape[1] - ww)
        own = big[small].astype(labels.dtype)[:, None, None]
        canvas = np.zeros((len(small), hh + 1, ww + 1), np.uint8)
        mask = canvas[:, :hh, :ww].view(bool)  # (n, hh, ww), in the traced canvas
        np.equal(_windows(labels, hh, ww, y0, x0), own, out=mask)
        traced = _trace_stack(canvas, x[small] - x0, y[small] - y0)
        if traced is not None:
            outlines = dict(zip(big[small].tolist(), traced, strict=True))
        if apart:  # the first pixel of its top row
            ys = y[small]
            first = mask[np.arange(len(small)), ys - y0].argmax(axis=1)
            pure[small], code[small] = True, index[ys, x0 + first]
        else:
            codes = _windows(index, hh, ww, y0, x0) * mask
            top = codes.max(axis=(1, 2))
            pure[small] = np.count_nonzero(codes == top[:, None, None], axis=(1, 2)) == area[small]
            code[small] = top
        # one product gives every window's sums of x, y, x², xy and y²; in float64 each
        # is exact (an integer far below 2**53: at most 96**2 pixels × 95**2)
        sx, sy, sxx, sxy, syy = (mask.reshape(len(small), -1).astype(float) @ _powers(hh, ww)).T
        n = area[small].astype(float)
        elong[small] = _axis_ratios(sxx - sx * sx / n, sxy - sx * sy / n, syy - sy * sy / n)
    for k in np.flatnonzero((w > STACKED_BOX_PX) | (h > STACKED_BOX_PX)).tolist():
        roi = (slice(y[k], y[k] + h[k]), slice(x[k], x[k] + w[k]))
        region = (labels[roi] == big[k]).view(np.uint8)
        lo, hi, _, _ = cv2.minMaxLoc(index[roi], mask=region)
        pure[k], code[k], elong[k] = lo == hi, int(lo), _elongation(region)
    return Measured(pure, code, elong, outlines)


def _windows(image: np.ndarray, rows: int, cols: int, y0: np.ndarray, x0: np.ndarray) -> np.ndarray:
    """The ``rows``×``cols`` windows of a 2-D image at (``y0``, ``x0``), (N, rows, cols).

    A copy, read through a strided view of every window of a C-contiguous image (made
    directly: ``sliding_window_view`` checks its arguments at several times the cost).
    """
    if not image.flags.c_contiguous:
        return sliding_window_view(image, (rows, cols))[y0, x0]
    height, width = image.shape
    step = image.strides
    every = np.ndarray(
        (height - rows + 1, width - cols + 1, rows, cols), image.dtype, image, 0, step + step
    )
    return every[y0, x0]


@functools.lru_cache(maxsize=32)  # a frame's windows are of one size; a few frames' kept
def _powers(rows: int, cols: int) -> np.ndarray:
    """Per pixel of a ``rows``×``cols`` window (row-major), its x, y, x², xy and y², (P, 5)."""
    y, x = np.mgrid[0:rows, 0:cols].reshape(2, -1).astype(float)
    out = np.stack([x, y, x * x, x * y, y * y], axis=1)
    out.setflags(write=False)
    return out


def _axis_ratios(mu20: np.ndarray, mu11: np.ndarray, mu02: np.ndarray) -> np.ndarray:
    """Principal-axis ratios √(λ_max/λ_min) of regions' second central moments, (N,).

    1 for a single pixel (both eigenvalues 0), ``inf`` for a line (the smaller one 0).
    """
    root = np.sqrt(np.maximum((mu20 - mu02) ** 2 + 4.0 * mu11 * mu11, 0.0))
    lam_max, lam_min = (mu20 + mu02 + root) / 2.0, (mu20 + mu02 - root) / 2.0
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.sqrt(lam_max / lam_min)
    ratio = np.where(lam_min <= 1e-12, np.inf, ratio)  # a line
    return np.where(lam_max <= 1e-12, 1.0, ratio)  # a single pixel


def _region_mask(
    source: int | np.ndarray, labels: np.ndarray, box: tuple[int, int, int, int], ox: int, oy: int
) -> np.ndarray:
    """A region's 0/1 mask over its box: its label's pixels, or a split piece's own mask."""
    if isinstance(source, np.ndarray):
        return source
    x, y, w, h = box[0] - ox, box[1] - oy, box[2], box[3]
    return (labels[y : y + h, x : x + w] == source).view(np.uint8)


def region_outlines(
    labels: np.ndarray, boxes: np.ndarray, own: np.ndarray
) -> list[np.ndarray] | None:
    """Regions' outer contours, as :func:`~mearm.vision.shapes.measure_shape` finds them.

    Each (M, 1, 2) int32 [px], in its box's pixels padded by one (the points that
    ``measure_shape`` of the region's mask gives, so the same fill and yaw). The regions
    (labels ``own`` (N,), boxes (N, 4) (x, y, w, h) in ``labels``, each at most
    :data:`STACKED_BOX_PX` a side) are cut out as one stack of equal windows, each a
    zero row and column apart, and traced in one ``findContours`` call, not one per
    region. ``None`` if a window does not give one contour (then measure them one by one).
    """
    count = len(own)
    if not count:
        return []
    x, y, w, h = (np.asarray(boxes[:, i], dtype=np.int64) for i in range(4))
    hh, ww = int(h.max()), int(w.max())
    y0 = np.minimum(y, labels.shape[0] - hh)  # moved inwards at the image's edge
    x0 = np.minimum(x, labels.shape[1] - ww)
    canvas = np.zeros((count, hh + 1, ww + 1), np.uint8)
    own_ = np.asarray(own).astype(labels.dtype)[:, None, None]
    canvas[:, :hh, :ww] = _windows(labels, hh, ww, y0, x0) == own_
    return _trace_stack(canvas, x - x0, y - y0)


def _trace_stack(canvas: np.ndarray, dx: np.ndarray, dy: np.ndarray) -> list[np.ndarray] | None:
    """The outlines of a stack of windows (n, hh + 1, ww + 1), one region each.

    Window ``k`` holds its region at (``dx[k]``, ``dy[k]``) and a zero last row and
    column, which keep neighbouring windows' regions apart; outlines as
    :func:`region_outlines` gives them, ``None`` if a window gives not one.
    """
    count, rows, cols = canvas.shape
    # each window holds one 8-connected region, so one outer contour
    contours, _ = cv2.findContours(
        canvas.reshape(count * rows, cols), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE
    )
    if len(contours) != count:
        return None
    # shifted all at once: one array of every point, each outline a slice of it
    length = np.fromiter(map(len, contours), np.intp, count)
    end = np.cumsum(length)
    start = end - length
    points = np.concatenate(contours)  # (M, 1, 2) int32
    window = points[start, 0, 1] // rows  # the window each outline's first point is in
    if np.count_nonzero(np.bincount(window, minlength=count)) != count:
        return None
    shift = np.stack([1 - dx, 1 - dy - np.arange(count) * rows], axis=1).astype(np.int32)
    points += np.repeat(shift[window], length, axis=0)[:, None, :]
    out: list[np.ndarray] = [points] * count
    for k, a, b in zip(window.tolist(), start.tolist(), end.tolist(), strict=True):
        out[k] = points[a:b]
    return out


def _axis_ratio(m: dict[str, float]) -> float:
    """Principal-axis ratio √(λ_max/λ_min) from a region's image moments (:func:`_axis_ratios`)."""
    one = _axis_ratios(np.array([m["mu20"]]), np.array([m["mu11"]]), np.array([m["mu02"]]))
    return float(one[0])


@dataclass(frozen=True)
class Part:
    """One object of a split region, in the region's box pixels.

    Attributes:
        area_px: Its pixel count.
        centroid_px: Mean (u, v) of its pixel centres, in the box [px].
        bbox_px: Its bounding box (x, y, w, h) in the box [px].
        elongation: Its principal-axis ratio [-].
        mask: Its pixels, a 0/1 uint8 image of its bounding box.
    """

    area_px: int
    centroid_px: tuple[float, float]
    bbox_px: tuple[int, int, int, int]
    elongation: float
    mask: np.ndarray = field(repr=False, compare=False)


def split_region(
    region: np.ndarray,
    radius_px: float,
    min_area_px: float,
    max_area_px: float,
    max_elongation: float,
) -> list[Part] | None:
    """The objects of a region holding several touching ones, or ``None`` if not sure.

    Args:
        region: The region, 0/1 uint8 image of its bounding box.
        radius_px: One object's radius there [px] (its flat disc's).
        min_area_px: A part smaller than this is no object: no split.
        max_area_px: A part larger than this is not one object: no split.
        max_elongation: A part longer than this is not one object: no split.

    Returns:
        The parts (≥ 2, pixels given to the nearest core), or ``None`` when the region
        has fewer than two cores or a part fails the size or shape test.
    """
    padded = cv2.copyMakeBorder(region, 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0)
    depth = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    cores = (depth >= CORE_DEPTH * radius_px).view(np.uint8)
    n, _, _, _ = _label(cores)
    if n < 3:  # background and one core (or none)
        return None
    _, nearest = cv2.distanceTransformWithLabels(
        1 - cores, cv2.DIST_L2, cv2.DIST_MASK_5, labelType=cv2.DIST_LABEL_CCOMP
    )
    nearest = nearest[1:-1, 1:-1]
    parts = []
    for lab in np.unique(nearest[region.view(bool)]):
        piece = ((nearest == lab) & region.view(bool)).view(np.uint8)
        m = cv2.moments(piece, binaryImage=True)
        area = m["m00"]
        if not min_area_px <= area <= max_area_px:
            return None
        elongation = _axis_ratio(m)
        if elongation > max_elongation:
            return None
        x, y, w, h = cv2.boundingRect(piece)
        centroid = (m["m10"] / area, m["m01"] / area)
        parts.append(
            Part(int(area), centroid, (x, y, w, h), elongation, piece[y : y + h, x : x + w])
        )
    return parts if len(parts) >= 2 else None


class Piece(NamedTuple):
    """One class's region inside a region where objects of several classes touch.

    Attributes:
        code: Its class code (1..N).
        area_px: Its pixel count.
        bbox_px: Its bounding box (x, y, w, h) in the working box [px].
        centroid_px: Mean (u, v) of its pixel centres in the working box [px], (2,).
        elongation: Its principal-axis ratio [-].
        mask: Its pixels, a 0/1 uint8 image of its bounding box.
    """

    code: int
    area_px: int
    bbox_px: tuple[int, int, int, int]
    centroid_px: np.ndarray
    elongation: float
    mask: np.ndarray


def class_pieces(
    index: np.ndarray,
    labels: np.ndarray,
    stats_row: Sequence[int],
    lab: int,
    min_area: int,
    row_shift: int = 0,
) -> list[Piece]:
    """The regions of each class inside union region ``lab``, where classes touch.

    Each class inside the region's box is labelled on its own; pieces under
    ``min_area`` [px] are dropped. Their boxes and centroids are ``row_shift`` rows
    below the labels' (:func:`label_rows`).
    """
    x, y, w, h, _ = stats_row
    roi = (slice(y, y + h), slice(x, x + w))
    y_out = y + row_shift
    region = (labels[roi] == lab).view(np.uint8)
    lo, hi, _, _ = cv2.minMaxLoc(index[roi], mask=region)
    out = []
    for i in range(int(lo), int(hi) + 1):
        sub = equal_mask(index[roi], i)
        sub = cv2.bitwise_and(sub, sub, mask=region)
        m, sub_labels, sub_stats, sub_centroids = _label(sub)
        for s in range(1, m):
            sx, sy, sw, sh, sarea = sub_stats[s].tolist()
            if sarea >= min_area:
                mask = (sub_labels[sy : sy + sh, sx : sx + sw] == s).view(np.uint8)
                centre = sub_centroids[s] + (x, y_out)
                out.append(
                    Piece(i, sarea, (x + sx, y_out + sy, sw, sh), centre, _elongation(mask), mask)
                )
    return out
