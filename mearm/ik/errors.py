"""Errors of the IK solvers that are not about the target or the joints.

A target or a start the solvers cannot use is an error of the arm's model
(:mod:`mearm.kinematics.errors`).
"""

from __future__ import annotations

from collections.abc import Sequence

from mearm.errors import MearmError


class QPSolverError(MearmError):
    """The QP backend asked for the mink cross-check is not installed.

    Attributes:
        name: The backend asked for.
        available: The installed qpsolvers backends.
    """

    def __init__(self, name: str, available: Sequence[str]):
        self.name = name
        self.available = list(available)
        super().__init__(
            f"QP solver {name!r} is not installed; available: {self.available} "
            "(set controller.qp_solver)"
        )
