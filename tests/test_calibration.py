"""Camera → table calibration: the paper's rig, fitting, degenerate point sets (paper §4)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mearm.config import CalibrationConfig, Config, load_config
from mearm.exceptions import CalibrationError
from mearm.vision import Calibration

ROOT = Path(__file__).resolve().parent.parent
LAB = Calibration.from_config(load_config(ROOT / "configs" / "lab.yaml").calibration)
LAYOUT_CM = np.array([(o.x, o.y) for o in Config().task.scene])  # (12, 2)
CORNERS_PX = np.array([[0.0, 0.0], [640.0, 0.0], [640.0, 480.0], [0.0, 480.0]])


def field_grid_px(n: int = 41) -> np.ndarray:
    u, v = np.meshgrid(np.linspace(0, 639, n), np.linspace(0, 479, n))
    return np.stack([u.ravel(), v.ravel()], axis=1)


def test_lab_calibration_is_the_papers_formula() -> None:
    """x = 0.0625·u − 20.5, y = 59.0 − 0.0625·v (paper §4)."""
    px = field_grid_px(9)
    expected = np.stack([0.0625 * px[:, 0] - 20.5, 59.0 - 0.0625 * px[:, 1]], axis=1)
    np.testing.assert_allclose(LAB.pixel_to_table(px), expected, atol=1e-12)
    np.testing.assert_allclose(LAB.table_to_pixel([-10.99, 49.70]), [152.16, 148.8], atol=1e-9)


def test_layout_round_trip_is_exact() -> None:
    """The 12 layout positions → pixels → table again, within 1e-9 cm."""
    back = LAB.pixel_to_table(LAB.table_to_pixel(LAYOUT_CM))
    assert np.abs(back - LAYOUT_CM).max() < 1e-9


def test_four_noisy_pairs_recover_the_rig() -> None:
    """4 corner pairs, 0.1 px and 0.01 cm of noise (50 draws): within 0.05 cm over the field.

    (Sub-pixel marker corners and a careful tape measure. The worst error over the field
    is 2-3x the noise of one pair: 0.3 px gives up to ~0.085 cm; see the README.)
    """
    grid = field_grid_px()
    truth = LAB.pixel_to_table(grid)
    worst = 0.0
    for seed in range(50):
        rng = np.random.default_rng(seed)
        px = CORNERS_PX + rng.normal(0.0, 0.1, CORNERS_PX.shape)
        cm = LAB.pixel_to_table(CORNERS_PX) + rng.normal(0.0, 0.01, CORNERS_PX.shape)
        fit = Calibration.fit(px, cm)
        worst = max(worst, float(np.linalg.norm(fit.pixel_to_table(grid) - truth, axis=1).max()))
        assert fit.reprojection_error_cm is not None and fit.reprojection_error_cm < 1e-4
    assert worst < 0.05


def test_many_pairs_report_their_residual() -> None:
    """With more than 4 pairs the RMS and max reprojection errors measure the noise."""
    rng = np.random.default_rng(1)
    px = rng.uniform([0, 0], [640, 480], (30, 2))
    cm = LAB.pixel_to_table(px) + rng.normal(0.0, 0.02, (30, 2))
    fit = Calibration.fit(px, cm)
    assert 0.01 < fit.reprojection_error_cm < 0.03
    assert fit.max_error_cm >= fit.reprojection_error_cm


def test_perspective_homography_is_recovered() -> None:
    """A tilted camera (projective H) is fitted from 4 exact pairs (OpenCV's solver: ~1e-7)."""
    H = LAB.H @ np.array([[1.0, 0.02, 3.0], [0.01, 1.0, -2.0], [1e-4, 2e-4, 1.0]])
    truth = Calibration(H)
    fit = Calibration.fit(CORNERS_PX, truth.pixel_to_table(CORNERS_PX))
    grid = field_grid_px()
    np.testing.assert_allclose(fit.pixel_to_table(grid), truth.pixel_to_table(grid), atol=1e-5)


@settings(max_examples=50, deadline=None)
@given(
    a=st.floats(-0.05, 0.05),
    b=st.floats(-0.05, 0.05),
    g=st.floats(-3e-4, 3e-4),
    h=st.floats(-3e-4, 3e-4),
)
def test_any_reasonable_homography_round_trips(a: float, b: float, g: float, h: float) -> None:
    """pixel → table → pixel is the identity to 1e-9 px for tilted cameras."""
    cal = Calibration(LAB.H @ np.array([[1.0, a, 0.0], [b, 1.0, 0.0], [g, h, 1.0]]))
    grid = field_grid_px(7)
    np.testing.assert_allclose(cal.table_to_pixel(cal.pixel_to_table(grid)), grid, atol=1e-9)


def test_pixel_area_matches_the_scale() -> None:
    """One pixel covers 0.0625² cm² in the lab rig; a 2 cm disc covers π·16² px."""
    np.testing.assert_allclose(LAB.pixel_area_cm2([[0, 0], [320, 240]]), 0.0625**2)
    np.testing.assert_allclose(LAB.expected_disc_area_px([[320, 240]], 2.0), np.pi * 256)


def test_pixel_area_is_the_jacobian_determinant() -> None:
    """|det J| of pixel → table by finite differences equals pixel_area_cm2 on a tilted rig."""
    cal = Calibration(LAB.H @ np.array([[1.0, 0.03, 0.0], [0.02, 1.0, 0.0], [2e-4, 1e-4, 1.0]]))
    for u, v in [(10.0, 20.0), (320.0, 240.0), (600.0, 450.0)]:
        e = 1e-4
        du = (cal.pixel_to_table([u + e, v]) - cal.pixel_to_table([u - e, v])) / (2 * e)
        dv = (cal.pixel_to_table([u, v + e]) - cal.pixel_to_table([u, v - e])) / (2 * e)
        det = abs(du[0] * dv[1] - du[1] * dv[0])
        assert cal.pixel_area_cm2([u, v])[0] == pytest.approx(det, rel=1e-6)


def test_config_round_trip() -> None:
    """to_config → from_config keeps H and the recorded error; shapes of inputs are kept."""
    fit = Calibration.fit(CORNERS_PX, LAB.pixel_to_table(CORNERS_PX) + 0.01)
    again = Calibration.from_config(fit.to_config())
    np.testing.assert_allclose(again.H, fit.H)
    assert again.reprojection_error_cm == fit.reprojection_error_cm
    assert LAB.pixel_to_table([1.0, 2.0]).shape == (2,)
    assert LAB.pixel_to_table(np.zeros((5, 2))).shape == (5, 2)


@pytest.mark.parametrize(
    ("px", "cm", "words"),
    [
        (CORNERS_PX[:3], CORNERS_PX[:3], "at least 4 point pairs, got 3"),
        ([], [], "shape \\(N, 2\\)"),
        (CORNERS_PX, CORNERS_PX[:3], "4 pixel points but 3 table points"),
        (
            [[0, 0], [100, 0], [100, 0], [0, 100]],
            CORNERS_PX,
            "pixel points 1 and 2 are the same point",
        ),
        (CORNERS_PX, [[0, 0], [1, 0], [1, 1], [1, 1]], "table points 2 and 3 are the same"),
        (
            [[0, 0], [100, 1], [200, 2], [300, 3], [400, 4]],
            np.ones((5, 2)),
            "all 5 pixel points lie on one line",
        ),
        ([[0, 0], [100, 0], [200, 0], [0, 100]], CORNERS_PX, "\\(0, 1, 2\\) lie on one line"),
        ([[0, 0], [1, np.nan], [2, 0], [0, 1]], CORNERS_PX, "must be finite"),
        ([["a", "b"]] * 4, CORNERS_PX, "must be numbers"),
    ],
)
def test_degenerate_point_sets_are_clear_errors(px, cm, words: str) -> None:
    """Fewer than 4, repeated, collinear, mismatched or non-finite points: CalibrationError."""
    with pytest.raises(CalibrationError, match=words) as info:
        Calibration.fit(px, cm)
    assert info.value.reason == str(info.value)


def test_mirrored_pairs_are_refused() -> None:
    """Pairs that need the horizon between them (swapped points) are an error."""
    cm = LAB.pixel_to_table(CORNERS_PX)
    swapped = cm[[0, 2, 1, 3]]  # a bow-tie: not a projective image of the rectangle
    with pytest.raises(CalibrationError, match="horizon"):
        Calibration.fit(CORNERS_PX, swapped)


def test_singular_homography_is_refused() -> None:
    """A singular or non-finite H cannot be a calibration."""
    with pytest.raises(CalibrationError, match="singular"):
        Calibration(np.array([[1.0, 0, 0], [2.0, 0, 0], [0, 0, 1.0]]))
    with pytest.raises(CalibrationError, match="finite 3x3"):
        Calibration(np.full((3, 3), np.inf))
    with pytest.raises(ValueError, match="singular"):
        CalibrationConfig(homography=((1, 0, 0), (2, 0, 0), (0, 0, 1)))
