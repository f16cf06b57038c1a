"""Inverse kinematics: PD-PIJ (SPEC §3) on Pinocchio; mink and the closed form cross-check.

Example::

    from mearm.ik import PdPij
    solver = PdPij(ArmModel(config.robot), config.controller)
    result = solver.solve(model.home_rad, [-10.99, 49.70, 12.76])
    result.status, result.iterations, result.q_path_rad  # (N+1, 4)

The mink solver (:mod:`mearm.ik.mink_solver`) imports MuJoCo and is loaded on first use.
"""

from mearm.ik.analytic import AnalyticSolver
from mearm.ik.factory import make_solver, solve_ik
from mearm.ik.pdpij import PdPij
from mearm.ik.pseudoinverse import PseudoInverse
from mearm.ik.result import STATUSES, IKResult, Status
from mearm.ik.routes import DemoRoute, demo_routes, run_routes
from mearm.ik.solver import IKSolver, start_joints

__all__ = [
    "STATUSES",
    "AnalyticSolver",
    "DemoRoute",
    "IKResult",
    "IKSolver",
    "MinkSolver",
    "PdPij",
    "PseudoInverse",
    "Status",
    "demo_routes",
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
