"""The record an IK solve returns: status, figures and the whole path."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

Status = Literal["converged", "max_iterations", "stalled"]
STATUSES: tuple[Status, ...] = ("converged", "max_iterations", "stalled")


def _frozen(a: npt.ArrayLike) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    a.flags.writeable = False
    return a


def path_deviation_cm(ee_path_cm: npt.ArrayLike, target_cm: npt.ArrayLike) -> float:
    r"""Largest distance of an EE path from the straight segment start → target [cm].

    .. math:: \max_k \min_{\lambda \in [0, 1]} \| s_k - (s_0 + \lambda (s_d - s_0)) \|

    Args:
        ee_path_cm: The path, first row the start [cm], (N+1, 3).
        target_cm: The target [cm], (3,).
    """
    path = np.asarray(ee_path_cm, dtype=float)
    start = path[0]
    seg = np.asarray(target_cm, dtype=float) - start
    rel = path - start
    length2 = float(seg @ seg)
    if length2 == 0.0:
        return float(np.linalg.norm(rel, axis=1).max())
    lam = np.clip(rel @ seg / length2, 0.0, 1.0)
    return float(np.linalg.norm(rel - lam[:, None] * seg, axis=1).max())


@dataclass(frozen=True, eq=False)  # arrays inside: compare fields, not records
class IKResult:
    """One solve from a start pose to a target (SPEC §3).

    Row ``k`` of each path is the state after ``k`` updates; row 0 is the start, the last
    row the result. Every row is a pose the arm may be commanded to: within the joint
    limits and with θ2 + θ3 + θ4 = 0.

    Attributes:
        status: ``converged`` (|e|² below the tolerance), ``max_iterations`` or
            ``stalled`` (no update could lower the error any more).
        solver: Which solver produced it, e.g. ``"pdpij-paper"``, ``"mink"``.
        iterations: Number of updates applied [-].
        initial_error_cm: |e| at the start [cm].
        final_error_cm: |e| at the end [cm].
        target_cm: The target (x, y, z) in the base frame [cm], (3,).
        q_rad: Final joints (θ1..θ4) [rad], (4,).
        ee_cm: Final EE position [cm], (3,).
        q_path_rad: Joints after every update, start included [rad], (N+1, 4).
        ee_path_cm: EE after every update [cm], (N+1, 3).
        error_path_cm: |e| after every update [cm], (N+1,).
        blocked_steps: Updates in which the limit rule held at least one joint [-].
        fallback_steps: Updates the safeguard replaced by the clamped exact step [-].
    """

    status: Status
    solver: str
    iterations: int
    initial_error_cm: float
    final_error_cm: float
    target_cm: np.ndarray
    q_rad: np.ndarray
    ee_cm: np.ndarray
    q_path_rad: np.ndarray
    ee_path_cm: np.ndarray
    error_path_cm: np.ndarray
    blocked_steps: int = 0
    fallback_steps: int = 0

    @classmethod
    def from_paths(
        cls,
        status: Status,
        solver: str,
        target_cm: np.ndarray,
        q_path_rad: np.ndarray,
        ee_path_cm: np.ndarray,
        *,
        blocked_steps: int = 0,
        fallback_steps: int = 0,
    ) -> IKResult:
        """Build the record from the joint and EE paths (the errors follow from them).

        The arrays given (target included) become the record's own, read-only: pass
        fresh ones.
        """
        target = _frozen(target_cm)
        q_path = _frozen(q_path_rad)
        ee_path = _frozen(ee_path_cm)
        diff = ee_path - target
        errors = np.sqrt(np.einsum("ij,ij->i", diff, diff))
        errors.flags.writeable = False
        return cls(
            status=status,
            solver=solver,
            iterations=len(q_path) - 1,
            initial_error_cm=float(errors[0]),
            final_error_cm=float(errors[-1]),
            target_cm=target,
            q_rad=q_path[-1],
            ee_cm=ee_path[-1],
            q_path_rad=q_path,
            ee_path_cm=ee_path,
            error_path_cm=errors,
            blocked_steps=blocked_steps,
            fallback_steps=fallback_steps,
        )

    @property
    def converged(self) -> bool:
        """Whether the error fell below the tolerance."""
        return self.status == "converged"

    @property
    def q_deg(self) -> np.ndarray:
        """Final joints (θ1..θ4) [deg], (4,)."""
        return np.degrees(self.q_rad)

    @property
    def path_deviation_cm(self) -> float:
        """Largest distance of the EE path from the straight segment start → target [cm]."""
        return path_deviation_cm(self.ee_path_cm, self.target_cm)

    def summary(self) -> dict[str, object]:
        """The CLI's JSON record: status, iterations, errors [cm], joints [deg], EE [cm]."""
        return {
            "status": self.status,
            "iterations": self.iterations,
            "initial_error_cm": self.initial_error_cm,
            "final_error_cm": self.final_error_cm,
            "joints_deg": [float(v) for v in self.q_deg],
            "ee_cm": [float(v) for v in self.ee_cm],
        }
