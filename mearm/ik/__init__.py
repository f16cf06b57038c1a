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

The mink solver (:mod:`mearm.ik.mink_solver`) imports MuJoCo and is loaded on first use.

For joints alone (no path), :func:`fastest_solver` gives the fastest solve for an arm:
its registered closed form (:class:`AnalyticSolver`), else the generic Gauss–Newton
(:class:`NewtonIK`).
"""

from mearm.ik.analytic import AnalyticSolver
from mearm.ik.factory import fastest_solver, make_solver, solve_ik
from mearm.ik.failure import FAILURE_KINDS, FailureKind, IKFailure, failure_of_error
from mearm.ik.newton import NewtonIK
from mearm.ik.pdpij import PdPij
from mearm.ik.pseudoinverse import PseudoInverse
from mearm.ik.result import METHODS, STATUSES, IKResult, Method, Status
from mearm.ik.routes import DemoRoute, demo_routes, run_routes
from mearm.ik.solver import (
    APPROACH_TOLERANCE_DEG,
    APPROACH_WEIGHT_CM,
    IKSolver,
    start_joints,
)
from mearm.ik.target import IKTarget

__all__ = [
    "APPROACH_TOLERANCE_DEG",
    "APPROACH_WEIGHT_CM",
    "FAILURE_KINDS",
    "METHODS",
    "STATUSES",
    "AnalyticSolver",
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
    "solve_ik",
    "start_joints",
]


def __getattr__(name: str) -> object:
    # MinkSolver pulls in MuJoCo and mink (~0.3 s): import it only when named.
    if name == "MinkSolver":
        from mearm.ik.mink_solver import MinkSolver  # noqa: PLC0415

        return MinkSolver
    raise AttributeError(f"module 'mearm.ik' has no attribute {name!r}")
