"""``report.md``: the tables and the plots of an analysis in one page, images linked relatively."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from mearm.analysis.paths import SolvedRoute
from mearm.analysis.run_analysis import Analysis
from mearm.analysis.tables import (
    failure_table,
    gain_table,
    render_markdown,
    success_table,
    table6,
    table8,
    table9,
    weibull_table,
)


def _image(images: Mapping[str, Path], key: str, alt: str, out_dir: Path) -> list[str]:
    if key not in images:
        return []
    return ["", f"![{alt}]({images[key].relative_to(out_dir).as_posix()})"]


def report_markdown(
    out_dir: Path,
    images: Mapping[str, Path],
    *,
    analysis: Analysis | None = None,
    rig: str | None = None,
    path_routes: Sequence[SolvedRoute] = (),
    gains_kp: Sequence[SolvedRoute] = (),
    gains_kd: Sequence[SolvedRoute] = (),
) -> str:
    """The report's Markdown.

    Args:
        out_dir: The folder the report is written to; image links are relative to it.
        images: PNG files by key (``histogram``, ``success``, ``path3d``, ``joints``,
            ``gains_kp``, ``gains_kd``).
        analysis: The log's analysis, if a log was analysed.
        rig: What produced the log, e.g. ``"simulated arm (servo backend 'sim')"``.
        path_routes: The routes re-solved for the path plots.
        gains_kp: The kp sweep.
        gains_kd: The kd sweep.
    """
    out: list[str] = []
    if analysis is not None:
        a = analysis
        out += [f"# Analysis of `{Path(a.source).name}`", ""]
        out.append(
            f"{a.trials} trials, {a.routes} routes, {a.skips} skipped objects, "
            f"{a.faults} faults. The paper's figures (paper §5) are its real arm's."
        )
        if rig:
            out += ["", f"Produced by: {rig}."]
        if a.problem is not None:
            out += [
                "",
                f"**The log is damaged:** line {a.problem.line}: {a.problem.reason}. "
                "Everything before that line is analysed.",
            ]
        out += ["", "## Final error", "", render_markdown(table8(a))]
        out += ["", render_markdown(weibull_table(a))]
        out += _image(images, "histogram", "final-error histogram with the Weibull fit", out_dir)
        out += ["", "## Success", "", render_markdown(table9(a))]
        failures = failure_table(a)
        if failures is not None:
            out += ["", render_markdown(failures)]
        out += ["", render_markdown(success_table(a))]
        out += _image(images, "success", "pick success against error", out_dir)
        out += ["", "## Iterations", "", render_markdown(table6(a))]
    if path_routes:
        names = " and ".join(f"`{r.label}`" for r in path_routes)
        out += [
            "",
            "## Paths",
            "",
            f"The first logged {names}, solved again with PD-PIJ on "
            "the ideal kinematics from the logged start joints (▲ marks where the arm "
            "really ended according to the log).",
        ]
        out += _image(images, "path3d", "3-D EE path of a pick and a place", out_dir)
        out += _image(images, "joints", "joint angles against iteration", out_dir)
    if gains_kp or gains_kd:
        out += ["", "## Gains", ""]
        if gains_kp:
            out += [render_markdown(gain_table(gains_kp, "Proportional gain kp"))]
            out += _image(images, "gains_kp", "error and EE path for several kp", out_dir)
        if gains_kd:
            out += ["", render_markdown(gain_table(gains_kd, "Derivative gain kd"))]
            out += _image(images, "gains_kd", "error and EE path for several kd", out_dir)
    if not out:
        out = ["# Analysis", "", "Nothing was analysed."]
    return "\n".join(out) + "\n"
