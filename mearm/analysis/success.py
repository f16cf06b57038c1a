"""Pick and place success: the paper's Table 9 and success against error (paper §5).

The error of a route is the Euclidean distance between where the arm really ended and
the target, ‖ee − target‖, the error of Table 8 (not the solver's ideal final error).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from mearm.analysis.errors import AnalysisError
from mearm.analysis.stats import select_routes
from mearm.analysis.weibull import WeibullFit
from mearm.runlog import RouteRecord


@dataclass(frozen=True)
class Rate:
    """k successes out of n tries.

    Attributes:
        successes: Tries that succeeded.
        n: Tries.
    """

    successes: int
    n: int

    @property
    def failures(self) -> int:
        """Tries that failed."""
        return self.n - self.successes

    @property
    def rate(self) -> float:
        """Share of tries that succeeded, successes / n [-] (``nan`` when there were no tries)."""
        return self.successes / self.n if self.n else math.nan

    @property
    def failure_rate(self) -> float:
        """Share of tries that failed, failures / n [-] (``nan`` when there were no tries)."""
        return self.failures / self.n if self.n else math.nan

    @classmethod
    def of(cls, outcomes: Iterable[bool]) -> Rate:
        """Count the ``True`` outcomes."""
        flags = list(outcomes)
        return cls(successes=sum(1 for f in flags if f), n=len(flags))


@dataclass(frozen=True)
class SuccessTable:
    """Table 9: first-attempt success per class.

    Attributes:
        pick: First-attempt picks per class name, in the config's class order.
        pick_total: All classes together.
        place: First-attempt places per class name.
        place_total: All classes together.
    """

    pick: dict[str, Rate]
    pick_total: Rate
    place: dict[str, Rate]
    place_total: Rate


def success_table(routes: Iterable[RouteRecord], class_names: Sequence[str] = ()) -> SuccessTable:
    """First-attempt pick and place success per class (Table 9).

    Args:
        routes: The routes to count.
        class_names: The classes in their order (``config.task.class_names``); each gets
            a row even with no route. Classes that occur in the routes but not here are
            added after them, in order of appearance.
    """
    first = [r for r in routes if r.attempt == 1 and r.confirmed]
    order = list(dict.fromkeys([*class_names, *(r.color for r in first)]))

    def per_class(step: str) -> tuple[dict[str, Rate], Rate]:
        rows = [r for r in first if r.step == step]
        table = {name: Rate.of(r.success for r in rows if r.color == name) for name in order}
        return table, Rate.of(r.success for r in rows)

    pick, pick_total = per_class("pick")
    place, place_total = per_class("place")
    return SuccessTable(pick=pick, pick_total=pick_total, place=place, place_total=place_total)


@dataclass(frozen=True)
class ErrorBin:
    """Picks whose error is in [lo_cm, hi_cm)."""

    lo_cm: float
    hi_cm: float
    picks: Rate


@dataclass(frozen=True)
class SuccessVsError:
    """How pick success depends on the EE error.

    Attributes:
        picks: All picks analysed.
        bound_cm: The smallest error of a failed pick: every pick with a smaller error
            succeeded. ``None`` when no pick failed.
        above: The picks with error ≥ ``bound_cm``. Empty when no pick failed.
        p_below: P(error < ``bound_cm``) from the fitted Weibull density, or ``None``.
        max_error_cm: The largest pick error [cm].
        bins: Success per error bin, for the plot.
    """

    picks: Rate
    bound_cm: float | None
    above: Rate
    p_below: float | None
    max_error_cm: float
    bins: tuple[ErrorBin, ...]


def pick_outcomes(
    routes: Iterable[RouteRecord], *, attempts: Literal["first", "all"] = "first"
) -> tuple[np.ndarray, np.ndarray]:
    """Errors ‖ee − target‖ [cm], (N,), and success flags, (N,), of the picks.

    Raises:
        AnalysisError: ``attempts`` is not ``"first"`` or ``"all"``.
    """
    if attempts not in ("first", "all"):
        raise AnalysisError(f"attempts must be 'first' or 'all', got {attempts!r}")
    picks = [
        r
        for r in select_routes(routes, step="pick", first_attempt=attempts == "first")
        if r.confirmed  # a fault before the check: neither a success nor a failure
    ]
    errors = np.array([r.error_norm_cm for r in picks], dtype=float)
    success = np.array([r.success for r in picks], dtype=bool)
    return errors, success


def success_vs_error(
    errors_cm: Sequence[float] | np.ndarray,
    success: Sequence[bool] | np.ndarray,
    fit: WeibullFit | None = None,
    *,
    bin_width_cm: float = 0.1,
) -> SuccessVsError:
    """Where picks start to fail (paper §5: all picks under 1.2 cm succeeded).

    Args:
        errors_cm: Each pick's Euclidean error [cm], (N,).
        success: Whether each pick gripped its object, (N,).
        fit: The Weibull fit of the errors, for P(error < bound); ``None`` to skip it.
        bin_width_cm: Width of the error bins of :attr:`SuccessVsError.bins` [cm].

    Raises:
        AnalysisError: No picks, mismatched lengths, or a bin width that is not > 0.
    """
    e = np.asarray(errors_cm, dtype=float).ravel()
    ok = np.asarray(success, dtype=bool).ravel()
    if e.size == 0:
        raise AnalysisError("no picks: success against error needs at least one pick")
    if e.shape != ok.shape:
        raise AnalysisError(f"{e.size} errors but {ok.size} success flags")
    if not bin_width_cm > 0:
        raise AnalysisError(f"bin width must be > 0 cm, got {bin_width_cm!r}")
    failed = e[~ok]
    bound: float | None
    if failed.size:
        bound = float(failed.min())
        mask = e >= bound
        above = Rate(successes=int(ok[mask].sum()), n=int(mask.sum()))
        p_below = fit.prob_below(bound) if fit is not None else None
    else:
        bound, above, p_below = None, Rate(0, 0), None
    edges = np.arange(0.0, float(e.max()) + bin_width_cm, bin_width_cm)
    if edges.size < 2 or edges[-1] <= e.max():
        edges = np.append(edges, edges[-1] + bin_width_cm)
    index = np.digitize(e, edges) - 1
    bins = tuple(
        ErrorBin(
            lo_cm=float(edges[i]),
            hi_cm=float(edges[i + 1]),
            picks=Rate(successes=int(ok[index == i].sum()), n=int((index == i).sum())),
        )
        for i in range(edges.size - 1)
    )
    return SuccessVsError(
        picks=Rate(successes=int(ok.sum()), n=int(e.size)),
        bound_cm=bound,
        above=above,
        p_below=p_below,
        max_error_cm=float(e.max()),
        bins=bins,
    )


@dataclass(frozen=True)
class RoutesAroundBound:
    """The paper's way of counting around the bound: over all routes, picks and places.

    paper §5's "above 1.2 cm, 51.88 % of 133 picks failed" and "P(error < 1.2 cm) =
    94.46 %" only add up this way: 133 of its 2 400 routes are at or above 1.2 cm
    (1 − 133/2400 = 94.46 %, the empirical share, not the fitted density's 94.82 %),
    and its 69 failed picks (5.75 % of 1 200) are 51.88 % of those 133.

    Attributes:
        routes: Routes counted (picks and places).
        above: Routes with error ≥ the bound.
        failed_picks: Failed picks (all at or above the bound, by its definition).
    """

    routes: int
    above: int
    failed_picks: int

    @property
    def failed_share_above(self) -> float:
        """Failed picks / routes at or above the bound [-] (the paper's 51.88 %)."""
        return self.failed_picks / self.above if self.above else math.nan

    @property
    def empirical_p_below(self) -> float:
        """Share of routes below the bound [-] (the paper's 94.46 %)."""
        return 1.0 - self.above / self.routes if self.routes else math.nan


def routes_around_bound(
    route_errors_cm: Sequence[float] | np.ndarray, sve: SuccessVsError
) -> RoutesAroundBound | None:
    """Count routes around ``sve``'s bound the paper's way; ``None`` when there is no bound.

    Args:
        route_errors_cm: Euclidean errors of all routes, picks and places [cm], (N,).
        sve: The success-against-error analysis of the picks.
    """
    if sve.bound_cm is None:
        return None
    e = np.asarray(route_errors_cm, dtype=float).ravel()
    return RoutesAroundBound(
        routes=int(e.size), above=int((e >= sve.bound_cm).sum()), failed_picks=sve.picks.failures
    )
