r"""Why a solve gives nothing to send: a kind a program can count and a line for people.

Six kinds, each with one cause:

- ``outside_box``: the target leaves the arm's target box (refused before any motion).
- ``unreachable``: out of reach (a closed form proves it, before any motion).
- ``limit``: the target needs a joint outside its limits, the start is outside them, the
  solver stopped with joints on their limits blocking every way down, or the solution
  needs a servo over several joints past its pulse range (the sort planner and ``mearm
  ik`` check that: :meth:`~mearm.hardware.mapping.ServoMap.outside_pulse_range`).
- ``singular``: the target sits where the arm is singular (on the base axis), or the
  solver stopped at a pose where no joint motion changes the error to first order (the
  arm stretched towards a target out of reach, usually).
- ``stalled``: the solver stopped short for another reason (the iteration cap).
- ``collision``: the solve converged, but every route the planner could make to the
  target brings the arm's body within its clearance of the table, a bin or an object
  (:mod:`mearm.kinematics.collision`); the message names the two bodies and the pose.

A solver that stopped is classified at its last pose :math:`q` by the gradient of
:math:`\tfrac12|e|^2` over the actuated joints, :math:`g = (J C)^T e`: with
:math:`\|g\| \le \epsilon\,\|J C\|\,\|e\|` the pose is singular in the error's direction;
with only the projected gradient that small (components pushing a joint past a limit
it sits on removed) the limits block it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from mearm.kinematics import Chain
from mearm.kinematics.closed_form import JointLimitTargetError, SingularTargetError
from mearm.kinematics.errors import JointLimitError, TargetError, TargetOutsideBoxError

FailureKind = Literal["unreachable", "limit", "stalled", "singular", "outside_box", "collision"]
FAILURE_KINDS: tuple[FailureKind, ...] = (
    "unreachable",
    "limit",
    "stalled",
    "singular",
    "outside_box",
    "collision",
)

#: A (projected) gradient below this share of |J C|·|e| counts as none [-].
GRADIENT_RATIO = 1e-3
#: A joint this close to a limit [model units] is on it, for the classification.
_ON_LIMIT = 1e-6


@dataclass(frozen=True)
class IKFailure:
    """Why there is no plan to send.

    Attributes:
        kind: One of :data:`FAILURE_KINDS`, for counting and for programs.
        message: One line for people: what stopped it, with the values.
    """

    kind: FailureKind
    message: str


def failure_of_error(exc: TargetError | JointLimitError) -> IKFailure:
    """The failure a refused target (or a start outside the limits) stands for.

    The message of a refused target is its reason (the target itself is known to the
    caller); a start outside the limits says so, naming the joint.
    """
    if isinstance(exc, TargetOutsideBoxError):
        return IKFailure("outside_box", exc.reason)
    if isinstance(exc, SingularTargetError):
        return IKFailure("singular", exc.reason)
    if isinstance(exc, JointLimitTargetError):
        return IKFailure("limit", exc.reason)
    if isinstance(exc, TargetError):
        return IKFailure("unreachable", exc.reason)
    return IKFailure("limit", f"the start is outside the joint limits: {exc}")


def blocking_joints(
    J_actuated: np.ndarray, e: np.ndarray, q: np.ndarray, chain: Chain
) -> tuple[FailureKind, list[int]]:
    """Classify a pose where a solver stopped (see the module docstring).

    Args:
        J_actuated: Jacobian of the (stacked) error over the actuated joints, (rows, m).
        e: The error at that pose, target minus actual, (rows,), same units as J.
        q: The pose, every joint, model units, (n,).
        chain: The arm's chain (limits, actuated joints).

    Returns:
        ``(kind, blocked)``: ``singular``, ``limit`` or ``stalled``, and the indices in
        ``q`` of the actuated joints whose limits block the error's gradient.
    """
    g = J_actuated.T @ e  # (m,): moving q_a along g lowers |e|² to first order
    small = GRADIENT_RATIO * float(np.linalg.norm(J_actuated, 2) * np.linalg.norm(e))
    if not small > 0 or not np.all(np.isfinite(g)):
        return "stalled", []
    index = chain.actuated_index
    q_a = q[index]
    pushes_down = (q_a <= chain.lower[index] + _ON_LIMIT) & (g < -small)
    pushes_up = (q_a >= chain.upper[index] - _ON_LIMIT) & (g > small)
    blocked = pushes_down | pushes_up
    blocked_index = [int(i) for i in index[blocked]]
    if np.linalg.norm(g) <= small:
        return "singular", []
    if np.linalg.norm(np.where(blocked, 0.0, g)) <= small:
        return "limit", blocked_index
    return "stalled", blocked_index
