"""The detector on rendered scenes of the paper's layout (SPEC §4) and its error paths."""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest

from mearm.config import Config, VisionConfig
from mearm.exceptions import ImageError
from mearm.vision import (
    DISTRACTOR_BGR,
    OBJECT_BGR,
    Calibration,
    ColorDetector,
    Detection,
    Disc,
    TableRenderer,
)
from mearm.vision.reference import detect_reference
from mearm.vision.scenes import BASE_OPTIONS, CONDITIONS, DISTRACTORS, match_detections

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
LAYOUT = [(o.color, o.x, o.y) for o in CONFIG.task.scene]


@functools.lru_cache(maxsize=32)
def renderer(extras: tuple, options: tuple) -> TableRenderer:
    return TableRenderer(CAL, 640, 480, extras=extras, **dict(options))


def render(objects=LAYOUT, extras=(), **kw) -> np.ndarray:
    r = renderer(tuple(extras), tuple(sorted((BASE_OPTIONS | kw).items())))
    return r.render([Disc(OBJECT_BGR[c], x, y) for c, x, y in objects])


def match(found: list[Detection], objects=LAYOUT, tol_cm: float = 0.1) -> float:
    """Assert a one-to-one match of colours within tol_cm; return the worst error [cm]."""
    errors = match_detections(found, objects, CAL)
    assert errors is not None, [(d.color, CAL.pixel_to_table(d.centroid_px)) for d in found]
    assert errors.max() < tol_cm, errors
    return float(errors.max())


@pytest.mark.parametrize("name", list(CONDITIONS))
@pytest.mark.parametrize("with_distractors", [False, True])
def test_paper_layout_found_within_a_millimetre(name: str, with_distractors: bool) -> None:
    """Every object found with its colour within 0.1 cm, nothing else (SPEC §4 layout)."""
    extras = DISTRACTORS if with_distractors else ()
    frame = render(extras=extras, **CONDITIONS[name])
    found = ColorDetector(CONFIG.vision, CAL).detect(frame)
    match(found)
    assert not any(d.merged for d in found)


def test_empty_table_gives_no_detections() -> None:
    """Nothing on the table, distractors or not: an empty list."""
    detector = ColorDetector(CONFIG.vision, CAL)
    for table in ("wood", "grey"):
        assert detector.detect(render([], table=table)) == []
        assert detector.detect(render([], DISTRACTORS, table=table, brightness=1.3)) == []


def test_same_as_the_numpy_scipy_recipe() -> None:
    """The OpenCV shortcuts change nothing: colours, areas, boxes and centroids agree."""
    touching = [("red", -5.0, 45.0), ("green", -3.0, 45.0), ("red", 5.0, 50.0), ("red", 7.0, 50.0)]
    scenes = [render(), render(touching, DISTRACTORS, seed=5), render(LAYOUT + touching[:2])]
    for preset in ("default", "paper"):
        vision = VisionConfig(preset=preset)
        detector = ColorDetector(vision)
        for frame in scenes:
            ours, ref = detector.detect(frame), detect_reference(frame, vision)
            assert [(d.color, d.area_px, d.bbox_px) for d in ours] == [
                (d.color, d.area_px, d.bbox_px) for d in ref
            ]
            for a, b in zip(ours, ref, strict=True):
                np.testing.assert_allclose(a.centroid_px, b.centroid_px, atol=1e-9)


def test_order_is_colour_then_row_then_column() -> None:
    """Red, green, blue; each sorted by image row then column; repeatable."""
    detector = ColorDetector(CONFIG.vision, CAL)
    frame = render()
    found = detector.detect(frame)
    keys = [("red", "green", "blue").index(d.color) for d in found]
    assert keys == sorted(keys)
    for color in ("red", "green", "blue"):
        rows = [d.centroid_px[1] for d in found if d.color == color]
        assert rows == sorted(rows)
    again = detector.detect(frame)
    assert [(d.color, d.area_px) for d in again] == [(d.color, d.area_px) for d in found]
    assert all(
        np.array_equal(a.centroid_px, b.centroid_px) for a, b in zip(found, again, strict=True)
    )


def test_centroids_are_sub_pixel() -> None:
    """A disc at a non-integer pixel position is located to a tenth of a pixel."""
    detector = ColorDetector(CONFIG.vision, CAL)
    for dx in (0.0, 0.3, 0.55, 0.8):
        x, y = -3.0 + dx * 0.0625, 45.0 - dx * 0.0625 / 2  # fractions of a pixel
        (d,) = detector.detect(render([("blue", x, y)], noise_std=0.0, gradient=0.0))
        np.testing.assert_allclose(d.centroid_px, CAL.table_to_pixel([x, y]), atol=0.1)


def test_touching_objects_of_one_colour_are_flagged_merged() -> None:
    """Two touching red discs: one region, flagged, area about two objects'; no invention."""
    detector = ColorDetector(CONFIG.vision, CAL)
    (d,) = detector.detect(render([("red", -2.0, 45.0), ("red", 0.0, 45.0)]))
    assert d.merged and d.color == "red"
    assert d.elongation > 2.0
    one = np.pi * 16.0**2
    assert 1.8 * one < d.area_px < 2.2 * one
    np.testing.assert_allclose(CAL.pixel_to_table(d.centroid_px), [-1.0, 45.0], atol=0.05)


def test_merged_needs_the_calibration_for_a_compact_cluster() -> None:
    """Three touching discs in a triangle are round: only the area rule catches them."""
    r3 = np.sqrt(3.0)
    cluster = [("green", 0.0, 45.0), ("green", 2.0, 45.0), ("green", 1.0, 45.0 + r3)]
    frame = render(cluster)
    (with_cal,) = ColorDetector(CONFIG.vision, CAL).detect(frame)
    (without,) = ColorDetector(CONFIG.vision).detect(frame)
    assert with_cal.elongation < CONFIG.vision.merged_elongation
    assert with_cal.merged and not without.merged


def test_single_objects_are_not_flagged() -> None:
    """No single disc anywhere in the field is flagged (area and elongation under limits)."""
    xs, ys = np.meshgrid(np.linspace(-18, 17, 6), np.linspace(31.5, 56.5, 5))
    objects = [("blue", x, y) for x, y in zip(xs.ravel(), ys.ravel(), strict=True)]
    found = ColorDetector(CONFIG.vision, CAL).detect(render(objects))
    match(found, objects)
    assert not any(d.merged for d in found)
    assert max(d.elongation for d in found) < 1.1


def test_touching_objects_of_different_colours_are_split() -> None:
    """Red touching green: two detections at their own centres, neither flagged."""
    objects = [("red", -5.0, 45.0), ("green", -3.0, 45.0), ("blue", -4.0, 45.0 + np.sqrt(3))]
    found = ColorDetector(CONFIG.vision, CAL).detect(render(objects))
    match(found, objects, tol_cm=0.1)
    assert not any(d.merged for d in found)


def test_regions_under_the_minimum_area_are_dropped() -> None:
    """A 0.6 cm disc (~72 px) is under 100 px: dropped; with min_area_px 50 it is found."""
    frame = render([("red", 0.0, 45.0)] + [("red", 8.0, 45.0)], noise_std=0.0)
    small = TableRenderer(CAL, noise_std=0.0).render(
        [Disc(OBJECT_BGR["red"], 0.0, 45.0), Disc(OBJECT_BGR["red"], 8.0, 45.0, diameter_cm=0.6)]
    )
    assert len(ColorDetector(CONFIG.vision, CAL).detect(frame)) == 2
    assert len(ColorDetector(CONFIG.vision, CAL).detect(small)) == 1
    vision = VisionConfig(min_area_px=50)
    assert len(ColorDetector(vision, CAL).detect(small)) == 2


def test_paper_preset_misreads_real_colours() -> None:
    """As printed (SPEC §4): real blue (216°) is missed, purple (288°) is called red."""
    paper = ColorDetector(VisionConfig(preset="paper"), CAL)
    frame = render([("red", -5.0, 45.0), ("green", 0.0, 45.0), ("blue", 5.0, 45.0)])
    assert [d.color for d in paper.detect(frame)] == ["red", "green"]
    purple = TableRenderer(CAL).render([Disc(DISTRACTOR_BGR["purple"], 0.0, 45.0)])
    assert [d.color for d in paper.detect(purple)] == ["red"]
    assert ColorDetector(CONFIG.vision, CAL).detect(purple) == []


def test_band_overrides_change_the_classification() -> None:
    """A ``bands`` override in the config replaces that colour's bands only."""
    frame = render([("blue", 0.0, 45.0)])
    vision = VisionConfig(bands={"blue": [{"lo_deg": 100, "hi_deg": 110}]})
    assert ColorDetector(vision, CAL).detect(frame) == []
    vision = VisionConfig(preset="paper", bands={"blue": [{"lo_deg": 200, "hi_deg": 230}]})
    assert [d.color for d in ColorDetector(vision, CAL).detect(frame)] == ["blue"]


def test_masks_are_full_frame_and_filtered() -> None:
    """masks() covers the frame; an isolated red pixel does not survive the median."""
    frame = render([("green", 0.0, 45.0)], noise_std=0.0)
    frame[10, 10] = (0, 0, 255)
    masks = ColorDetector(CONFIG.vision, CAL).masks(frame)
    assert all(m.shape == frame.shape[:2] for m in masks.values())
    assert masks["red"].max() == 0
    assert 700 < np.count_nonzero(masks["green"]) < 900


def test_detection_is_a_frozen_record() -> None:
    """Detections are immutable: fields and the centroid array."""
    (d,) = ColorDetector(CONFIG.vision, CAL).detect(render([("red", 0.0, 45.0)]))
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.area_px = 3  # type: ignore[misc]
    with pytest.raises(ValueError):
        d.centroid_px[0] = 0.0
    assert d.centroid_px.shape == (2,) and len(d.bbox_px) == 4


@pytest.mark.parametrize(
    ("frame", "words"),
    [
        (np.zeros((48, 64), np.uint8), "(H, W, 3)"),
        (np.zeros((48, 64, 4), np.uint8), "(H, W, 3)"),
        (np.zeros((48, 64, 3), np.float32), "uint8"),
        ([[0, 0, 0]], "numpy array"),
        (np.zeros((0, 64, 3), np.uint8), "empty"),
    ],
)
def test_bad_frames_are_named_errors(frame: object, words: str) -> None:
    """A frame that is not 8-bit BGR raises ImageError saying what was expected."""
    with pytest.raises(ImageError, match=words.replace("(", r"\(").replace(")", r"\)")) as info:
        ColorDetector(CONFIG.vision).detect(frame)  # type: ignore[arg-type]
    assert info.value.source == "frame"


def test_any_frame_size_is_accepted() -> None:
    """The detector does not assume 640×480 (the 3×3 median trims a square's 4 corners)."""
    frame = np.full((100, 90, 3), 128, np.uint8)
    frame[30:60, 20:50] = OBJECT_BGR["green"]
    (d,) = ColorDetector(CONFIG.vision).detect(frame)
    assert d.color == "green" and d.area_px == 900 - 4
    np.testing.assert_allclose(d.centroid_px, [34.5, 44.5])


@pytest.mark.parametrize("shape", [(1, 1, 3), (1, 3, 3), (2, 2, 3), (4, 1, 3), (1, 7, 3)])
def test_tiny_frames_work(shape: tuple[int, int, int]) -> None:
    """Frames of a few pixels (OpenCV reads ≤ 4-element arrays as scalars) still work."""
    frame = np.zeros(shape, np.uint8)
    frame[...] = OBJECT_BGR["red"]
    (d,) = ColorDetector(VisionConfig(min_area_px=1, median_kernel=1)).detect(frame)
    assert d.color == "red" and d.area_px == shape[0] * shape[1]
    assert ColorDetector(VisionConfig(min_area_px=1)).detect(np.zeros(shape, np.uint8)) == []
