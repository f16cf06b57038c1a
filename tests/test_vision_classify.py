"""Pixel classification: the bands as printed (paper §4), exactly, and the fast path."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mearm.config import ColorClass, HueBand, VisionConfig, default_classes, paper_classes
from mearm.config.defaults import PAPER_HUE_BANDS_DEG
from mearm.exceptions import ConfigError
from mearm.vision.classify import PixelClassifier, classify_exact, hsv_exact, median_codes
from mearm.vision.thresholds import MAX_CLASSES, Thresholds

#: The paper's printed bands with its floors, S, V ≥ 0.1 (paper §4).
PAPER_VISION = VisionConfig(saturation_min=0.1, value_min=0.1)
PAPER = Thresholds.from_config(paper_classes(), PAPER_VISION)
DEFAULT = Thresholds.from_config(default_classes(), VisionConfig())
RED, GREEN, BLUE = (DEFAULT.codes[c] for c in ("red", "green", "blue"))


def with_bands(classes: list[ColorClass], name: str, *bands: tuple[float, float]):
    """``classes`` with the bands of class ``name`` replaced."""
    new = [HueBand(lo_deg=lo, hi_deg=hi) for lo, hi in bands]
    return [c.model_copy(update={"hue_bands_deg": new}) if c.name == name else c for c in classes]


def rgb(r: int, g: int, b: int) -> tuple[int, int, int]:
    return (b, g, r)  # BGR


# (pixel, its exact hue [deg], class under the bands as printed: red H ≤ 20 or H ≥ 280,
# blue 90..120, green 130..160; S and V in [0.1, 1])
PAPER_EDGES = [
    (rgb(255, 85, 0), 20.0, RED),  # H = 60·85/255 = 20 exactly: included
    (rgb(255, 86, 0), 60 * 86 / 255, 0),  # 20.24°: outside
    (rgb(170, 0, 255), 280.0, RED),  # 240 + 60·170/255 = 280: included
    (rgb(169, 0, 255), 240 + 60 * 169 / 255, 0),  # 279.76°: outside
    (rgb(255, 0, 0), 0.0, RED),
    (rgb(255, 0, 255), 300.0, RED),  # magenta is "red" as printed
    (rgb(127, 254, 0), 90.0, BLUE),  # 120 − 60·127/254 = 90: included
    (rgb(128, 254, 0), 120 - 60 * 128 / 254, 0),  # 89.76°
    (rgb(0, 255, 0), 120.0, BLUE),  # pure green is "blue" as printed
    (rgb(0, 255, 2), 120 + 60 * 2 / 255, 0),  # 120.47°: the gap between blue and green
    (rgb(0, 252, 42), 130.0, GREEN),  # 120 + 60·42/252 = 130: included
    (rgb(0, 255, 42), 120 + 60 * 42 / 255, 0),  # 129.88°
    (rgb(0, 255, 170), 160.0, GREEN),  # included
    (rgb(0, 255, 171), 120 + 60 * 171 / 255, 0),  # 160.24°
    (rgb(0, 0, 255), 240.0, 0),  # pure blue is nothing as printed
]


@pytest.mark.parametrize(("px", "hue", "code"), PAPER_EDGES)
def test_paper_bands_as_printed(px: tuple[int, int, int], hue: float, code: int) -> None:
    """Each band edge of paper §4 is inclusive, and a hair outside is out, on both paths."""
    frame = np.array([[px]], np.uint8)
    h, s, v = hsv_exact(frame)
    assert h[0, 0] == pytest.approx(hue, abs=1e-12)
    assert classify_exact(frame, PAPER)[0, 0] == code
    assert PixelClassifier(PAPER).classify(frame)[0, 0] == code


@pytest.mark.parametrize(
    ("px", "code"),
    [
        (rgb(100, 90, 90), RED),  # S = 0.1 exactly: in
        (rgb(100, 91, 91), 0),  # S = 0.09: out
        (rgb(26, 0, 0), RED),  # V = 26/255 = 0.102: in
        (rgb(25, 0, 0), 0),  # V = 0.098: out
        (rgb(128, 128, 128), 0),  # grey: S = 0
        (rgb(0, 0, 0), 0),
    ],
)
def test_paper_floors_as_printed(px: tuple[int, int, int], code: int) -> None:
    """S and V must lie in [0.1, 1] (paper §4)."""
    frame = np.array([[px]], np.uint8)
    assert classify_exact(frame, PAPER)[0, 0] == code
    assert PixelClassifier(PAPER).classify(frame)[0, 0] == code


def colour_slab(blue: range) -> np.ndarray:
    """Every (r, g) for the given blue levels, as a (256·len, 256, 3) BGR frame."""
    b, g, r = np.meshgrid(np.array(blue), np.arange(256), np.arange(256), indexing="ij")
    return np.stack([b, g, r], axis=-1).astype(np.uint8).reshape(-1, 256, 3)


@pytest.mark.heavy
def test_fast_path_is_exact_on_every_colour() -> None:
    """The 8-bit LUT path with exact refinement equals float64 on all 2²⁴ colours (paper)."""
    classifier = PixelClassifier(PAPER)
    for start in range(0, 256, 16):  # in slabs, to keep memory small
        frame = colour_slab(range(start, start + 16))
        assert np.array_equal(classifier.classify(frame), classify_exact(frame, PAPER))


def test_paper_thresholds_are_the_printed_ones() -> None:
    """paper_classes() + floors 0.1 resolve to the printed bands, codes in class order."""
    assert PAPER.bands_deg == {
        "red": ((280.0, 20.0),),
        "green": ((130.0, 160.0),),
        "blue": ((90.0, 120.0),),
    }
    assert PAPER.bands_deg == PAPER_HUE_BANDS_DEG
    assert (PAPER.saturation_min, PAPER.value_min) == (0.1, 0.1)
    assert PAPER.codes == {"red": 1, "green": 2, "blue": 3} == DEFAULT.codes


@pytest.mark.heavy
def test_fast_path_is_exact_for_the_default_preset() -> None:
    """Same for the default preset, on every 5th blue level (all r, g)."""
    classifier = PixelClassifier(DEFAULT)
    for start in range(0, 256, 80):
        frame = colour_slab(range(start, min(start + 80, 256), 5))
        assert np.array_equal(classifier.classify(frame), classify_exact(frame, DEFAULT))


@settings(deadline=None, max_examples=60)  # timing is not the point; load varies
@given(
    lo=st.floats(0, 360, allow_nan=False),
    hi=st.floats(0, 360, allow_nan=False),
    s_min=st.floats(0, 1),
    v_min=st.floats(0, 1),
)
def test_fast_path_is_exact_for_any_thresholds(lo: float, hi: float, s_min: float, v_min: float):
    """Whatever the bands and floors (wrapping or not), the fast path is exact."""
    vision = VisionConfig(saturation_min=s_min, value_min=v_min)
    thr = Thresholds.from_config(with_bands(default_classes(), "red", (lo, hi)), vision)
    rng = np.random.default_rng(int(lo * 1000 + hi))
    frame = rng.integers(0, 256, (64, 64, 3), dtype=np.uint8)
    assert np.array_equal(PixelClassifier(thr).classify(frame), classify_exact(frame, thr))


def test_default_preset_ignores_what_it_must() -> None:
    """Wood, grey, white paper, a highlight, shadowed wood, yellow, orange, purple: no class."""
    ignored = {
        "wood": (95, 145, 195),
        "dark wood grain": (70, 110, 160),
        "wood in shadow": (40, 62, 85),
        "grey table": (128, 128, 128),
        "white paper": (238, 240, 242),
        "highlight on wood": (200, 230, 250),
        "yellow": (40, 210, 230),
        "orange": (30, 130, 240),
        "purple": (150, 50, 130),
        "black": (10, 10, 10),
    }
    frame = np.array([list(ignored.values())], np.uint8)
    codes = classify_exact(frame, DEFAULT)[0]
    assert dict(zip(ignored, codes.tolist(), strict=True)) == dict.fromkeys(ignored, 0)


def test_default_preset_finds_real_colours_in_any_light() -> None:
    """Painted and drawn red, green, blue at 0.6×–1.5× light (clipped) keep their class."""
    painted = {RED: (45, 40, 200), GREEN: (70, 160, 50), BLUE: (180, 90, 30)}  # webcam, BGR
    drawn = {DEFAULT.codes[c.name]: c.draw_rgb[::-1] for c in default_classes()}  # sim, BGR
    for code, bgr in [*painted.items(), *drawn.items()]:
        for gain in (0.6, 0.8, 1.0, 1.2, 1.5):
            px = np.clip(np.rint(np.array(bgr) * gain), 0, 255).astype(np.uint8)
            assert classify_exact(px[None, None], DEFAULT)[0, 0] == code, (bgr, gain)


def test_overlapping_bands_go_to_the_first_class() -> None:
    """Classes are tried in their configured order (documented in classify.py)."""
    thr = Thresholds.from_config(with_bands(default_classes(), "green", (0, 360)), VisionConfig())
    frame = np.array([[rgb(255, 0, 0), rgb(0, 0, 255)]], np.uint8)
    assert classify_exact(frame, thr)[0].tolist() == [RED, GREEN]
    assert PixelClassifier(thr).classify(frame)[0].tolist() == [RED, GREEN]
    reordered = Thresholds.from_config(default_classes()[::-1], VisionConfig())
    assert reordered.codes == {"blue": 1, "green": 2, "red": 3}
    assert classify_exact(frame, reordered)[0].tolist() == [3, 1]


def test_bands_come_from_the_classes_and_floors_from_vision() -> None:
    """Changing one class's bands keeps the others'; the floors are vision's."""
    thr = Thresholds.from_config(with_bands(paper_classes(), "blue", (200, 250)), PAPER_VISION)
    assert thr.bands_deg["blue"] == ((200.0, 250.0),)
    assert thr.bands_deg["red"] == PAPER.bands_deg["red"]
    assert (thr.saturation_min, thr.value_min) == (0.1, 0.1)
    thr = Thresholds.from_config(default_classes(), VisionConfig(saturation_min=0.2))
    assert thr.saturation_min == 0.2 and thr.value_min == DEFAULT.value_min


def test_a_class_may_have_several_bands() -> None:
    """A pixel in any of a class's bands is that class, on both paths."""
    thr = Thresholds.from_config(
        with_bands(default_classes(), "blue", (200, 210), (240, 250)), VisionConfig()
    )
    hues = [rgb(0, 149, 255), rgb(0, 85, 255), rgb(21, 0, 255), rgb(85, 0, 255)]
    frame = np.array([hues], np.uint8)
    want = [BLUE, 0, BLUE, 0]  # 205°, 220°, 245°, 260°
    assert classify_exact(frame, thr)[0].tolist() == want
    assert PixelClassifier(thr).classify(frame)[0].tolist() == want


@pytest.mark.heavy
def test_any_number_of_classes() -> None:
    """One class, or four with a yellow between red and green: codes 1..N, fast = exact."""
    (blue,) = [c for c in default_classes() if c.name == "blue"]
    one = Thresholds.from_config([blue], VisionConfig())
    frame = np.array([[rgb(35, 60, 200), rgb(200, 30, 35), rgb(230, 200, 30)]], np.uint8)
    assert one.codes == {"blue": 1}
    assert classify_exact(frame, one)[0].tolist() == [1, 0, 0]
    yellow = ColorClass(
        name="yellow",
        hue_bands_deg=[HueBand(lo_deg=45, hi_deg=65)],
        draw_rgb=(230, 200, 30),
        bin_cm=(-20.0, 25.0, 20.0),
    )
    four = Thresholds.from_config([*default_classes(), yellow], VisionConfig())
    assert four.codes == {"red": 1, "green": 2, "blue": 3, "yellow": 4}
    assert classify_exact(frame, four)[0].tolist() == [3, 1, 4]
    for thr in (one, four):
        classifier = PixelClassifier(thr)
        for start in range(0, 256, 128):
            slab = colour_slab(range(start, start + 128, 9))
            assert np.array_equal(classifier.classify(slab), classify_exact(slab, thr))


def test_bad_class_lists_are_named_errors() -> None:
    """No classes, a name twice, or more classes than codes: ConfigError saying so."""
    with pytest.raises(ConfigError, match="no classes; give at least one"):
        Thresholds.from_config([], VisionConfig())
    red = default_classes()[0]
    with pytest.raises(ConfigError, match="'red' is listed twice"):
        Thresholds.from_config([red, red], VisionConfig())
    many = [
        red.model_copy(
            update={"name": f"c{i}", "hue_bands_deg": [HueBand(lo_deg=2.0 * i, hi_deg=2.0 * i + 1)]}
        )
        for i in range(MAX_CLASSES + 1)
    ]  # each a colour of its own
    with pytest.raises(ConfigError, match=f"{MAX_CLASSES + 1} colours .* at most {MAX_CLASSES}"):
        Thresholds.from_config(many, VisionConfig())
    assert len(Thresholds.from_config(many[:MAX_CLASSES], VisionConfig()).codes) == MAX_CLASSES
    # classes of one colour share its code: as many classes as codes, one colour
    same = [red.model_copy(update={"name": f"s{i}"}) for i in range(MAX_CLASSES + 1)]
    assert len(Thresholds.from_config(same, VisionConfig()).codes) == 1


def per_class_medians(codes: np.ndarray, kernel: int, count: int) -> np.ndarray:
    """Each class's mask median-filtered on its own, written back as its code."""
    out = np.zeros_like(codes)
    for code in range(1, count + 1):
        mask = np.where(codes == code, 255, 0).astype(np.uint8)
        out[cv2.medianBlur(mask, kernel) > 0] = code
    return out


def two_classes_touch(codes: np.ndarray) -> bool:
    """Whether two 8-neighbouring pixels hold two different classes (0 is none)."""
    padded = np.pad(codes.astype(int), 1)
    height, width = codes.shape
    for dy, dx in ((0, 1), (1, -1), (1, 0), (1, 1)):
        other = padded[1 + dy : 1 + dy + height, 1 + dx : 1 + dx + width]
        if np.any((codes > 0) & (other > 0) & (codes != other)):
            return True
    return False


@settings(max_examples=80, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    kernel=st.sampled_from([1, 3, 5, 7]),
    count=st.integers(1, 6),
    fill=st.floats(0.05, 0.9),
    height=st.integers(1, 40),
    width=st.integers(1, 40),
)
def test_median_codes_is_each_class_filtered_on_its_own(seed, kernel, count, fill, height, width):
    # blobs of several classes touching, noise, and the image's borders: every case where
    # one median of the codes could differ from the classes' own medians
    rng = np.random.default_rng(seed)
    coarse = rng.integers(1, count + 1, size=(height // 4 + 1, width // 4 + 1), dtype=np.uint8)
    codes = np.kron(coarse, np.ones((4, 4), np.uint8))[:height, :width]
    codes[rng.random((height, width)) > fill] = 0
    flips = rng.random((height, width)) < 0.1
    codes[flips] = rng.integers(0, count + 1, size=int(flips.sum()), dtype=np.uint8)
    got, apart = median_codes(codes, kernel, count)
    expected = codes if kernel == 1 else per_class_medians(codes, kernel, count)
    np.testing.assert_array_equal(got, expected)
    if apart:  # the promise the labelling relies on: each region is of one class
        assert not two_classes_touch(got)


@pytest.mark.parametrize("kernel", [3, 5])
def test_median_codes_of_classes_apart_says_so(kernel):
    # two blobs of two classes with a gap of a window between them: one median, apart;
    # the same blobs a pixel apart: some window holds both, so not known to be apart
    codes = np.zeros((20, 30), np.uint8)
    codes[5:15, 3:10] = 1
    codes[5:15, 10 + kernel : 20] = 2
    got, apart = median_codes(codes, kernel, 2)
    assert apart and not two_classes_touch(got)
    np.testing.assert_array_equal(got, per_class_medians(codes, kernel, 2))
    codes[5:15, 10 : 10 + kernel] = 0
    codes[5:15, 11:20] = 2
    got, apart = median_codes(codes, kernel, 2)
    assert not apart
    np.testing.assert_array_equal(got, per_class_medians(codes, kernel, 2))


def test_median_codes_of_a_window_of_two_classes_without_a_majority():
    # a 3x3 window 0 0 0 / 1 2 2 / 2 3 3: the codes' median is 2, held by three pixels of
    # nine; no class holds five, so each class's own median leaves the centre empty
    codes = np.zeros((9, 9), np.uint8)
    codes[3:6, 3:6] = [[0, 0, 0], [1, 2, 2], [2, 3, 3]]
    assert cv2.medianBlur(codes, 3)[4, 4] == 2
    got, apart = median_codes(codes, 3, 3)
    assert got[4, 4] == 0 and not apart
    np.testing.assert_array_equal(got, per_class_medians(codes, 3, 3))
    unfiltered, apart = median_codes(codes, 1, 3)
    np.testing.assert_array_equal(unfiltered, codes)
    assert not apart  # two classes touch there, unfiltered
