r"""Weibull fit of the Euclidean xyz error (paper §5: scale 0.7059 cm, shape 2.045).

Two-parameter Weibull, location fixed at 0, fitted by maximum likelihood with
``scipy.stats.weibull_min.fit(errors, floc=0)``:

.. math:: f(e) = \frac{k}{\lambda} \left(\frac{e}{\lambda}\right)^{k-1} e^{-(e/\lambda)^k}

with shape :math:`k` and scale :math:`\lambda` [cm].
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from mearm.analysis.errors import AnalysisError

if TYPE_CHECKING:
    from scipy import stats

MIN_SAMPLES = 3


@dataclass(frozen=True)
class WeibullFit:
    """A fitted Weibull distribution and how well it fits.

    Attributes:
        shape: Shape k [-].
        scale: Scale λ [cm].
        n: Number of errors fitted.
        ks_statistic: Kolmogorov–Smirnov distance between the sample and the fit [-].
        ks_pvalue: Its p-value. The parameters come from the same sample, so this is
            optimistic (too high): read it as "no evidence against", never as proof.
        qq_r2: R² of the Weibull Q-Q plot (sorted errors against the fit's quantiles);
            1 for a perfect fit.
    """

    shape: float
    scale: float
    n: int
    ks_statistic: float
    ks_pvalue: float
    qq_r2: float

    @property
    def distribution(self) -> stats.rv_continuous:
        """The fitted ``scipy.stats.weibull_min`` (frozen)."""
        # scipy.stats costs ~1 s to import; every `import mearm.analysis` paid it.
        from scipy import stats

        return stats.weibull_min(self.shape, loc=0.0, scale=self.scale)

    def pdf(self, error_cm: npt.ArrayLike) -> np.ndarray:
        """Density at ``error_cm`` [1/cm]."""
        return np.asarray(self.distribution.pdf(error_cm), dtype=float)

    def cdf(self, error_cm: npt.ArrayLike) -> np.ndarray:
        """P(error ≤ ``error_cm``) [-]."""
        return np.asarray(self.distribution.cdf(error_cm), dtype=float)

    def prob_below(self, bound_cm: float) -> float:
        """P(error < ``bound_cm``) from the fitted density [-]."""
        return float(self.distribution.cdf(bound_cm))

    @property
    def mean(self) -> float:
        """Mean of the fitted distribution [cm]."""
        return float(self.distribution.mean())


def fit_weibull(errors_cm: npt.ArrayLike) -> WeibullFit:
    """Fit a two-parameter Weibull (location 0) to positive errors.

    Args:
        errors_cm: Euclidean errors [cm], (N,), N ≥ 3, all finite and > 0.

    Raises:
        AnalysisError: Too few errors, or some are zero, negative or not finite.
    """
    e = np.asarray(errors_cm, dtype=float).ravel()
    if e.size < MIN_SAMPLES:
        raise AnalysisError(f"a Weibull fit needs at least {MIN_SAMPLES} errors, got {e.size}")
    bad = ~np.isfinite(e) | (e <= 0)
    if bad.any():
        raise AnalysisError(
            f"a Weibull fit needs finite errors > 0; {int(bad.sum())} of {e.size} are not "
            f"(e.g. {e[bad][0]!r} cm)"
        )
    from scipy import stats  # lazy: see WeibullFit.distribution

    shape, _, scale = stats.weibull_min.fit(e, floc=0)
    ks = stats.kstest(e, "weibull_min", args=(shape, 0.0, scale))
    _, (_, _, r) = stats.probplot(e, sparams=(shape, 0.0, scale), dist="weibull_min")
    return WeibullFit(
        shape=float(shape),
        scale=float(scale),
        n=int(e.size),
        ks_statistic=float(ks.statistic),
        ks_pvalue=float(ks.pvalue),
        qq_r2=float(r) ** 2,
    )
