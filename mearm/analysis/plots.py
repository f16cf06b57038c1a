"""The paper's analysis figures for any run, as PNG files (paper §5).

Figures are drawn on :class:`matplotlib.figure.Figure` objects with the Agg canvas, never
through ``pyplot``: no display is needed and no global state is touched. Matplotlib is
imported only when a figure is drawn.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from mearm.analysis import paper
from mearm.analysis.paths import SolvedRoute
from mearm.analysis.success import SuccessVsError
from mearm.analysis.weibull import WeibullFit
from mearm.errors import MearmError
from mearm.fileio import write_atomic

if TYPE_CHECKING:
    from matplotlib.figure import Figure

DPI = 120


def _figure(width_in: float, height_in: float) -> Figure:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _save(fig: Figure, path: str | Path, source: str | None = None) -> Path:
    """Write the figure as a PNG in one step (:func:`mearm.fileio.write_atomic`).

    Args:
        fig: The figure.
        path: PNG file to write.
        source: Where the figure's data came from (e.g. ``the simulated arm (…): not
            hardware``). Drawn above the figure and kept in the PNG's ``Source`` text
            field, so a simulated figure says so wherever the file goes.

    Raises:
        MearmError: The folder cannot be made or the file written.
    """
    p = Path(path)
    png = io.BytesIO()
    if source is not None:
        fig.suptitle(source, fontsize="small")
    fig.savefig(png, format="png", metadata={"Source": source} if source else None)
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(p, png.getvalue())
    except OSError as exc:
        raise MearmError(f"cannot write {p}: {exc}") from None
    return p


def error_histogram(
    errors_cm: npt.ArrayLike,
    fit: WeibullFit | None,
    path: str | Path,
    *,
    bins: int = 40,
    source: str | None = None,
) -> Path:
    """Histogram of the Euclidean errors with the fitted Weibull density (and the paper's).

    Args:
        errors_cm: Euclidean xyz errors [cm], (N,).
        fit: The Weibull fit of those errors, or ``None`` to draw the histogram alone.
        path: PNG file to write.
        bins: Histogram bins.
        source: Where the errors came from (simulated, hardware…), shown on the figure.
    """
    from scipy import stats

    e = np.asarray(errors_cm, dtype=float)
    fig = _figure(6.4, 4.2)
    ax = fig.add_subplot()
    ax.hist(
        e, bins=bins, density=True, color="#9ecae1", edgecolor="#3182bd", label=f"{e.size} routes"
    )
    x = np.linspace(0.0, max(float(e.max()), 2.2) * 1.05, 400)
    if fit is not None:
        ax.plot(
            x,
            fit.pdf(x),
            color="#de2d26",
            lw=2,
            label=f"Weibull fit: shape {fit.shape:.3f}, scale {fit.scale:.4f} cm",
        )
    paper_pdf = stats.weibull_min.pdf(x, paper.WEIBULL_SHAPE, scale=paper.WEIBULL_SCALE_CM)
    ax.plot(
        x,
        paper_pdf,
        color="black",
        ls="--",
        lw=1,
        label=f"paper: shape {paper.WEIBULL_SHAPE}, scale {paper.WEIBULL_SCALE_CM} cm",
    )
    ax.set_xlabel("Euclidean xyz error ‖ee − target‖ [cm]")
    ax.set_ylabel("density [1/cm]")
    title = "Final EE error"
    if fit is not None:
        title += f" (KS D = {fit.ks_statistic:.3f}, Q-Q R² = {fit.qq_r2:.4f})"
    ax.set_title(title)
    ax.legend(fontsize="small")
    return _save(fig, path, source)


def success_against_error(
    errors_cm: npt.ArrayLike,
    success: npt.ArrayLike,
    sve: SuccessVsError,
    path: str | Path,
    *,
    source: str | None = None,
) -> Path:
    """Pick success rate per error bin, each pick as a dot, and the bound below which all succeeded.

    Args:
        errors_cm: Each pick's Euclidean error [cm], (N,).
        success: Whether each pick gripped its object, (N,).
        sve: The analysis of the same picks.
        path: PNG file to write.
        source: Where the picks came from (simulated, hardware…), shown on the figure.
    """
    e = np.asarray(errors_cm, dtype=float)
    ok = np.asarray(success, dtype=bool)
    fig = _figure(6.4, 4.8)
    ax = fig.add_subplot()
    used = [b for b in sve.bins if b.picks.n]
    centers = [(b.lo_cm + b.hi_cm) / 2 for b in used]
    width = (used[0].hi_cm - used[0].lo_cm) * 0.9 if used else 0.1
    ax.bar(
        centers,
        [b.picks.rate * 100 for b in used],
        width=width,
        color="#a1d99b",
        edgecolor="#31a354",
        label="success rate per bin",
    )
    jitter = np.random.default_rng(0).uniform(-2.0, 2.0, size=e.size)
    ax.scatter(e[ok], 103 + jitter[ok], s=4, color="#31a354", alpha=0.5, label="pick gripped")
    ax.scatter(e[~ok], -3 + jitter[~ok], s=6, color="#de2d26", alpha=0.7, label="pick failed")
    if sve.bound_cm is not None:
        ax.axvline(
            sve.bound_cm,
            color="#de2d26",
            lw=1.5,
            label=f"all picks below {sve.bound_cm:.3f} cm succeeded",
        )
    ax.axvline(
        paper.SUCCESS_BOUND_CM,
        color="black",
        ls="--",
        lw=1,
        label=f"paper: {paper.SUCCESS_BOUND_CM} cm",
    )
    ax.set_xlabel("Euclidean xyz error of the pick [cm]")
    ax.set_ylabel("pick success [%]")
    ax.set_ylim(-8, 108)
    ax.set_title(f"Pick success against error ({sve.picks.n} picks, {sve.picks.failures} failed)")
    fig.legend(fontsize="small", loc="outside lower center", ncols=3)
    return _save(fig, path, source)


_PALETTE = ("#3182bd", "#e6550d", "#31a354", "#756bb1", "#636363", "#d6616b")
_LINESTYLES = ("-", "--", ":", "-.")


def _style(i: int) -> dict[str, str]:
    """Colour and line style of series ``i``: the colours first, then again dashed, ..."""
    return {
        "color": _PALETTE[i % len(_PALETTE)],
        "ls": _LINESTYLES[(i // len(_PALETTE)) % len(_LINESTYLES)],
    }


def _path_axes(ax: Any, routes: Sequence[SolvedRoute]) -> None:
    for i, route in enumerate(routes):
        style = _style(i)
        color = style["color"]
        p = route.ee_path_cm
        ax.plot(
            p[:, 0],
            p[:, 1],
            p[:, 2],
            **style,
            lw=1.5,
            label=f"{route.label} ({route.iterations} it.)",
        )
        ax.scatter(*p[0], color=color, marker="o", s=20)
        ax.scatter(*route.target_cm, color=color, marker="x", s=50)
        if route.logged_ee_cm is not None:
            ax.scatter(*route.logged_ee_cm, color=color, marker="^", s=30)
    ax.set_xlabel("x [cm]")
    ax.set_ylabel("y [cm]")
    ax.set_zlabel("z [cm]")
    ax.set_aspect("equal")  # centimetres are centimetres on every axis


def ee_paths_3d(
    routes: Sequence[SolvedRoute], path: str | Path, *, title: str, source: str | None = None
) -> Path:
    """The EE path of each route in 3-D: start ●, target ×, logged real end ▲.

    Args:
        routes: Solved routes, e.g. a pick and the place after it.
        path: PNG file to write.
        title: Figure title.
        source: Where the logged ends came from (simulated, hardware…), shown on the figure.
    """
    fig = _figure(6.4, 5.2)
    ax = fig.add_subplot(projection="3d")
    _path_axes(ax, routes)
    ax.set_title(f"{title}\n● start   × target   ▲ where the arm really ended (log)")
    ax.legend(fontsize="small")
    return _save(fig, path, source)


def joint_angles(
    routes: Sequence[SolvedRoute], path: str | Path, *, source: str | None = None
) -> Path:
    """Every joint [deg, or cm for a prismatic one] against iteration, one panel per route.

    Each joint is labelled by its name; the arm may have any number of joints. ``source``:
    the run the routes were logged by (simulated, hardware…), shown on the figure.
    """
    fig = _figure(6.4, 2.6 * len(routes) + 0.4)
    axes = fig.subplots(len(routes), 1, squeeze=False)[:, 0]
    for ax, route in zip(axes, routes, strict=True):
        values = route.joint_path
        units = route.joint_units
        for j, name in enumerate(route.joint_names):
            label = f"{name} [cm]" if units[j] == "cm" else name
            ax.plot(values[:, j], **_style(j), label=label)
        ax.set_title(f"{route.label}: {route.iterations} iterations, {route.status}")
        ax.set_ylabel("joint [" + " / ".join(dict.fromkeys(units)) + "]")
        ax.legend(fontsize="small", ncols=min(4, len(route.joint_names)))
    axes[-1].set_xlabel("iteration")
    return _save(fig, path, source)


def gain_sweep(routes: Sequence[SolvedRoute], path: str | Path, *, title: str) -> Path:
    """Error against iteration (log scale) and the EE path, one curve per gain."""
    fig = _figure(11.0, 4.6)
    ax_err = fig.add_subplot(1, 2, 1)
    for i, route in enumerate(routes):
        ax_err.semilogy(
            route.error_path_cm,
            **_style(i),
            label=f"{route.label}: {route.iterations} it., {route.status}",
        )
    ax_err.set_xlabel("iteration")
    ax_err.set_ylabel("|e| [cm]")
    ax_err.grid(visible=True, which="both", alpha=0.3)
    ax_err.legend(fontsize="small")
    ax_path = fig.add_subplot(1, 2, 2, projection="3d")
    _path_axes(ax_path, routes)
    fig.suptitle(title)
    return _save(fig, path)
