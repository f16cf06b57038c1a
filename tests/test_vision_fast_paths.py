"""The detector's per-frame shortcuts give what the plain computations give, bit for bit."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from mearm.config import Config
from mearm.vision.classify import _UNSURE, PixelClassifier, _at_least, _nonzero, median_codes
from mearm.vision.learned import median_bgr
from mearm.vision.regions import _label, _measure_regions, _windows, class_pieces, label_rows
from mearm.vision.shapes import shape_of_outline, shapes_of_outlines
from mearm.vision.thresholds import Thresholds


def _blobs(rng: np.random.Generator, height: int, width: int) -> np.ndarray:
    """A code image of a few blobs of codes 1..3 on rows apart, some touching, some ringed."""
    index = np.zeros((height, width), np.uint8)
    for _ in range(rng.integers(1, 30)):
        x, y = int(rng.integers(0, width)), int(rng.integers(0, height))
        r = int(rng.integers(1, 9))
        cv2.circle(index, (x, y), r, int(rng.integers(1, 4)), -1)
        if rng.random() < 0.2:  # a ring with a blob inside its hole
            cv2.circle(index, (x, y), r + 4, int(rng.integers(1, 4)), 2)
    index[rng.random((height, width)) < 0.002] = 2  # specks
    return index


@pytest.mark.parametrize("seed", range(60))
def test_labelling_the_filled_rows_finds_the_regions_of_the_whole_image(seed: int) -> None:
    """Labels, boxes, areas and centroids are the whole image's, moved by each row shift."""
    rng = np.random.default_rng(seed)
    index = _blobs(rng, int(rng.integers(1, 200)), int(rng.integers(1, 120)))
    n, labels, stats, centroids = _label(index)
    got = label_rows(index)
    assert got.n_labels == n
    shift = got.row_shift
    for k in range(1, n):
        x, y, w, h, area = got.stats[k].tolist()
        assert (x, y + shift[k], w, h, area) == tuple(stats[k].tolist())
        mine = got.labels[y : y + h, x : x + w] == k
        assert np.array_equal(mine, labels[y + shift[k] : y + shift[k] + h, x : x + w] == k)
        assert np.array_equal(got.codes[y : y + h, x : x + w] * mine, index[
            y + shift[k] : y + shift[k] + h, x : x + w] * mine)  # fmt: skip
        assert got.centroids[k, 0] == centroids[k, 0]
        exact = (np.rint(got.centroids[k, 1] * area) + shift[k] * area) / area
        assert exact == centroids[k, 1]
        pieces = class_pieces(got.codes, got.labels, got.stats[k].tolist(), k, 1, int(shift[k]))
        whole = class_pieces(index, labels, stats[k].tolist(), k, 1)
        assert [(p.code, p.area_px, p.bbox_px) for p in pieces] == [
            (p.code, p.area_px, p.bbox_px) for p in whole
        ]
        assert all(
            np.array_equal(a.centroid_px, b.centroid_px) for a, b in zip(pieces, whole, strict=True)
        )


def test_an_empty_code_image_has_only_the_background() -> None:
    """No pixel: one label, nothing moved."""
    got = label_rows(np.zeros((30, 40), np.uint8))
    assert got.n_labels == 1 and not got.row_shift.any()


@pytest.mark.parametrize("seed", range(20))
def test_the_set_pixels_are_found_in_raster_order(seed: int) -> None:
    """``_nonzero`` gives ``cv2.findNonZero``'s points."""
    rng = np.random.default_rng(seed)
    mask = ((rng.random(tuple(rng.integers(1, 70, 2))) < 0.05) * 255).astype(np.uint8)
    mask[0, 0] = 255
    expected = cv2.findNonZero(mask).reshape(-1, 2)
    u, v = _nonzero(mask)
    assert np.array_equal(u, expected[:, 0]) and np.array_equal(v, expected[:, 1])


@pytest.mark.parametrize(("s_min", "v_min"), [(0.4, 0.25), (0.0, 0.0), (1.0, 1.0), (0.1, 0.9)])
def test_the_floors_as_thresholds_are_their_tables(s_min: float, v_min: float) -> None:
    """Every 8-bit S and V level gets the value the floor's look-up table gives it."""
    c = Config()
    vision = c.vision.model_copy(update={"saturation_min": s_min, "value_min": v_min})
    pc = PixelClassifier(Thresholds.from_config(c.task.classes, vision))
    level = np.arange(256, dtype=np.uint8)[None, :]
    unsure, sure = pc._sat_levels
    sat = cv2.bitwise_or(_at_least(level, unsure, _UNSURE), _at_least(level, sure, 0xFF))
    assert np.array_equal(sat[0], pc._sat_lut)
    assert np.array_equal(_at_least(level, pc._val_level, 0xFF)[0], pc._val_lut)


@pytest.mark.parametrize("seed", range(30))
def test_the_median_colour_is_numpys(seed: int) -> None:
    """``median_bgr`` from histograms equals ``np.median`` of the same pixels: on frames
    whose width is a multiple of the stride (read in place) and others, and on a view."""
    rng = np.random.default_rng(seed)
    h, w = (int(v) for v in rng.integers(1, 90, 2))
    if seed % 4 < 2:  # rows read in place, as pixels of 3 x 8 channels
        w = 8 * (w // 8 + 1)
    frame = rng.integers(0, 256 if seed % 3 else 4, (h, w, 3), dtype=np.uint8)
    if seed % 5 == 0:  # a view, not C-contiguous
        frame = frame[:, ::-1]
    mask = ((rng.random((h, w)) < rng.random()) * 255).astype(np.uint8) if seed % 2 else None
    if seed % 7 == 3:  # any mask counts where it is > 0, as the recipe below
        mask = rng.integers(-2, 2, (h, w)).astype(np.int16)
    sub = frame[::8, ::8].reshape(-1, 3)
    if mask is not None and (inside := mask[::8, ::8].reshape(-1) > 0).any():
        sub = sub[inside]
    assert np.array_equal(median_bgr(frame, mask), np.median(sub, axis=0))


def test_shapes_taken_together_are_each_outlines() -> None:
    """Discs, squares at angles and triangles: the same fill, shape and yaw as one by one."""
    outlines = []
    for k in range(12):
        mask = np.zeros((60, 60), np.uint8)
        if k % 3 == 0:
            cv2.circle(mask, (30, 30), 5 + 2 * k, 1, -1)
        elif k % 3 == 1:
            box = cv2.boxPoints(((30.0, 30.0), (10.0 + 2 * k, 10.0 + 2 * k), 7.0 * k))
            cv2.fillPoly(mask, [np.round(box).astype(np.int32)], 1)
        else:
            cv2.fillPoly(mask, [np.array([[10, 50], [50, 50], [30, 50 - 3 * k]], np.int32)], 1)
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        outlines.append(contours[0])
    assert shapes_of_outlines(outlines) == [shape_of_outline(c) for c in outlines]
    assert {s.shape for s in shapes_of_outlines(outlines)} >= {"cylinder", "cube"}
    assert shapes_of_outlines([]) == []


@pytest.mark.parametrize("seed", range(40))
def test_regions_of_classes_apart_are_measured_as_when_their_purity_is_checked(seed: int) -> None:
    """When no two classes touch, each region's code read at one pixel is the one the
    purity check finds, and every region is pure; elongations and outlines the same."""
    rng = np.random.default_rng(seed)
    index = np.zeros((120, 160), np.uint8)
    for cy in range(12, 120, 24):  # blobs of any class, one per cell, a few pixels apart
        for cx in range(12, 160, 24):
            if rng.random() < 0.8:
                axes = (int(rng.integers(1, 10)), int(rng.integers(1, 10)))
                angle = float(rng.uniform(0, 180))
                cv2.ellipse(index, (cx, cy), axes, angle, 0, 360, int(rng.integers(1, 4)), -1)
    filtered, apart = median_codes(index, 3, 3)
    assert apart
    got = label_rows(filtered)
    big = np.flatnonzero(got.stats[1 : got.n_labels, cv2.CC_STAT_AREA] >= 1) + 1
    checked = _measure_regions(got.codes, got.labels, got.stats, big)
    read = _measure_regions(got.codes, got.labels, got.stats, big, apart=True)
    assert len(set(checked.code.tolist())) > 1  # regions of several classes
    assert checked.pure.all() and read.pure.all()
    assert np.array_equal(checked.code, read.code)
    assert np.array_equal(checked.elongation, read.elongation)
    assert checked.outlines.keys() == read.outlines.keys()


@pytest.mark.parametrize("seed", range(10))
def test_windows_are_numpys_sliding_windows(seed: int) -> None:
    """The windows read through the strided view are ``sliding_window_view``'s, for a
    C-contiguous image and for a view that is not."""
    rng = np.random.default_rng(seed)
    image = rng.integers(0, 2**16, (int(rng.integers(5, 60)), int(rng.integers(5, 60))))
    image = image.astype(np.uint16)
    for source in (image, image[:, ::2], image.T):
        rows, cols = (int(rng.integers(1, n + 1)) for n in source.shape)
        y0 = rng.integers(0, source.shape[0] - rows + 1, 7)
        x0 = rng.integers(0, source.shape[1] - cols + 1, 7)
        expected = np.lib.stride_tricks.sliding_window_view(source, (rows, cols))[y0, x0]
        assert np.array_equal(_windows(source, rows, cols, y0, x0), expected)
