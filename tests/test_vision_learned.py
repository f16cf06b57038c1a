"""Learned colours on rendered frames degraded as webcams degrade them (mearm.vision.learned)."""

from __future__ import annotations

import functools

import cv2
import numpy as np
import pytest

from mearm.config import Config, VisionConfig, default_classes
from mearm.config.classes import LearnedColour
from mearm.sim import TableRenderer, class_discs
from mearm.sim.kinematic.renderer import Disc
from mearm.sim.kinematic.vision_scenes import BASE_OPTIONS, CONDITIONS, match_detections
from mearm.vision import Calibration, ColorDetector
from mearm.vision.errors import SampleError
from mearm.vision.learned import (
    LearnedClassifier,
    accepts,
    area_mask,
    balance,
    clipped_bgr,
    distance,
    ellipse_distance,
    fit_colour,
    lab_of,
    median_bgr,
)
from mearm.vision.teaching import Sample, _refuse_shared, teach

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
LAYOUT = [(o.color, o.x, o.y) for o in CONFIG.task.scene]
ORANGE_BGR, PINK_BGR, PURPLE_BGR = (30, 130, 240), (170, 120, 245), (150, 50, 130)
#: Objects of colours no class has: orange and pink (the reds' neighbours), purple.
OTHERS = (
    Disc(ORANGE_BGR, 16.0, 56.0),
    Disc(PINK_BGR, -16.0, 55.0),
    Disc(PURPLE_BGR, 16.0, 33.0),
    Disc(ORANGE_BGR, -4.0, 38.5),
)


@functools.lru_cache(maxsize=16)
def render(extras: tuple = (), **kw) -> np.ndarray:
    options = BASE_OPTIONS | kw
    r = TableRenderer(CAL, 640, 480, extras=extras, **options)
    return r.render(class_discs(CONFIG.task.classes, LAYOUT))


def webcam(
    frame: np.ndarray,
    *,
    gains_bgr: tuple[float, float, float] = (1.0, 1.0, 1.0),
    noise: float = 0.0,
    jpeg: int | None = None,
    blur: int = 0,
    vignette: float = 0.0,
    seed: int = 0,
) -> np.ndarray:
    """``frame`` as a webcam spoils it: white balance and exposure (per-channel gains,
    clipped), vignetting (the corners darker by ``vignette``), blur, sensor noise, JPEG."""
    out = frame.astype(float) * np.asarray(gains_bgr)
    if vignette:
        h, w = frame.shape[:2]
        y, x = np.mgrid[0:h, 0:w]
        r2 = ((x - w / 2) / (w / 2)) ** 2 + ((y - h / 2) / (h / 2)) ** 2
        out *= (1.0 - vignette * r2 / 2.0)[..., None]
    if blur:
        out = cv2.GaussianBlur(out, (0, 0), blur)
    out += np.random.default_rng(seed).normal(0.0, noise, out.shape)
    img = np.clip(np.round(out), 0, 255).astype(np.uint8)
    if jpeg is not None:
        ok, data = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, jpeg])
        assert ok
        img = cv2.imdecode(data, cv2.IMREAD_COLOR)
    return img


def one_click_each(objects=LAYOUT) -> list[Sample]:
    """One click per class, on the first object of each (as a user teaches)."""
    out = []
    for name in dict.fromkeys(c for c, _, _ in objects):
        _, x, y = next(o for o in objects if o[0] == name)
        u, v = CAL.table_to_pixel(np.array([[x, y]]))[0]
        out.append(Sample(name, float(u), float(v)))
    return out


@functools.lru_cache(maxsize=4)
def taught_detector(extras: tuple = ()) -> ColorDetector:
    """The default classes taught by one click each on the nominal frame."""
    t = teach([render(extras)], one_click_each())
    classes = [
        c.model_copy(update={"learned_colour": t.colours[c.name]}) for c in default_classes()
    ]
    vision = CONFIG.vision.model_copy(
        update={"reference_bgr": t.reference_bgr, "work_area_px": t.work_area_px}
    )
    return ColorDetector(vision, CAL, classes)


def found_exactly(detector: ColorDetector, frame: np.ndarray, tol_cm: float = 0.15) -> None:
    found = detector.detect(frame)
    errors = match_detections(found, LAYOUT, CAL)
    assert errors is not None, [(d.color, CAL.pixel_to_table(d.centroid_px)) for d in found]
    assert errors.max() < tol_cm, errors


WEBCAMS = {
    "warm white balance": {"gains_bgr": (0.75, 0.95, 1.2)},
    "cool white balance": {"gains_bgr": (1.25, 1.0, 0.8)},
    "under-exposed": {"gains_bgr": (0.6, 0.6, 0.6)},
    "over-exposed": {"gains_bgr": (1.35, 1.35, 1.35)},
    "noise, JPEG 60": {"noise": 4.0, "jpeg": 60},
    "blur, vignetting": {"blur": 1, "vignette": 0.35},
    "all at once": {
        "gains_bgr": (0.8, 1.0, 1.2),
        "noise": 3.0,
        "jpeg": 70,
        "blur": 1,
        "vignette": 0.25,
    },
}


@pytest.mark.parametrize("name", list(WEBCAMS))
def test_taught_colours_hold_on_a_webcam(name: str) -> None:
    """Taught on one clean frame, every object is found under webcam white balance,
    exposure, noise, JPEG, blur and vignetting, with objects of other colours about."""
    frame = webcam(render(OTHERS), **WEBCAMS[name], seed=7)
    found_exactly(taught_detector(), frame)


@pytest.mark.parametrize("name", ["brightness +30%", "brightness -30%", "strong gradient"])
def test_taught_colours_hold_under_a_lamp(name: str) -> None:
    """The lamp conditions of the suite (the overexposed wood among them) on the same table."""
    found_exactly(taught_detector(), render(**CONDITIONS[name]))


def test_orange_and_pink_are_not_red() -> None:
    """Colours that fit no class are no class: the orange and pink discs are not red."""
    found = taught_detector().detect(render(OTHERS))
    assert match_detections(found, LAYOUT, CAL) is not None
    assert len(found) == len(LAYOUT)


def test_work_area_keeps_out_what_is_outside() -> None:
    """Nothing outside the work area is detected; inside, everything still is."""
    base = taught_detector()
    left = [(0.0, 0.0), (285.0, 0.0), (285.0, 479.0), (0.0, 479.0)]  # between objects
    vision = base.vision.model_copy(update={"work_area_px": left})
    found = ColorDetector(vision, CAL, base.classes).detect(render())
    assert found and all(d.bbox_px[0] + d.bbox_px[2] <= 286 for d in found)
    inside = [o for o in LAYOUT if CAL.table_to_pixel(np.array([o[1:]]))[0][0] < 285]
    assert len(found) == len(inside)


def test_balance_undoes_a_white_balance_shift() -> None:
    """Per-channel gains on a frame are undone against its own median colour (within 2 levels)."""
    frame = render()
    shifted = webcam(frame, gains_bgr=(0.7, 0.9, 1.1))
    back = balance(shifted, median_bgr(frame))
    assert np.abs(np.median(back.reshape(-1, 3), axis=0) - median_bgr(frame)).max() <= 1.0
    assert np.percentile(np.abs(back.astype(int) - frame.astype(int)), 95) <= 3


def test_lookup_table_agrees_with_the_model() -> None:
    """The classifier's table gives each pixel the code of the nearest colour whose model
    accepts its cell's centre (6 bits a channel), with and without gains, on 20 000
    random colours."""
    red = fit_colour(lab_of(np.array([[40, 40, 200], [50, 45, 190], [35, 30, 210]], np.uint8)))
    blue = fit_colour(lab_of(np.array([[200, 90, 30], [190, 80, 40]], np.uint8)))
    classifier = LearnedClassifier({1: red, 2: blue})
    px = np.random.default_rng(3).integers(0, 256, (1, 20_000, 3), dtype=np.uint8)
    for gain in (None, np.array([0.8, 1.0, 1.3])):
        codes = classifier.classify(px, gain)[0]
        scaled = px[0] if gain is None else np.clip(np.round(px[0] * gain), 0, 255)
        centre = (scaled.astype(int) >> 2) * 4 + 1.5
        flat = (centre / 255.0).astype(np.float32).reshape(1, -1, 3)
        lab = cv2.cvtColor(flat, cv2.COLOR_BGR2Lab).reshape(-1, 3).astype(float)
        clipped = clipped_bgr(centre)
        d = [
            np.where(accepts(m, lab, clipped), distance(m, lab, clipped), np.inf)
            for m in (red, blue)
        ]
        want = np.where(np.isfinite(np.minimum(*d)), np.where(d[0] <= d[1], 1, 2), 0)
        assert (codes == want).all()
        assert (codes == 1).any() and (codes == 2).any() and (codes == 0).any()
        # a frame of one pixel, of a row, of a column (OpenCV takes 4 bytes for a Scalar)
        for j in (*np.flatnonzero(want == 1)[:3], *np.flatnonzero(want == 2)[:3]):
            one = px[:, j : j + 1]
            assert classifier.classify(one, gain)[0, 0] == want[j]
            assert classifier.classify_with_highlights(one, gain)[0, 0] == want[j]
        assert (classifier.classify(px[:, :5].reshape(5, 1, 3), gain)[:, 0] == want[:5]).all()
    # wider than one remap takes (32,767 px): classified in tiles, each pixel as alone
    wide = np.tile(px[:, :4], (1, 10_000, 1))  # (1, 40 000, 3)
    assert (
        classifier.classify(wide)[0] == np.tile(classifier.classify(px[:, :4])[0], 10_000)
    ).all()
    assert (
        classifier.classify(wide.transpose(1, 0, 2))[:, 0] == classifier.classify(wide)[0]
    ).all()


def test_overlapping_colours_get_the_nearest_in_every_cell_and_share_one_table() -> None:
    """Six wide colours that overlap (two without a lightness of their own): every one of
    the table's 2^18 cells, classified as a pixel at its centre, gets the code of the
    nearest colour that accepts it. Classifiers of the same colours share one table,
    which cannot be written."""
    rng = np.random.default_rng(20261201)
    models = {}
    for code in range(1, 7):
        c, h = rng.uniform(15, 70), rng.uniform(-np.pi, np.pi)
        saa, sbb = rng.uniform(40, 300, 2)
        lo = rng.uniform(6, 40)
        models[code] = LearnedColour(
            ab_mean=(c * np.cos(h), c * np.sin(h)),
            ab_cov=(saa, 0.5 * np.sqrt(saa * sbb) * rng.uniform(-1, 1), sbb),
            lightness=(lo, min(100.0, lo + rng.uniform(30, 60))),
            chroma_min=rng.uniform(12, 40),
            chroma_lightness=None if code % 3 == 0 else rng.uniform(30, 70),
        )
    levels = np.arange(64) * 4 + 1.5
    centre = np.stack(np.meshgrid(levels, levels, levels, indexing="ij"), -1).reshape(-1, 3)
    px = np.floor(centre).astype(np.uint8).reshape(1, -1, 3)  # each in its own cell
    flat = (centre / 255.0).astype(np.float32).reshape(1, -1, 3)
    lab = cv2.cvtColor(flat, cv2.COLOR_BGR2Lab).reshape(-1, 3).astype(float)
    clipped = clipped_bgr(centre)
    d = np.stack(
        [
            np.where(accepts(m, lab, clipped), distance(m, lab, clipped), np.inf)
            for m in models.values()
        ]
    )
    want = np.where(np.isfinite(d.min(axis=0)), d.argmin(axis=0) + 1, 0)
    classifier = LearnedClassifier(models)
    assert (classifier.classify(px)[0] == want).all()
    assert len(np.unique(want)) == 7  # every colour wins somewhere, and none
    again = LearnedClassifier({k: m.model_copy() for k, m in models.items()})
    assert again._table is classifier._table
    with pytest.raises(ValueError, match="read-only"):
        again._table[0, 0] = 1


def test_chroma_floor_is_at_equal_lightness() -> None:
    """The chroma floor scales with L* + 16: a pastel of the hue (lighter, less coloured)
    is out, a darker shade of it in; without ``chroma_lightness`` the floor is flat."""
    scaled = LearnedColour(
        ab_mean=(50.0, 30.0),
        ab_cov=(100.0, 0.0, 100.0),
        lightness=(10.0, 95.0),
        chroma_min=38.0,
        chroma_lightness=50.0,
    )
    flat = scaled.model_copy(update={"chroma_lightness": None})
    unit = np.array([50.0, 30.0]) / np.hypot(50.0, 30.0)
    pastel = np.array([75.0, *(45.0 * unit)])  # chroma 45 < 38 · 91/66
    shade = np.array([30.0, *(32.0 * unit)])  # chroma 32 > 38 · 46/66, < 38
    assert not accepts(scaled, pastel) and accepts(flat, pastel)
    assert accepts(scaled, shade) and not accepts(flat, shade)
    # the floor is never under grey's chroma, however dark
    wide = scaled.model_copy(update={"ab_cov": (900.0, 0.0, 900.0), "lightness": (0.0, 95.0)})
    assert not accepts(wide, [2.0, *(11.0 * unit)])  # 38 · 18/66 = 10.4, but 11 < 12
    assert accepts(wide, [2.0, *(13.0 * unit)])
    samples = lab_of(np.array([[40, 40, 200], [50, 45, 190], [35, 30, 210]], np.uint8))
    assert fit_colour(samples).chroma_lightness == pytest.approx(np.median(samples[:, 0]))


def _srgb_dimmed(bgr: tuple[int, int, int], light: float) -> np.ndarray:
    """An 8-bit sRGB colour with its linear light times ``light`` (the sRGB curve), (3,)."""
    c = np.asarray(bgr, dtype=float) / 255.0
    linear = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4) * light
    out = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * linear ** (1 / 2.4) - 0.055)
    return np.round(np.clip(out, 0.0, 1.0) * 255).astype(np.uint8)


def test_a_shaded_face_is_measured_at_the_samples_lightness() -> None:
    """Dimming the light scales a*, b* and L* + 16 alike, so a colour is measured at its
    samples' lightness: the taught blue in shade (its light × 0.5, × 0.3) is at the
    ellipse's centre where, measured as it is, it is out; a pastel (lighter, less
    coloured) is farther than it looks; a brighter pixel with a channel clipped is
    measured as it is (the clipping took its chroma), a darker one never is."""
    blue = (200, 60, 40)
    model = fit_colour(lab_of(np.array([blue] * 3, np.uint8)))
    as_is = model.model_copy(update={"chroma_lightness": None})
    for light in (0.5, 0.3):
        shade = lab_of(_srgb_dimmed(blue, light))
        assert distance(model, shade) < 0.5 < model.max_distance < distance(as_is, shade)
        assert accepts(model, shade) and not accepts(as_is, shade)
    lighter = model.chroma_lightness + 30.0
    pastel = np.array([lighter, *(0.8 * np.array(model.ab_mean))])
    assert distance(model, pastel) > distance(as_is, pastel)
    assert distance(model, pastel, clipped=True) == pytest.approx(distance(as_is, pastel))
    darker = np.array([model.chroma_lightness - 20.0, *(0.8 * np.array(model.ab_mean))])
    assert distance(model, darker, clipped=True) == pytest.approx(distance(model, darker))
    assert distance(model, darker) < distance(as_is, darker)
    assert clipped_bgr(np.array([[255, 10, 10], [251, 251, 251], [252, 0, 0]])).tolist() == [
        True,
        False,
        True,
    ]


def test_more_coloured_pixels_of_the_hue_are_the_colour() -> None:
    """The ellipse is open outwards along the hue: a more vivid pixel of the taught hue is
    the colour however vivid, a pixel as vivid 30° off the hue is not, and a duller one is
    measured as it is (the ellipse still bounds it)."""
    model = LearnedColour(
        ab_mean=(40.0, 0.0), ab_cov=(25.0, 0.0, 25.0), lightness=(10.0, 95.0), chroma_min=12.0
    )

    def at(c: float, hue_deg: float) -> np.ndarray:
        h = np.radians(hue_deg)
        return np.array([50.0, c * np.cos(h), c * np.sin(h)])

    assert distance(model, at(90.0, 0.0)) == pytest.approx(0.0, abs=1e-9)
    assert accepts(model, at(90.0, 0.0)) and accepts(model, at(90.0, 15.0))
    assert distance(model, at(90.0, 15.0)) == pytest.approx(distance(model, at(40.0, 15.0)))
    assert not accepts(model, at(90.0, 30.0))  # 40·sin 30° = 20 = 4σ off: another hue
    assert not accepts(model, at(24.0, 0.0))  # duller: 16 under the centre, 3.2σ (floor 12)
    assert distance(model, at(30.0, 0.0)) == pytest.approx(2.0)  # measured as it is
    # a centre too faint to have a hue is measured as it is, outwards too
    faint = model.model_copy(update={"ab_mean": (8.0, 0.0), "chroma_min": 0.0})
    assert distance(faint, at(28.0, 0.0)) == pytest.approx(4.0)


def test_a_dull_class_beside_a_vivid_one_is_not_one_colour() -> None:
    """Two classes are refused as sampled on one colour by their ellipses closed all round:
    a dull green open outwards reaches a vivid yellow-green's centre (distance < 1 along
    its hue), yet they were sampled on colours 5 σ apart, and teaching takes both."""

    def at(c: float, hue_deg: float) -> tuple[float, float]:
        h = np.radians(hue_deg)
        return (c * np.cos(h), c * np.sin(h))

    green = LearnedColour(
        ab_mean=at(23.0, 140.0), ab_cov=(100.0, 0.0, 100.0), lightness=(10.0, 95.0)
    )
    yellow = LearnedColour(
        ab_mean=at(70.0, 115.0), ab_cov=(100.0, 0.0, 100.0), lightness=(10.0, 95.0)
    )
    centre = np.array([50.0, *yellow.ab_mean])
    assert distance(green, centre) < 1.0 < 4.0 < ellipse_distance(green, centre)
    clicks = [Sample("green", 10.0, 10.0), Sample("yellow", 20.0, 20.0)]
    _refuse_shared({"green": green, "yellow": yellow}, clicks)  # no SampleError
    with pytest.raises(SampleError, match="sampled on the same colour"):
        _refuse_shared({"green": green, "yellow": green}, clicks)


def test_a_click_on_a_speck_teaches_the_objects_colour() -> None:
    """A click on a dot no larger than the pointer (a printed mark, a glint) teaches the
    object's colour, as a click beside it does; a patch wider than the pointer is what
    the user clicked, and is taught."""

    def dotted(radius_px: float, names: tuple[str, ...]) -> np.ndarray:
        frame = render().copy()
        yy, xx = np.mgrid[0:480, 0:640]
        for s in (s for s in one_click_each() if s.name in names):
            frame[(xx - s.u_px) ** 2 + (yy - s.v_px) ** 2 <= radius_px**2] = PURPLE_BGR
        return frame

    for radius in (4.0, 15.0):  # the default, and a wide one (evenly spaced candidates)
        clean = teach([render()], one_click_each(), radius_px=radius).colours
        specked = teach([dotted(1.0, tuple(clean))], one_click_each(), radius_px=radius).colours
        for name, colour in clean.items():
            assert np.hypot(*np.subtract(specked[name].ab_mean, colour.ab_mean)) < 2.0, name
    purple = lab_of(np.array([[PURPLE_BGR]], np.uint8))[0, 0, 1:]
    patched = teach([dotted(3.0, ("red",))], one_click_each()).colours
    assert np.hypot(*np.subtract(patched["red"].ab_mean, purple)) < 2.0


def test_area_mask_is_the_polygon() -> None:
    """The work area's mask is its polygon's inside; ``None`` is the whole frame."""
    m = area_mask([(10, 10), (29, 10), (29, 19), (10, 19)], (40, 50))
    assert m[15, 20] == 255 and m[5, 5] == 0 and m.sum() == 255 * 20 * 10
    assert area_mask(None, (4, 5)).min() == 255


def test_shipped_bands_are_unchanged_without_learned_colours() -> None:
    """A config without learned colours, reference or work area classifies as before."""
    det = ColorDetector(CONFIG.vision, CAL, CONFIG.task.classes)
    assert det.learned is None and det.work_area((480, 640)) is None
    found_exactly(det, render())


def test_learned_colour_validation() -> None:
    """A covariance that is not one, or an empty lightness range, is a config error."""
    with pytest.raises(ValueError, match="positive definite"):
        LearnedColour(ab_mean=(1, 2), ab_cov=(1.0, 2.0, 1.0), lightness=(10, 90))
    with pytest.raises(ValueError, match="lo must be below hi"):
        LearnedColour(ab_mean=(1, 2), ab_cov=(1.0, 0.0, 1.0), lightness=(90, 10))
    with pytest.raises(ValueError, match="work_area_px"):
        Config.model_validate({"vision": {"work_area_px": [[0, 0], [1, 1]]}})
    assert VisionConfig().reference_bgr is None


@pytest.mark.parametrize("brighter", [1.0, 1.2])
def test_a_blown_out_top_is_found_whole(brighter: float) -> None:
    """An object whose middle is blown out to a tinted white is one region of its full
    area, centred; the same white alone on the table is no object. Also in a frame
    brighter than the taught one: there the gains are below 1 and took the clipped red
    under the clip, and the top read as grey (0.6 of the area, before)."""
    frame = np.clip(np.round(render() * brighter), 0, 255).astype(np.uint8)
    _, x, y = LAYOUT[0]  # a red object
    (u, v), = CAL.table_to_pixel(np.array([[x, y]]))  # fmt: skip
    yy, xx = np.mgrid[0:480, 0:640]
    frame[(xx - u) ** 2 + (yy - v) ** 2 <= 10**2] = (238, 242, 255)  # clipped red, faint tint
    frame[(xx - 40) ** 2 + (yy - 440) ** 2 <= 10**2] = (238, 242, 255)  # the same, alone
    det = taught_detector()
    whole = next(d for d in det.detect(render()) if np.hypot(*(d.centroid_px - (u, v))) < 2)
    found = det.detect(frame)
    assert match_detections(found, LAYOUT, CAL) is not None and len(found) == len(LAYOUT)
    blown = next(d for d in found if np.hypot(*(d.centroid_px - (u, v))) < 2)
    assert blown.area_px >= 0.95 * whole.area_px
    plain = LearnedClassifier(det.learned.models).classify(frame)  # type: ignore[union-attr]
    assert plain[round(v), round(u)] == 0  # the white itself is no colour


#: A top blown out to a tint of its class (B, G, R): red, yellow and green are found whole,
#: blue's tint is under the highlights' chroma.
BLOWN_TINT = {"red": (238, 242, 255), "yellow": (225, 255, 255), "green": (240, 255, 244),
              "blue": (255, 246, 236)}  # fmt: skip


def test_a_brighter_frame_reads_each_blown_out_top_as_the_taught_exposure_does() -> None:
    """Every object of the scene, its top blown out to a tint of its class: in frames 15,
    25 and 35 % brighter the detection keeps the area it has at the taught exposure (the
    gains below 1 took the clipped channel under the clip: about 0.74 of it, before)."""
    det = taught_detector()
    base = render()
    clean = det.detect(base)
    yy, xx = np.mgrid[0:480, 0:640]
    whole = 0
    for color, x, y in LAYOUT:
        (u, v), = CAL.table_to_pixel(np.array([[x, y]]))  # fmt: skip
        unharmed = min(clean, key=lambda d: np.hypot(*(d.centroid_px - (u, v)))).area_px
        top = (xx - u) ** 2 + (yy - v) ** 2 <= 8**2
        area = []
        for brighter in (1.0, 1.15, 1.25, 1.35):
            frame = np.clip(np.round(base * brighter), 0, 255).astype(np.uint8)
            frame[top] = BLOWN_TINT[color]
            found = det.detect(frame)
            assert match_detections(found, LAYOUT, CAL) is not None and len(found) == len(LAYOUT)
            area.append(min(found, key=lambda d: np.hypot(*(d.centroid_px - (u, v)))).area_px)
        assert max(area) - min(area) <= 0.02 * area[0], (color, area)
        whole += area[0] >= 0.95 * unharmed
    assert whole == 8  # the reds, greens and yellows whole; the blues' faint tint is not
