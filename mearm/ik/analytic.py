"""The closed form as a solver: one step from the start to the exact solution.

Wraps :func:`mearm.kinematics.analytic_ik_deg` (elbow-up, unique within the limits) in
the same :class:`IKResult` record as the iterative solvers, so a caller can swap solvers
by config. Its path has two rows, the start and the solution: it says nothing about how
the arm gets there.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from mearm.ik.result import IKResult
from mearm.ik.solver import IKSolver


class AnalyticSolver(IKSolver):
    """The closed-form solution, reported as one update (see :class:`IKSolver`)."""

    name = "analytic"

    def solve(self, q_start_rad: npt.ArrayLike, target_cm: npt.ArrayLike) -> IKResult:
        """Jump from ``q_start_rad`` [rad] to the closed-form solution for ``target_cm``."""
        q0, target_cm, q_solution = self.prepare(q_start_rad, target_cm)
        q_solution = np.clip(q_solution, self.model.lower_rad, self.model.upper_rad)
        q_path = np.stack([q0, q_solution])
        ee_path = np.stack([self.model.fk_cm(q) for q in q_path])
        return IKResult.from_paths("converged", self.name, target_cm, q_path, ee_path)
