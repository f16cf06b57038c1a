"""A run log analysed as a whole: every statistic of paper §5 in one record.

:func:`analyze` turns what :func:`mearm.runlog.read_runlog` found into an
:class:`Analysis`; :func:`to_json` gives it as plain data. The tables beside the
paper's figures are in :mod:`mearm.analysis.tables`.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from mearm.analysis.errors import AnalysisError
from mearm.analysis.stats import (
    ErrorTable,
    IterationStats,
    Step,
    error_table,
    iteration_stats,
    route_errors_cm,
    select_routes,
)
from mearm.analysis.success import (
    Rate,
    RoutesAroundBound,
    SuccessTable,
    SuccessVsError,
    pick_outcomes,
    routes_around_bound,
    success_table,
    success_vs_error,
)
from mearm.analysis.weibull import WeibullFit, fit_weibull
from mearm.errors import MearmError
from mearm.runlog import RouteRecord, RunLogContents
from mearm.runlog.errors import RunLogFormatError


@dataclass(frozen=True)
class Analysis:
    """Everything measured on one run log.

    Attributes:
        source: The log file.
        problem: The log's first bad line, or ``None``: the analysis covers the records
            before it.
        trials: Trials (headers) read.
        routes: Route records read.
        skips: Skip records read.
        faults: Fault records read.
        step: Which routes Table 8 and the Weibull fit cover (``"all"``: picks and places).
        first_attempt: Whether they cover first attempts only.
        table8: Error statistics of those routes.
        weibull: Weibull fit of their Euclidean errors, or ``None`` (see ``weibull_problem``).
        weibull_problem: Why there is no fit.
        table9: First-attempt pick and place success per class.
        attempts: Which picks the success-against-error analysis covers.
        success: Success against error of those picks, or ``None`` when there are none.
        around_bound: The same bound counted over the Table 8 routes, the paper's way.
        table6: Iteration and solver-error statistics for all routes, picks and places.
        grip: Error statistics of the picks' TCP when the jaws close, the arm settled
            (``grip_ee_cm``), or ``None`` when the log has none.
        failures: The routes that ran, were checked and failed, every attempt, counted
            by step and why (:func:`failure_counts`), most first.
        twin_faults: The twin's injected faults (``twin.faults``) that struck, over the
            trials (their summaries' ``twin_faults``): those that stopped a trial, and
            those that struck and never mattered.
        twin_fault_trials: The trials in which one struck.
    """

    source: str
    problem: RunLogFormatError | None
    trials: int
    routes: int
    skips: int
    faults: int
    step: Step
    first_attempt: bool
    table8: ErrorTable
    weibull: WeibullFit | None
    weibull_problem: str | None
    table9: SuccessTable
    attempts: Literal["first", "all"]
    success: SuccessVsError | None
    around_bound: RoutesAroundBound | None
    table6: dict[str, IterationStats]
    grip: ErrorTable | None = None
    failures: tuple[FailureCount, ...] = ()
    twin_faults: int = 0
    twin_fault_trials: int = 0


@dataclass(frozen=True)
class FailureCount:
    """How many routes of a step failed for one reason.

    ``why`` is :data:`UNRECORDED` for a log older than the reasons.
    """

    step: str
    why: str
    routes: int


#: The reason counted for a failed route of a log written before routes said why.
UNRECORDED = "not recorded (a log older than the reasons)"
#: Where a released object landed: a place and its coordinates, left out of the count.
_AT_CM = re.compile(r" at \([^)]*\) cm")


def failure_counts(routes: Sequence[RouteRecord]) -> tuple[FailureCount, ...]:
    """The routes that ran, were checked and failed, counted by step and reason.

    A reason's coordinates (where a released object landed) are left out, so the
    objects that landed on the table count as one reason. Most first, then by step and
    reason. An unconfirmed route (a fault before its check) is no failure.
    """
    counts: dict[tuple[str, str], int] = {}
    for r in routes:
        if r.success or not r.confirmed:
            continue
        why = UNRECORDED if r.why_failed is None else _AT_CM.sub("", r.why_failed)
        counts[r.step, why] = counts.get((r.step, why), 0) + 1
    ranked = sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))
    return tuple(FailureCount(step, why, n) for (step, why), n in ranked)


def class_names(contents: RunLogContents) -> list[str]:
    """The class names of every trial's config (``task.class_names``), in order, once each.

    A header whose config does not load adds none: its classes then appear in the order
    the routes name them.
    """
    names: list[str] = []
    seen: set[str] = set()
    for trial in contents.trials:
        key = json.dumps(trial.header.config, sort_keys=True)
        if key in seen:  # loading a config validates the arm: once per distinct config
            continue
        seen.add(key)
        try:
            names += trial.header.load_config().task.class_names
        except MearmError:
            continue
    return list(dict.fromkeys(names))


def analyze(
    contents: RunLogContents,
    *,
    step: Step = "all",
    first_attempt: bool = False,
    attempts: Literal["first", "all"] = "first",
) -> Analysis:
    """Analyse a read run log.

    Args:
        contents: What :func:`~mearm.runlog.read_runlog` returned.
        step: Routes for Table 8 and the Weibull fit: ``"all"`` (the paper's 2 400
            picks and places), ``"pick"`` or ``"place"``.
        first_attempt: Table 8 and the fit over first attempts only.
        attempts: Picks for success against error: ``"first"`` (as Table 9) or ``"all"``.

    Raises:
        AnalysisError: No route matches ``step`` / ``first_attempt``.
    """
    routes = contents.routes
    chosen = select_routes(routes, step=step, first_attempt=first_attempt)
    if not chosen:
        what = "routes" if step == "all" else f"{step} routes"
        raise AnalysisError(
            f"{contents.path}: no {what}{' (first attempts)' if first_attempt else ''} "
            f"to analyse in {contents.lines_read} lines"
        )
    errors = route_errors_cm(chosen)
    norms = np.linalg.norm(errors, axis=1)
    weibull: WeibullFit | None
    try:
        weibull, weibull_problem = fit_weibull(norms), None
    except AnalysisError as exc:
        weibull, weibull_problem = None, str(exc)
    pick_errors, pick_success = pick_outcomes(routes, attempts=attempts)
    success = success_vs_error(pick_errors, pick_success, weibull) if pick_errors.size else None
    table6 = {
        name: iteration_stats(subset)
        for name in ("all", "pick", "place")
        if (subset := select_routes(routes, step=name))
    }
    return Analysis(
        source=str(contents.path),
        problem=contents.problem,
        trials=len(contents.trials),
        routes=len(routes),
        skips=len(contents.skips),
        faults=len(contents.faults),
        step=step,
        first_attempt=first_attempt,
        table8=error_table(errors),
        weibull=weibull,
        weibull_problem=weibull_problem,
        table9=success_table(routes, class_names(contents)),
        attempts=attempts,
        success=success,
        around_bound=routes_around_bound(norms, success) if success else None,
        table6=table6,
        grip=_grip_errors(routes, first_attempt=first_attempt),
        failures=failure_counts(routes),
        twin_faults=sum(len(t.twin_faults) for t in contents.trials),
        twin_fault_trials=sum(1 for t in contents.trials if t.twin_faults),
    )


def _grip_errors(routes: Sequence[RouteRecord], *, first_attempt: bool) -> ErrorTable | None:
    """The picks' errors when the jaws close (``grip_ee_cm − target_cm``), or ``None``."""
    picks = select_routes(routes, step="pick", first_attempt=first_attempt)
    errors = [np.subtract(r.grip_ee_cm, r.target_cm) for r in picks if r.grip_ee_cm is not None]
    return error_table(errors) if errors else None


def jsonable(value: Any) -> Any:
    """Dataclasses, numpy values and errors → JSON-ready data; ``nan`` and ``inf`` → ``None``."""
    if isinstance(value, Rate):
        return {
            "successes": value.successes,
            "n": value.n,
            "rate": jsonable(value.rate),
        }
    if isinstance(value, RoutesAroundBound):
        return {
            "routes": value.routes,
            "above": value.above,
            "failed_picks": value.failed_picks,
            "failed_share_above": jsonable(value.failed_share_above),
            "empirical_p_below": jsonable(value.empirical_p_below),
        }
    if isinstance(value, RunLogFormatError):
        return {"line": value.line, "reason": value.reason, "text": value.text}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        return jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def to_json(analysis: Analysis) -> dict[str, Any]:
    """The analysis as plain data, with the paper's figures under ``"paper"``."""
    from mearm.analysis import paper

    data = jsonable(analysis)
    data["paper"] = {
        "table8_cm": {
            k: dict(zip(("mean", "std", "max", "min"), v, strict=True))
            for k, v in paper.TABLE8_CM.items()
        },
        "weibull": {"shape": paper.WEIBULL_SHAPE, "scale": paper.WEIBULL_SCALE_CM},
        "table9_pick_percent": {
            **paper.TABLE9_PICK_PERCENT,
            "total": paper.TABLE9_PICK_TOTAL_PERCENT,
        },
        "table9_place_percent": paper.TABLE9_PLACE_PERCENT,
        "success_bound_cm": paper.SUCCESS_BOUND_CM,
        "failure_above_percent": paper.FAILURE_ABOVE_PERCENT,
        "picks_above_bound": paper.PICKS_ABOVE_BOUND,
        "p_below_bound_percent": paper.P_BELOW_BOUND_PERCENT,
        "table6": {
            "mean_iterations": paper.TABLE6_MEAN_ITERATIONS,
            "min_iterations": paper.TABLE6_MIN_ITERATIONS,
            "max_iterations": paper.TABLE6_MAX_ITERATIONS,
            "mean_initial_error_cm": paper.TABLE6_MEAN_INITIAL_ERROR_CM,
            "mean_final_error_cm": paper.TABLE6_MEAN_FINAL_ERROR_CM,
        },
    }
    return data
