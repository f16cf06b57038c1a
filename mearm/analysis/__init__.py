"""Analysis of run logs: the paper's error, iteration and success statistics (paper §5).

Needs the ``analysis`` extra (SciPy; Matplotlib for :mod:`mearm.analysis.plots`).
"""

from mearm.analysis.stats import (
    ErrorTable,
    IterationStats,
    Moments,
    error_table,
    iteration_stats,
    route_errors_cm,
    select_routes,
)
from mearm.analysis.success import (
    Rate,
    SuccessTable,
    SuccessVsError,
    pick_outcomes,
    success_table,
    success_vs_error,
)
from mearm.analysis.weibull import WeibullFit, fit_weibull

__all__ = [
    "ErrorTable",
    "IterationStats",
    "Moments",
    "Rate",
    "SuccessTable",
    "SuccessVsError",
    "WeibullFit",
    "error_table",
    "fit_weibull",
    "iteration_stats",
    "pick_outcomes",
    "route_errors_cm",
    "select_routes",
    "success_table",
    "success_vs_error",
]
