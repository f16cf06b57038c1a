"""The Weibull fit recovers a known distribution (paper §5: scale 0.7059 cm, shape 2.045)."""

from __future__ import annotations

import numpy as np
import pytest

from mearm.analysis import fit_weibull, route_errors_cm
from mearm.analysis import paper as P
from mearm.analysis.synthetic import weibull_error_vectors, write_synthetic_log
from mearm.exceptions import AnalysisError
from mearm.runlog import read_runlog


@pytest.mark.heavy
def test_fit_recovers_the_papers_weibull_from_a_2400_route_log(tmp_path) -> None:
    """Errors whose norms follow Weibull(2.045, 0.7059): the fit is within 5 % on both."""
    path = tmp_path / "trials.jsonl"
    write_synthetic_log(path, n_routes=2400, seed=0)
    contents = read_runlog(path)
    assert contents.complete and len(contents.routes) == 2400
    norms = np.linalg.norm(route_errors_cm(contents.routes), axis=1)
    fit = fit_weibull(norms)
    assert fit.n == 2400
    assert fit.shape == pytest.approx(P.WEIBULL_SHAPE, rel=0.05)
    assert fit.scale == pytest.approx(P.WEIBULL_SCALE_CM, rel=0.05)
    assert fit.ks_pvalue > 0.05 and fit.qq_r2 > 0.99


@pytest.mark.parametrize(
    ("shape", "scale", "seed"), [(1.2, 0.3, 1), (2.045, 0.7059, 2), (3.5, 1.5, 3)]
)
def test_fit_recovers_other_weibulls(shape: float, scale: float, seed: int) -> None:
    rng = np.random.default_rng(seed)
    norms = np.linalg.norm(weibull_error_vectors(2400, shape=shape, scale=scale, rng=rng), axis=1)
    fit = fit_weibull(norms)
    assert fit.shape == pytest.approx(shape, rel=0.05)
    assert fit.scale == pytest.approx(scale, rel=0.05)


def test_synthetic_error_lengths_follow_the_weibull() -> None:
    """The generator itself: the lengths pass a KS test against the true Weibull."""
    e = weibull_error_vectors(2400, shape=2.045, scale=0.7059, rng=np.random.default_rng(9))
    norms = np.linalg.norm(e, axis=1)
    from scipy import stats  # here, not at the top: every xdist worker collects this file

    assert stats.kstest(norms, "weibull_min", args=(2.045, 0, 0.7059)).pvalue > 0.05
    # directions are uniform: each axis has mean ≈ 0
    assert np.abs(e.mean(axis=0)).max() < 0.05


def test_goodness_of_fit_tells_weibull_from_not() -> None:
    """A uniform sample fits worse than a Weibull one: larger KS D, lower Q-Q R²."""
    rng = np.random.default_rng(4)
    good = fit_weibull(0.7059 * rng.weibull(2.045, size=2400))
    bad = fit_weibull(rng.uniform(0.01, 2.0, size=2400))
    assert bad.ks_statistic > 2 * good.ks_statistic
    assert bad.ks_pvalue < 1e-3 < good.ks_pvalue
    assert bad.qq_r2 < good.qq_r2


def test_probabilities_are_the_closed_form() -> None:
    r"""P(e < b) = 1 − exp(−(b/λ)^k), and the density integrates to it."""
    rng = np.random.default_rng(5)
    fit = fit_weibull(0.7059 * rng.weibull(2.045, size=500))
    for b in (0.3, 1.2, 2.0):
        expected = 1.0 - np.exp(-((b / fit.scale) ** fit.shape))
        assert fit.prob_below(b) == pytest.approx(expected, rel=1e-12)
        x = np.linspace(0.0, b, 20001)
        assert np.trapezoid(fit.pdf(x), x) == pytest.approx(expected, abs=1e-6)


def test_papers_own_fit_gives_948_percent_below_1_2_cm() -> None:
    """With the paper's shape and scale, P(e < 1.2 cm) is 94.82 %, not the printed 94.46 %."""
    from scipy import stats  # here, not at the top: every xdist worker collects this file

    d = stats.weibull_min(P.WEIBULL_SHAPE, scale=P.WEIBULL_SCALE_CM)
    assert 100 * d.cdf(P.SUCCESS_BOUND_CM) == pytest.approx(94.82, abs=0.01)


@pytest.mark.parametrize(
    ("errors", "pattern"),
    [
        ([0.5, 0.7], "at least 3"),
        ([0.5, 0.0, 0.7], "finite errors > 0; 1 of 3"),
        ([0.5, np.nan, 0.7, 0.1], "1 of 4"),
        ([0.5, -0.1, 0.7], "1 of 3"),
    ],
)
def test_bad_samples_are_refused(errors: list[float], pattern: str) -> None:
    with pytest.raises(AnalysisError, match=pattern):
        fit_weibull(errors)
