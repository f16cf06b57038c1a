"""Error and iteration statistics of routes: the paper's Table 8 and Table 6 (paper §5, §3).

Standard deviations are sample ones (``ddof=1``), as MATLAB's ``std``, which the paper used.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from mearm.analysis.errors import AnalysisError
from mearm.runlog import RouteRecord

Step = Literal["all", "pick", "place"]
STEPS: tuple[Step, ...] = ("all", "pick", "place")


@dataclass(frozen=True)
class Moments:
    """Mean, sample std (``nan`` for one value), max and min of n values."""

    mean: float
    std: float
    max: float
    min: float
    n: int

    @classmethod
    def of(cls, values: npt.ArrayLike) -> Moments:
        """The moments of a non-empty 1-D sample.

        Raises:
            AnalysisError: The sample is empty.
        """
        v = np.asarray(values, dtype=float).ravel()
        if v.size == 0:
            raise AnalysisError("no values to take statistics of")
        std = float(np.std(v, ddof=1)) if v.size > 1 else math.nan
        return cls(float(np.mean(v)), std, float(np.max(v)), float(np.min(v)), int(v.size))

    def as_tuple(self) -> tuple[float, float, float, float]:
        """(mean, std, max, min), the column order of Table 8."""
        return (self.mean, self.std, self.max, self.min)


@dataclass(frozen=True)
class ErrorTable:
    r"""Table 8: statistics of the final EE error e = ee − target [cm].

    Attributes:
        x: Per-axis error e_x [cm].
        y: Per-axis error e_y [cm].
        z: Per-axis error e_z [cm].
        xy: Euclidean :math:`\sqrt{e_x^2 + e_y^2}` [cm].
        xyz: Euclidean :math:`\lVert e \rVert` [cm].
        n: Number of routes.
    """

    x: Moments
    y: Moments
    z: Moments
    xy: Moments
    xyz: Moments
    n: int

    def rows(self) -> dict[str, Moments]:
        """The five rows in Table 8's order, by name."""
        return {"x": self.x, "y": self.y, "z": self.z, "xy": self.xy, "xyz": self.xyz}


def error_table(error_cm: npt.ArrayLike) -> ErrorTable:
    """Table 8 of N error vectors.

    Args:
        error_cm: Errors ee − target [cm], (N, 3).

    Raises:
        AnalysisError: No errors, or not of shape (N, 3).
    """
    e = np.asarray(error_cm, dtype=float)
    if e.ndim != 2 or e.shape[1] != 3:
        raise AnalysisError(f"errors must have shape (N, 3), got {e.shape}")
    if e.shape[0] == 0:
        raise AnalysisError("no routes: Table 8 needs at least one route")
    return ErrorTable(
        x=Moments.of(e[:, 0]),
        y=Moments.of(e[:, 1]),
        z=Moments.of(e[:, 2]),
        xy=Moments.of(np.hypot(e[:, 0], e[:, 1])),
        xyz=Moments.of(np.linalg.norm(e, axis=1)),
        n=int(e.shape[0]),
    )


def select_routes(
    routes: Iterable[RouteRecord], *, step: Step = "all", first_attempt: bool = False
) -> list[RouteRecord]:
    """The routes of one step (``"pick"``, ``"place"`` or ``"all"``), optionally first tries.

    Raises:
        AnalysisError: ``step`` is not one of :data:`STEPS`.
    """
    if step not in STEPS:
        raise AnalysisError(f"step must be one of {list(STEPS)}, got {step!r}")
    return [
        r
        for r in routes
        if (step == "all" or r.step == step) and (not first_attempt or r.attempt == 1)
    ]


def route_errors_cm(routes: Sequence[RouteRecord]) -> np.ndarray:
    """The routes' error vectors ee − target [cm], (N, 3)."""
    return np.array([r.error_cm for r in routes], dtype=float).reshape(-1, 3)


@dataclass(frozen=True)
class IterationStats:
    """The columns of the paper's Table 6 over a set of routes (solver figures).

    Attributes:
        iterations: Iterations per route [-].
        initial_error_cm: Distance from the start EE to the target [cm].
        final_error_cm: The solver's final error, ideal kinematics [cm].
        statuses: How many routes ended with each solver status.
        n: Number of routes.
    """

    iterations: Moments
    initial_error_cm: Moments
    final_error_cm: Moments
    statuses: dict[str, int]
    n: int

    def as_dict(self) -> dict[str, object]:
        """Plain-data form for JSON."""
        return asdict(self)


def iteration_stats(routes: Sequence[RouteRecord]) -> IterationStats:
    """Iteration and solver-error statistics of routes (Table 6's columns).

    Raises:
        AnalysisError: No routes.
    """
    if not routes:
        raise AnalysisError("no routes: iteration statistics need at least one route")
    return IterationStats(
        iterations=Moments.of([r.iterations for r in routes]),
        initial_error_cm=Moments.of([r.initial_error_cm for r in routes]),
        final_error_cm=Moments.of([r.final_error_cm for r in routes]),
        statuses=dict(Counter(r.status for r in routes)),
        n=len(routes),
    )
