"""The closed form as a solver: one step from the start to the exact solution.

Only for an arm whose description names a closed form (``arm.closed_form``, see
:mod:`mearm.kinematics.closed_form`); it is reported in the same :class:`IKResult` record
as the iterative solvers, so a caller can swap solvers by config. Its path has two rows,
the start and the solution: it says nothing about how the arm gets there.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from mearm.config import ControllerConfig
from mearm.ik.result import IKResult
from mearm.ik.solver import APPROACH_TOLERANCE_DEG, IKSolver
from mearm.ik.target import IKTarget
from mearm.kinematics import ArmModel
from mearm.kinematics.errors import ModelError


class AnalyticSolver(IKSolver):
    """The closed-form solution, reported as one update (see :class:`IKSolver`).

    The closed form places the TCP only: with an approach target the result is
    ``converged`` if the approach it gives is within the tolerance, else ``stalled``.

    Raises:
        ModelError: the arm has no closed form.
    """

    name = "analytic"

    def __init__(self, model: ArmModel, config: ControllerConfig):
        super().__init__(model, config)
        if self.closed_form is None:
            raise ModelError(
                f"arm {model.arm.name!r} has no closed form (arm.closed_form is null), so "
                "the analytic solver cannot run: choose controller.solver 'pdpij' or 'mink'"
            )

    def solve(self, q_start: npt.ArrayLike, target: IKTarget | npt.ArrayLike) -> IKResult:
        """Jump from ``q_start`` (model units) to the closed-form solution for ``target``."""
        q0, target, q_solution = self.prepare(q_start, target)
        assert q_solution is not None  # the constructor checked there is a closed form
        q_path = np.stack([q0, q_solution])  # the closed form's joints are within limits
        ee_path = np.stack([self.model.fk_cm(q) for q in q_path])
        result = self._result("converged", target, q_path, ee_path)
        error = result.final_approach_error_deg
        if error is not None and not error < APPROACH_TOLERANCE_DEG:
            return self._result("stalled", target, q_path, ee_path)
        return result
