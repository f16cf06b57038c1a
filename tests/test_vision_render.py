"""The sim table renderer: objects where the calibration puts them, light, noise, seeds."""

from __future__ import annotations

import numpy as np
import pytest

from mearm.config import Config
from mearm.exceptions import ConfigError
from mearm.sim import Disc, Extra, Highlight, Paper, Shadow, TableRenderer, class_bgr, class_discs
from mearm.vision import Calibration, ColorDetector
from mearm.vision.classify import hsv_exact

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
RED = CONFIG.task.class_named("red")


def test_disc_is_drawn_through_the_inverse_calibration() -> None:
    """On a noiseless, even table a disc's coloured pixels centre on table_to_pixel(x, y).

    Exactly for the paper's affine rig; a tilted camera shifts the image centroid of a
    disc off the image of its centre by a few hundredths of a pixel (perspective).
    """
    tilted = Calibration(CAL.H @ np.array([[1.0, 0.03, 0.0], [0.02, 1.0, 0.0], [2e-4, 1e-4, 1.0]]))
    for cal, tol in ((CAL, 0.005), (tilted, 0.1)):
        r = TableRenderer(cal, noise_std=0.0, gradient=0.0, table="grey")
        frame = r.render([Disc.of_class(RED, 5.3, 44.1)]).astype(float)
        redness = np.clip(frame[..., 2] - frame[..., 1], 0, None)  # 0 on grey
        v, u = np.indices(redness.shape)
        centre = np.array([(u * redness).sum(), (v * redness).sum()]) / redness.sum()
        np.testing.assert_allclose(centre, cal.table_to_pixel([5.3, 44.1]), atol=tol)


def test_brightness_and_gradient_scale_the_light() -> None:
    """Brightness multiplies every pixel; the gradient brightens towards the bottom right."""
    dim = TableRenderer(CAL, noise_std=0.0, gradient=0.0, brightness=0.5, table="grey").render([])
    full = TableRenderer(CAL, noise_std=0.0, gradient=0.0, brightness=1.0, table="grey").render([])
    assert np.abs(dim.astype(float) * 2 - full).max() <= 2.0
    ramp = TableRenderer(CAL, noise_std=0.0, gradient=0.3, table="grey").render([])
    light = ramp.astype(float) / full  # the light factor, texture divided out
    assert light[0, 0].mean() == pytest.approx(0.7, abs=0.01)
    assert light[-1, -1].mean() == pytest.approx(1.3, abs=0.01)
    assert light[240, 320].mean() == pytest.approx(1.0, abs=0.01)


def test_noise_has_the_configured_spread() -> None:
    """Two frames differ by noise of std √2·σ."""
    r = TableRenderer(CAL, noise_std=3.0, table="grey")
    diff = r.render([], 1).astype(float) - r.render([], 2).astype(float)
    assert diff.std() == pytest.approx(np.sqrt(2) * 3.0, rel=0.05)
    assert np.array_equal(r.render([], 5), r.render([], 5))


def test_highlight_washes_out_saturation() -> None:
    """A strong highlight on a disc leaves a hole in its mask but the centre holds."""
    hl = Highlight(0.3, 45.2, sigma_cm=0.2, strength=1.0)
    frame = TableRenderer(CAL, extras=[hl]).render([Disc.of_class(RED, 0.0, 45.0)])
    (d,) = ColorDetector.from_config(
        CONFIG.vision, CONFIG.calibration, CONFIG.camera, CONFIG.task.classes
    ).detect(frame)
    assert d.area_px < 780
    assert np.linalg.norm(CAL.pixel_to_table(d.centroid_px) - [0.0, 45.0]) < 0.1


def test_bad_table_name() -> None:
    with pytest.raises(ValueError, match="'wood' or 'grey'"):
        TableRenderer(CAL, table="marble")


def test_objects_are_drawn_in_their_class_colour_and_size() -> None:
    """A class's disc has its draw_rgb (BGR in the frame) and its diameter_cm."""
    r = TableRenderer(CAL, noise_std=0.0, gradient=0.0, table="grey")
    for name, diameter_cm in (("green", 2.0), ("blue", 3.5)):
        cls = CONFIG.task.class_named(name).model_copy(update={"diameter_cm": diameter_cm})
        frame = r.render(class_discs([cls], [(name, 0.0, 45.0)]))
        u, v = np.rint(CAL.table_to_pixel([0.0, 45.0])).astype(int)
        assert tuple(frame[v, u]) == class_bgr(cls)  # the centre is unshaded
        assert class_bgr(cls) == tuple(reversed(cls.draw_rgb))
        _, sat, _ = hsv_exact(frame)
        coloured = sat > 0.4  # the grey table and the disc's drop shadow have S ≈ 0
        radius_px = diameter_cm / 2 / 0.0625
        assert np.count_nonzero(coloured) == pytest.approx(np.pi * radius_px**2, rel=0.03)


def test_unknown_class_is_a_named_error() -> None:
    with pytest.raises(ConfigError, match="'purple': not a class \\(classes: red, green, blue\\)"):
        class_discs(CONFIG.task.classes, [("purple", 0.0, 45.0)])


@pytest.mark.heavy
def test_a_frame_is_its_discs_and_index_whatever_was_drawn_before() -> None:
    """A renderer keeps the table and each disc's patch: a frame drawn after other scenes
    (or after its caller wrote into an earlier frame) is the frame a new renderer draws."""
    extras: list[Extra] = [
        Paper(-8.0, 40.0, angle_deg=20.0),
        Shadow(3.0, 45.0),
        Highlight(1.0, 44.0),
        Disc((30, 200, 200), -4.0, 42.0),
    ]
    discs = class_discs(CONFIG.task.classes, [("red", 0.0, 45.0), ("blue", 5.0, 40.0)])
    for noise_std in (0.0, 2.0):
        kept = TableRenderer(CAL, extras=extras, noise_std=noise_std)
        first = kept.render(discs, 3)
        first[:] = 0
        kept.render(discs[:1], 4)
        kept.render([], 5)
        again = kept.render(discs, 3)
        fresh = TableRenderer(CAL, extras=extras, noise_std=noise_std).render(discs, 3)
        assert np.array_equal(again, fresh)


def test_an_unchanged_table_is_not_drawn_again() -> None:
    """Frames of the same discs differ only by their noise, drawn from the kept table."""
    r = TableRenderer(CAL)
    discs = class_discs(CONFIG.task.classes, [("green", 0.0, 45.0)])
    a, b = r.render(discs, 1), r.render(discs, 2)
    kept = r._clean  # the lit table before noise, drawn once for both frames
    assert r.render(list(discs), 3) is not None and r._clean is kept
    assert not np.array_equal(a, b)
    assert np.abs(a.astype(float) - b).max() <= 2 * 6 * r.noise_std
