"""Choose a solver: the one the config names, or the fastest one the arm has.

``controller.solver`` is ``pdpij``, ``mink`` or ``analytic``; :func:`fastest_solver` picks
the arm's closed form, else Gauss–Newton.
"""

from __future__ import annotations

import numpy.typing as npt

from mearm.config import ControllerConfig
from mearm.ik.pdpij import PdPij
from mearm.ik.result import IKResult
from mearm.ik.solver import IKSolver, require_controller, require_model
from mearm.ik.target import IKTarget
from mearm.kinematics import ArmModel


def make_solver(model: ArmModel, config: ControllerConfig) -> IKSolver:
    """The solver ``config.solver`` names, built for ``model``.

    The mink solver imports MuJoCo, so it is only loaded when asked for.

    Raises:
        ModelError: ``analytic`` for an arm without a closed form; ``model`` is not an
            :class:`ArmModel` (pass ``ArmModel(config.arm)``).
        ConfigError: ``config`` is not the controller section (pass ``config.controller``).
        QPSolverError: ``mink`` with a QP backend that is not installed.
    """
    require_model(model, "make_solver")
    require_controller(config, "make_solver")
    if config.solver == "pdpij":
        return PdPij(model, config)
    if config.solver == "mink":
        from mearm.ik.mink_solver import MinkSolver  # noqa: PLC0415 (MuJoCo is heavy)

        return MinkSolver(model, config)
    from mearm.ik.analytic import AnalyticSolver  # noqa: PLC0415 (a sort needs PD-PIJ only)

    return AnalyticSolver(model, config)


def solve_ik(
    model: ArmModel,
    config: ControllerConfig,
    target: IKTarget | npt.ArrayLike,
    q_start: npt.ArrayLike | None = None,
) -> IKResult:
    """Solve once with the solver ``config.solver`` names: ``make_solver(...).solve(...)``.

    Args:
        model: The arm model.
        config: The controller section of the config.
        target: An :class:`IKTarget`, or (x, y, z) in the base frame [cm].
        q_start: Every joint (n,) or the actuated ones (m,), model units; ``None``: home.

    Returns:
        The :class:`IKResult`.

    Raises:
        TargetOutsideBoxError, UnreachableTargetError: the target, before anything moves.
        JointLimitError, InvalidJointsError: the start.
        ModelError, ConfigError: ``model`` or ``config`` is not what it should be
            (:func:`make_solver`).

    To solve many targets, build the solver once with :func:`make_solver` instead.
    """
    require_model(model, "solve_ik")
    require_controller(config, "solve_ik")
    return make_solver(model, config).solve(target, q_start)


def fastest_solver(model: ArmModel) -> IKSolver:
    """The fastest position solve for ``model``'s arm.

    Its registered closed form (:class:`AnalyticSolver`) where the arm names one, else
    :class:`NewtonIK`.

    Raises:
        ModelError: ``model`` is not an :class:`ArmModel` (pass ``ArmModel(config.arm)``).
    """
    require_model(model, "fastest_solver")
    from mearm.ik.analytic import AnalyticSolver  # noqa: PLC0415 (a sort needs PD-PIJ only)
    from mearm.ik.newton import NewtonIK  # noqa: PLC0415

    if model.arm.closed_form is not None:
        return AnalyticSolver(model)
    return NewtonIK(model)
