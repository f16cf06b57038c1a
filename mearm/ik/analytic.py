"""The arm's closed form as a solver: the one wrapper of :mod:`mearm.kinematics.closed_form`.

Only for an arm whose description names a closed form (``arm.closed_form``). It returns
the same :class:`IKResult` as the iterative solvers, so a caller can swap solvers by
config (``controller.solver: analytic``), and it is the fastest solve mearm ships
(:func:`~mearm.ik.fastest_solver`): a position target costs the formula, the box check
and one small array (``mearm bench``). Its path is one update, from the start to the
solution (:meth:`IKResult.jump`): it says nothing about how the arm gets there.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from mearm.config import ControllerConfig
from mearm.ik.result import IKResult
from mearm.ik.solver import APPROACH_TOLERANCE_DEG, IKSolver
from mearm.ik.target import IKTarget
from mearm.kinematics import ArmModel, check_in_box
from mearm.kinematics.closed_form import scalar_target_cm
from mearm.kinematics.errors import ModelError


class AnalyticSolver(IKSolver):
    """The closed-form solution, reported as one update (see :class:`IKSolver`).

    The TCP of a position target is the target itself: the closed form is exact to
    rounding (below 1e-9 cm, ``tests/test_analytic.py``). The closed form places the TCP
    only: with an approach target the result is ``converged`` if the approach it gives is
    within the tolerance, else ``stalled``.

    Raises:
        ModelError: the arm has no closed form (:func:`~mearm.ik.fastest_solver` picks
            :class:`~mearm.ik.NewtonIK` for such an arm; the message names the config's
            choices only, as a sort or ``mearm ik`` shows it).
    """

    name = "analytic"

    def __init__(self, model: ArmModel, config: ControllerConfig | None = None):
        super().__init__(model, config)
        if self._solve_closed_form is None:
            raise ModelError(
                f"arm {model.arm.name!r} has no closed form (arm.closed_form is null), so "
                "the analytic solver cannot run: choose controller.solver 'pdpij' or 'mink'"
            )
        self._solve_closed_form_checked = self._solve_closed_form

    def solve(
        self, target: IKTarget | npt.ArrayLike, q_start: npt.ArrayLike | None = None
    ) -> IKResult:
        """Jump from ``q_start`` to the closed form's joints for ``target`` (:class:`IKSolver`).

        The hot path of :func:`~mearm.ik.fastest_solver`: :meth:`position_cm` and
        :meth:`_jump` written out, each call saved is a tenth of a solve.
        """
        if isinstance(target, IKTarget):
            if target.approach is not None:
                return self._solve_approach(target, q_start)
            p = target.position_cm
        else:
            p = scalar_target_cm(target)
        x, y, z = p
        (x0, x1), (y0, y1), (z0, z1) = self._box
        if not (x0 <= x <= x1 and y0 <= y <= y1 and z0 <= z <= z1):
            check_in_box(p, self.model.arm)  # raises, naming the axis and the range
        # within the limits and on the coupling; as bytes, a read-only array in one step
        q = np.frombuffer(self._pack_joints(*self._solve_closed_form_checked(p)))
        start = self._from_home if q_start is None else self._jump_start(q_start)
        return IKResult.jump("converged", p, q, p, start)

    def _solve_approach(self, target: IKTarget, q_start: npt.ArrayLike | None) -> IKResult:
        """With an approach: ``converged`` only if the closed form's approach meets it."""
        target, q0, q_solution = self.prepare(target, q_start)
        assert q_solution is not None  # the constructor checked there is a closed form
        q_path = np.stack([q0, q_solution])
        ee_path = np.stack([self.model.fk_cm(q) for q in q_path])
        result = self._result("converged", target, q_path, ee_path)
        error = result.final_approach_error_deg
        if error is not None and not error < APPROACH_TOLERANCE_DEG:
            return self._result("stalled", target, q_path, ee_path)
        return result
