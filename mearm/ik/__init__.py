"""Inverse kinematics for any arm: PD-PIJ (paper §3), cross-checked by mink and closed forms.

mink runs on MuJoCo; a closed form exists only for the arms that register one.

Example::

    from mearm.ik import IKTarget, PdPij
    model = ArmModel(config.arm)
    solver = PdPij(model, config.controller)
    result = solver.solve(model.home, IKTarget((-10.99, 49.70, 12.76)))
    result.status, result.iterations, result.q_path  # (N+1, n), model units

The mink solver (:mod:`mearm.ik.mink_solver`) imports MuJoCo and is loaded on first use.

For joints alone (no path), :func:`fastest_solver` gives the fastest solve for an arm:
its registered closed form, else the generic Gauss–Newton (:mod:`mearm.ik.fast`).
"""

from mearm.ik.analytic import AnalyticSolver
from mearm.ik.factory import make_solver, solve_ik
from mearm.ik.failure import FAILURE_KINDS, FailureKind, IKFailure, failure_of_error
from mearm.ik.fast import ClosedFormIK, FastIK, FastSolution, NewtonIK, fastest_solver
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
    "ClosedFormIK",
    "DemoRoute",
    "FailureKind",
    "FastIK",
    "FastSolution",
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
