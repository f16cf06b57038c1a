"""What every IK solver shares: the checks made before anything moves."""

from __future__ import annotations

import abc
import math

import numpy as np
import numpy.typing as npt

from mearm.config import ControllerConfig
from mearm.exceptions import InvalidJointsError
from mearm.ik.result import IKResult
from mearm.kinematics import ArmModel, as_target_cm, check_target

#: A start's θ2 + θ3 + θ4 may differ from 0 by this much [rad] (SPEC §2: the
#: parallelogram holds it at 0; 1e-6 rad moves the EE by under 1e-4 cm).
COUPLING_TOLERANCE_RAD = 1e-6
#: A start this close outside a limit [rad] counts as on it (as ArmModel.check_limits).
_LIMIT_TOL_RAD = 1e-9


def start_joints(q_start_rad: npt.ArrayLike, model: ArmModel) -> np.ndarray:
    """Validate a start pose and return it as a full, exactly coupled joint vector.

    Args:
        q_start_rad: (θ1, θ2, θ3) or (θ1, θ2, θ3, θ4) [rad].
        model: The arm (its joint limits).

    Returns:
        (4,) joints [rad] within the limits, θ4 = −(θ2 + θ3). A start within the
        limits' 1e-9 rad tolerance is moved onto the limit.

    Raises:
        InvalidJointsError: not 3 or 4 finite numbers, or θ2 + θ3 + θ4 ≠ 0.
        JointLimitError: a joint is outside its limits.
    """
    try:
        q = np.asarray(q_start_rad, dtype=float).ravel().tolist()
    except (TypeError, ValueError):
        raise InvalidJointsError(
            (), f"expected 3 or 4 joint angles in rad, got {q_start_rad!r}"
        ) from None
    if len(q) not in (3, 4):
        raise InvalidJointsError(q, f"expected 3 or 4 joint angles, got {len(q)}")
    if not all(map(math.isfinite, q)):
        raise InvalidJointsError(q, "joint angles must be finite")
    a, b, c = q[:3]
    if len(q) == 4:
        residual = b + c + q[3]
        if abs(residual) > COUPLING_TOLERANCE_RAD:
            raise InvalidJointsError(
                q,
                f"θ2 + θ3 + θ4 = {residual:.3g} rad; the parallelogram holds it at 0 "
                f"(within {COUPLING_TOLERANCE_RAD:g} rad): pass θ4 = −(θ2 + θ3) or 3 angles",
            )
    q4 = [a, b, c, -(b + c)]
    lower, upper = model.lower_rad.tolist(), model.upper_rad.tolist()
    tol = _LIMIT_TOL_RAD
    if not all(lo - tol <= v <= hi + tol for v, lo, hi in zip(q4, lower, upper, strict=True)):
        model.check_limits(q4, tol_rad=tol)  # raises, naming the joint
    # within the tolerance counts as on the limit; θ4's limits are degrees converted, so
    # clip it too rather than trust −(θ2 + θ3) to the last bit
    a, b, c = (min(max(v, lo), hi) for v, lo, hi in zip(q4[:3], lower[:3], upper[:3], strict=True))
    d = min(max(-(b + c), lower[3]), upper[3])
    return np.array((a, b, c, d))


class IKSolver(abc.ABC):
    """Base class: a solver moves the EE from a start pose to a Cartesian target.

    Args:
        model: The arm model (geometry and limits).
        config: The controller section of the config.
    """

    #: Short name recorded in :attr:`IKResult.solver`.
    name: str = "ik"

    def __init__(self, model: ArmModel, config: ControllerConfig):
        self.model = model
        self.config = config

    def prepare(
        self, q_start_rad: npt.ArrayLike, target_cm: npt.ArrayLike
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Check the target and the start before anything moves.

        Returns:
            ``(q_start, target, q_solution)``: the start (4,) [rad], the target (3,) [cm]
            and the closed-form solution (4,) [rad].

        Raises:
            InvalidTargetError: the target is not three finite numbers.
            TargetOutsideBoxError: outside the Table 3 box (SPEC §3).
            UnreachableTargetError: in the box but out of reach within the limits.
            InvalidJointsError: see :func:`start_joints`.
            JointLimitError: the start is outside the joint limits.
        """
        target = as_target_cm(target_cm).copy()
        q_solution = np.radians(check_target(target, self.model.robot))
        return start_joints(q_start_rad, self.model), target, q_solution

    @abc.abstractmethod
    def solve(self, q_start_rad: npt.ArrayLike, target_cm: npt.ArrayLike) -> IKResult:
        """Move from ``q_start_rad`` (θ1..θ3 or θ1..θ4) [rad] to ``target_cm`` [cm].

        Raises:
            MearmError: a bad target or start (see :meth:`prepare`); never for numerics.
        """
