"""Inverse kinematics for any arm: PD-PIJ (paper §3), cross-checked by mink and closed forms.

Every solver has one interface (:class:`IKSolver`): ``solve(target, q_start=None)``
returns an :class:`IKResult`. mink runs on MuJoCo; a closed form exists only for the
arms that register one.

Example::

    from mearm.ik import IKTarget, PdPij
    model = ArmModel(config.arm)
    solver = PdPij(model, config.controller)
    result = solver.solve(IKTarget((-10.99, 49.70, 12.76)), model.home)
    result.status, result.iterations, result.q_path  # (N+1, n), model units

The mink solver (:mod:`mearm.ik.mink_solver`) imports MuJoCo; it, the fast solves and the
demo routes are loaded on first use.

For joints alone (no path), :func:`fastest_solver` gives the fastest solve for an arm:
its registered closed form (:class:`AnalyticSolver`), else the generic Gauss–Newton
(:class:`NewtonIK`). For many targets at once, :func:`solve_batch`.
"""

from typing import TYPE_CHECKING

from mearm._lazy import lazy_exports
from mearm.ik.batch import BatchSolution, solve_batch
from mearm.ik.factory import fastest_solver, make_solver, solve_ik
from mearm.ik.failure import FAILURE_KINDS, FailureKind, IKFailure, failure_of_error
from mearm.ik.pdpij import PdPij
from mearm.ik.pseudoinverse import PseudoInverse
from mearm.ik.result import METHODS, STATUSES, IKResult, Method, Status
from mearm.ik.solver import (
    APPROACH_TOLERANCE_DEG,
    APPROACH_WEIGHT_CM,
    IKSolver,
    start_joints,
)
from mearm.ik.target import IKTarget

if TYPE_CHECKING:  # typed for the checker, imported on first use (_LAZY)
    from mearm.ik.analytic import AnalyticSolver
    from mearm.ik.mink_solver import MinkSolver
    from mearm.ik.newton import NewtonIK
    from mearm.ik.routes import DemoRoute, demo_routes, run_routes

#: Names a sort never needs, imported on first use: mink pulls in MuJoCo (~0.3 s).
_LAZY = {
    "AnalyticSolver": "mearm.ik.analytic",
    "NewtonIK": "mearm.ik.newton",
    "MinkSolver": "mearm.ik.mink_solver",
    "DemoRoute": "mearm.ik.routes",
    "demo_routes": "mearm.ik.routes",
    "run_routes": "mearm.ik.routes",
}

__all__ = [
    "APPROACH_TOLERANCE_DEG",
    "APPROACH_WEIGHT_CM",
    "FAILURE_KINDS",
    "METHODS",
    "STATUSES",
    "AnalyticSolver",
    "BatchSolution",
    "DemoRoute",
    "FailureKind",
    "IKFailure",
    "IKResult",
    "IKSolver",
    "IKTarget",
    "Method",
    "MinkSolver",
    "NewtonIK",
    "PdPij",
    "PseudoInverse",
    "Status",
    "demo_routes",
    "failure_of_error",
    "fastest_solver",
    "make_solver",
    "run_routes",
    "solve_batch",
    "solve_ik",
    "start_joints",
]

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals(), __all__)
