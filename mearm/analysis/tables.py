"""An analysis as tables with the paper's figures beside ours, in plain text or Markdown."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from mearm.analysis import paper
from mearm.analysis.paths import SolvedRoute
from mearm.analysis.run_analysis import Analysis
from mearm.analysis.success import Rate

DASH = "—"


@dataclass(frozen=True)
class Table:
    """A titled table of strings, rendered by :func:`render_text` or :func:`render_markdown`."""

    title: str
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    notes: tuple[str, ...] = ()


def _num(value: float | None, digits: int = 4) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return DASH
    return f"{value:.{digits}f}"


def _pct(rate: Rate) -> str:
    if not rate.n:
        return DASH
    return f"{100 * rate.rate:.2f} % ({rate.successes}/{rate.n})"


def render_text(table: Table) -> str:
    """Fixed-width text: title, header, rule, rows, notes."""
    cells = [table.header, *table.rows]
    widths = [max(len(row[i]) for row in cells) for i in range(len(table.header))]

    def line(row: Sequence[str]) -> str:
        first = row[0].ljust(widths[0])
        rest = (c.rjust(w) for c, w in zip(row[1:], widths[1:], strict=True))
        return "  ".join([first, *rest]).rstrip()

    out = [table.title, line(table.header), "  ".join("-" * w for w in widths)]
    out += [line(r) for r in table.rows]
    out += [f"  {n}" for n in table.notes]
    return "\n".join(out)


def render_markdown(table: Table) -> str:
    """A Markdown table under a bold title, notes as a list."""
    out = [f"**{table.title}**", ""]
    out.append("| " + " | ".join(table.header) + " |")
    out.append("|" + "|".join(["---"] + ["---:"] * (len(table.header) - 1)) + "|")
    out += ["| " + " | ".join(r) + " |" for r in table.rows]
    if table.notes:
        out.append("")
        out += [f"- {n}" for n in table.notes]
    return "\n".join(out)


def _selection(a: Analysis) -> str:
    which = {"all": "picks and places", "pick": "picks", "place": "places"}[a.step]
    return f"{a.table8.n} routes ({which}{', first attempts' if a.first_attempt else ''})"


def table8(a: Analysis) -> Table:
    """Table 8: per-axis and Euclidean error, ours and the paper's."""
    rows = []
    for name, m in a.table8.rows().items():
        ours = [_num(v) for v in m.as_tuple()]
        theirs = [f"{v:g}" for v in paper.TABLE8_CM[name]]
        rows.append((name, *ours, *theirs))
    return Table(
        title=f"Table 8: final EE error ee − target [cm], {_selection(a)}",
        header=(
            "",
            "mean",
            "std",
            "max",
            "min",
            "paper mean",
            "paper std",
            "paper max",
            "paper min",
        ),
        rows=tuple(rows),
        notes=(
            f"paper: the real arm, {paper.TABLE8_ROUTES} routes (paper §5); std is the "
            "sample std (ddof = 1)",
        ),
    )


def grip_table(a: Analysis) -> Table | None:
    """The picks' error when the jaws close, the arm settled (``None``: not in the log)."""
    if a.grip is None:
        return None
    rows = [(name, *(_num(v) for v in m.as_tuple())) for name, m in a.grip.rows().items()]
    return Table(
        title=f"Picks when the jaws close: TCP − target [cm], {a.grip.n} picks",
        header=("", "mean", "std", "max", "min"),
        rows=tuple(rows),
        notes=(
            "the arm settled, the tool's hold done (Table 8 takes each route's TCP on "
            "arrival, within a degree of each servo's command)",
        ),
    )


def weibull_table(a: Analysis) -> Table:
    """The Weibull fit and its goodness of fit, ours and the paper's."""
    fit = a.weibull
    if fit is None:
        return Table(
            "Weibull fit of the Euclidean xyz error",
            ("", "this run", "paper"),
            (("fit", a.weibull_problem or DASH, DASH),),
        )
    rows = (
        ("shape k", _num(fit.shape), f"{paper.WEIBULL_SHAPE:g}"),
        ("scale λ [cm]", _num(fit.scale), f"{paper.WEIBULL_SCALE_CM:g}"),
        ("errors fitted", str(fit.n), str(paper.TABLE8_ROUTES)),
        ("KS statistic D", _num(fit.ks_statistic), DASH),
        ("KS p-value", _num(fit.ks_pvalue, 3), DASH),
        ("Q-Q R²", _num(fit.qq_r2), DASH),
    )
    return Table(
        title="Weibull fit of the Euclidean xyz error (scipy weibull_min, location 0)",
        header=("", "this run", "paper"),
        rows=rows,
        notes=("the KS p-value uses parameters fitted to the same data, so it is optimistic",),
    )


def table9(a: Analysis) -> Table:
    """Table 9: first-attempt success per class, ours and the paper's (by class name)."""
    t = a.table9
    rows = [
        (
            name,
            _pct(t.pick[name]),
            f"{paper.TABLE9_PICK_PERCENT[name]:.2f} %"
            if name in paper.TABLE9_PICK_PERCENT
            else DASH,
            _pct(t.place[name]),
            f"{paper.TABLE9_PLACE_PERCENT:.2f} %",
        )
        for name in t.pick
    ]
    rows.append(
        (
            "total",
            _pct(t.pick_total),
            f"{paper.TABLE9_PICK_TOTAL_PERCENT:.2f} %",
            _pct(t.place_total),
            f"{paper.TABLE9_PLACE_PERCENT:.2f} %",
        )
    )
    return Table(
        title="Table 9: first-attempt success per class",
        header=("", "pick", "paper pick", "place", "paper place"),
        rows=tuple(rows),
        notes=(
            f"skipped objects: {a.skips} (never attempted or retries exhausted)",
            *(
                [
                    f"faults: {a.faults} (each stopped its run or trial: the objects it left "
                    "were not attempted, and no table here counts them)"
                ]
                if a.faults
                else []
            ),
            *(
                [
                    f"twin faults that struck: {a.twin_faults} in {a.twin_fault_trials} "
                    f"trial{'' if a.twin_fault_trials == 1 else 's'} (twin.faults, injected; "
                    "simulated)"
                ]
                if a.twin_faults
                else []
            ),
        ),
    )


def success_table(a: Analysis) -> Table:
    """Success against error, ours and the paper's."""
    from scipy import stats

    s = a.success
    attempts = "first-attempt picks" if a.attempts == "first" else "pick attempts"
    if s is None:
        return Table(
            "Pick success against error", ("", "this run", "paper"), ((attempts, "0", DASH),)
        )
    has_bound = s.bound_cm is not None
    r = a.around_bound
    fit = a.weibull
    paper_fit = stats.weibull_min(paper.WEIBULL_SHAPE, scale=paper.WEIBULL_SCALE_CM)
    paper_fit_below = 100 * float(paper_fit.cdf(paper.SUCCESS_BOUND_CM))
    bound = paper.SUCCESS_BOUND_CM
    rows = (
        (attempts, str(s.picks.n), str(paper.TABLE9_PICKS)),
        ("failed picks", str(s.picks.failures), str(paper.FAILED_PICKS)),
        ("every pick below [cm] succeeded", _num(s.bound_cm, 3), f"{bound:g}"),
        ("picks at or above it", str(s.above.n) if has_bound else DASH, DASH),
        ("  failed [%]", _num(100 * s.above.failure_rate, 2) if has_bound else DASH, DASH),
        ("routes at or above it", str(r.above) if r else DASH, str(paper.PICKS_ABOVE_BOUND)),
        (
            "  failed picks / those routes [%]",
            _num(100 * r.failed_share_above, 2) if r else DASH,
            f"{paper.FAILURE_ABOVE_PERCENT:.2f}",
        ),
        (
            "P(error < bound), share of routes [%]",
            _num(100 * r.empirical_p_below, 2) if r else DASH,
            f"{paper.P_BELOW_BOUND_PERCENT:.2f}",
        ),
        (
            "P(error < bound), fitted [%]",
            _num(100 * s.p_below, 2) if s.p_below is not None else DASH,
            f"{paper_fit_below:.2f}",
        ),
        (
            f"P(error < {bound:g} cm), fitted [%]",
            _num(100 * fit.prob_below(bound), 2) if fit else DASH,
            f"{paper_fit_below:.2f}",
        ),
        ("largest pick error [cm]", _num(s.max_error_cm, 3), DASH),
    )
    notes = [
        "bound = the smallest error of a failed pick (no failure, no bound); routes = the "
        "Table 8 routes, picks and places",
        f"paper: '{paper.FAILURE_ABOVE_PERCENT} % of {paper.PICKS_ABOVE_BOUND} picks failed' "
        f"and 'P = {paper.P_BELOW_BOUND_PERCENT} %' only add up over routes: "
        f"{paper.FAILED_PICKS} failed picks / {paper.PICKS_ABOVE_BOUND} routes, and "
        f"1 − {paper.PICKS_ABOVE_BOUND}/{paper.TABLE8_ROUTES}; its own Weibull fit gives "
        f"{paper_fit_below:.2f} % (its failed picks: 1 200 × 5.75 %)",
    ]
    if fit is None:
        notes.append("no Weibull fit, so no fitted probabilities")
    return Table("Pick success against error", ("", "this run", "paper"), rows, tuple(notes))


def table6(a: Analysis) -> Table:
    """Iterations and solver errors (the paper's Table 6 columns)."""
    rows = []
    for name, st in a.table6.items():
        statuses = ", ".join(f"{k} {v}" for k, v in sorted(st.statuses.items()))
        rows.append(
            (
                name,
                str(st.n),
                f"{st.iterations.mean:.1f} ({st.iterations.min:.0f}–{st.iterations.max:.0f})",
                _num(st.initial_error_cm.mean, 2),
                f"{st.final_error_cm.mean:.4f} ({st.final_error_cm.min:.4f}–"
                f"{st.final_error_cm.max:.4f})",
                statuses,
            )
        )
    lo, hi = paper.TABLE6_FINAL_ERROR_RANGE_CM
    rows.append(
        (
            "paper",
            str(paper.TABLE6_ROUTES),
            f"{paper.TABLE6_MEAN_ITERATIONS:.0f} ({paper.TABLE6_MIN_ITERATIONS}–"
            f"{paper.TABLE6_MAX_ITERATIONS})",
            f"{paper.TABLE6_MEAN_INITIAL_ERROR_CM:.2f}",
            f"{paper.TABLE6_MEAN_FINAL_ERROR_CM:.4f} ({lo:.4f}–{hi:.4f})",
            DASH,
        )
    )
    return Table(
        title="Table 6 columns: solver iterations and errors (ideal kinematics)",
        header=(
            "routes",
            "n",
            "iterations mean (min–max)",
            "initial error mean [cm]",
            "final error mean (min–max) [cm]",
            "status",
        ),
        rows=tuple(rows),
        notes=("paper: the 24 routes of its demo",),
    )


def failure_table(a: Analysis) -> Table | None:
    """Why routes failed, every attempt, by step; ``None`` when none failed."""
    if not a.failures:
        return None
    n = sum(f.routes for f in a.failures)
    return Table(
        title="Why routes failed (every attempt)",
        header=("why", "step", "routes"),
        rows=tuple((f.why, f.step, str(f.routes)) for f in a.failures),
        notes=(f"{n} of {a.routes} routes; where an object landed is left out of its reason",),
    )


def analysis_tables(a: Analysis) -> list[Table]:
    """All tables of an analysis, in the order of the report."""
    grip = grip_table(a)
    failures = failure_table(a)
    return [
        table8(a),
        *([] if grip is None else [grip]),
        weibull_table(a),
        table9(a),
        *([] if failures is None else [failures]),
        success_table(a),
        table6(a),
    ]


def gain_table(routes: Sequence[SolvedRoute], title: str) -> Table:
    """One row per gain: iterations, status, final error, largest detour from the line."""
    rows = tuple(
        (
            r.label,
            f"{r.kp:g}",
            f"{r.kd:g}",
            str(r.iterations),
            r.status,
            _num(r.final_error_cm),
            _num(r.path_deviation_cm, 3),
        )
        for r in routes
    )
    if routes:
        r0 = routes[0]
        start = ", ".join(f"{v:.4g}" for v in r0.ee_path_cm[0])
        target = ", ".join(f"{v:.4g}" for v in r0.target_cm)
        title = f"{title}: PD-PIJ, {r0.mode} mode, ({start}) → ({target}) cm"
    return Table(
        title=title,
        header=("", "kp", "kd", "iterations", "status", "final error [cm]", "largest detour [cm]"),
        rows=rows,
        notes=("detour = the EE path's largest distance from the straight start → target line",),
    )
