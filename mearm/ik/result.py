"""The record an IK solve returns: status, figures and the whole path."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt

from mearm.ik.failure import IKFailure
from mearm.kinematics.chain import M_PER_CM

Status = Literal["converged", "max_iterations", "stalled"]
STATUSES: tuple[Status, ...] = ("converged", "max_iterations", "stalled")
#: How the path was made: by the solver's own updates from the start (``direct``), or,
#: after they stopped short, as a joint-space move to a solution from the closed form
#: (``closed_form``) or from the solver started elsewhere (``multi_start``).
Method = Literal["direct", "closed_form", "multi_start", "joint_move"]
METHODS: tuple[Method, ...] = ("direct", "closed_form", "multi_start", "joint_move")


def _frozen(a: npt.ArrayLike) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    a.flags.writeable = False
    return a


def path_deviation_cm(ee_path_cm: npt.ArrayLike, target_cm: npt.ArrayLike) -> float:
    r"""Largest distance of a TCP path from the straight segment start → target [cm].

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


def joint_units(joint_names: Sequence[str], scale: npt.ArrayLike) -> dict[str, str]:
    """Each joint's unit by name: ``cm`` for a prismatic joint, else ``deg``.

    The ``joint_units`` of ``mearm fk --json`` and ``mearm ik --json`` (:meth:`IKResult.summary`),
    one rule for both, read off the model units per config unit that a chain and every
    record carry (``M_PER_CM`` for a prismatic joint, π/180 for a revolute one).
    """
    return {
        name: "cm" if s == M_PER_CM else "deg"
        for name, s in zip(joint_names, np.asarray(scale).tolist(), strict=True)
    }


class JumpStart:
    """What the jumps (:meth:`IKResult.jump`) of one solver from one start share.

    The start's TCP is computed the first time a record asks for it (its path or its
    errors), then kept: a solve whose caller reads only ``q`` never pays the FK.

    Attributes:
        solver: The solver's name.
        q: The start, every joint, model units, read-only, (n,).
        joint_names: The chain's joint names (n,).
        scale: Model units per config unit of each joint, read-only, (n,).
    """

    __slots__ = ("_ee_cm", "_fk_cm", "joint_names", "q", "scale", "solver")

    def __init__(
        self,
        solver: str,
        q: np.ndarray,
        joint_names: tuple[str, ...],
        scale: np.ndarray,
        fk_cm: Callable[[np.ndarray], np.ndarray],
    ):
        self.solver = solver
        self.q = q
        self.joint_names = joint_names
        self.scale = scale
        self._fk_cm = fk_cm
        self._ee_cm: tuple[float, float, float] | None = None

    @property
    def ee_cm(self) -> tuple[float, float, float]:
        """The TCP at the start [cm]."""
        if self._ee_cm is None:
            x, y, z = self._fk_cm(self.q).tolist()
            self._ee_cm = (x, y, z)
        return self._ee_cm


#: The fields of a jump (:meth:`IKResult.jump`) made on first use, from its ``_jump``.
_JUMP_FIELDS = frozenset(
    {
        "solver",
        "iterations",
        "joint_names",
        "scale",
        "initial_error_cm",
        "final_error_cm",
        "target_cm",
        "ee_cm",
        "q_path",
        "ee_path_cm",
        "error_path_cm",
    }
)


@dataclass(frozen=True, eq=False)  # arrays inside: compare fields, not records
class IKResult:
    """One solve from a start pose to a target: what every solver returns.

    Row ``k`` of each path is the state after ``k`` updates; row 0 is the start, the last
    row the result. Every row is a pose the arm may be commanded to: within the joint
    limits and with every passive joint on its coupling. A solver that finds joints but
    no way there (a closed form, Gauss–Newton) reports one update, a jump from the start
    to the solution (:meth:`jump`): it says nothing about how the arm gets there.

    Attributes:
        status: ``converged`` (|e|² below the tolerance and, with an approach, the approach
            angle below its tolerance), ``max_iterations`` or ``stalled`` (no update could
            lower the error any more).
        solver: Which solver produced it, e.g. ``"pdpij-paper"``, ``"mink"``.
        iterations: Number of updates applied [-].
        initial_error_cm: Position error |e| at the start [cm].
        final_error_cm: Position error |e| at the end [cm].
        target_cm: The TCP target (x, y, z) in the base frame [cm], (3,).
        q: Final joints in model units (rad, or m for a prismatic joint), (n,).
        ee_cm: Final TCP position [cm], (3,).
        q_path: Joints after every update, start included, model units, (N+1, n).
        ee_path_cm: TCP after every update [cm], (N+1, 3).
        error_path_cm: |e| after every update [cm], (N+1,).
        joint_names: The chain's joint names, the order of ``q`` (n,).
        scale: Model units per config unit of each joint (π/180 or 0.01), (n,).
        approach: The required approach direction (base frame, unit), (3,), or ``None``.
        final_approach_error_deg: Angle between the tool's approach axis and ``approach``
            at the end [deg]; ``None`` without an approach.
        blocked_steps: Updates in which the limit rule held at least one joint [-].
        fallback_steps: Updates the safeguard replaced by the bounded step [-].
        method: How the path was made (:data:`METHODS`): ``direct`` — the solver's own
            updates; ``closed_form`` / ``multi_start`` — its own updates stopped short
            (``recovered_from``) and were discarded, and the path is a joint-space move
            from the start to a solution found that way; ``joint_move`` — the solver's
            updates reached the target but swung a servo over a combination of joints
            past its pulse range on the way (:class:`~mearm.task.plan.Planner`), and the
            path is a straight joint-space move to the same solution.
        recovered_from: With a recovery, the status the solver's own updates ended with;
            else ``None``.
        search_iterations: Updates computed but not in the path [-]: the discarded
            attempt and every solve from another start. ``iterations`` counts only the
            path's updates, the poses sent to the servos.
        failure: Why the result cannot be sent (kind and message); ``None`` when
            converged.
    """

    status: Status
    solver: str
    iterations: int
    initial_error_cm: float
    final_error_cm: float
    target_cm: np.ndarray
    q: np.ndarray
    ee_cm: np.ndarray
    q_path: np.ndarray
    ee_path_cm: np.ndarray
    error_path_cm: np.ndarray
    joint_names: tuple[str, ...]
    scale: np.ndarray
    approach: np.ndarray | None = None
    final_approach_error_deg: float | None = None
    blocked_steps: int = 0
    fallback_steps: int = 0
    method: Method = "direct"
    recovered_from: Status | None = None
    search_iterations: int = 0
    failure: IKFailure | None = None

    @classmethod
    def from_paths(
        cls,
        status: Status,
        solver: str,
        target_cm: np.ndarray,
        q_path: np.ndarray,
        ee_path_cm: np.ndarray,
        *,
        joint_names: tuple[str, ...],
        scale: npt.ArrayLike,
        approach: npt.ArrayLike | None = None,
        final_approach_error_deg: float | None = None,
        blocked_steps: int = 0,
        fallback_steps: int = 0,
        method: Method = "direct",
        recovered_from: Status | None = None,
        search_iterations: int = 0,
        failure: IKFailure | None = None,
    ) -> IKResult:
        """Build the record from the joint and TCP paths (the errors follow from them).

        The arrays given (target included) become the record's own, read-only: pass
        fresh ones.
        """
        target = _frozen(target_cm)
        q_path = _frozen(q_path)
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
            q=q_path[-1],
            ee_cm=ee_path[-1],
            q_path=q_path,
            ee_path_cm=ee_path,
            error_path_cm=errors,
            joint_names=tuple(joint_names),
            scale=_frozen(scale),
            approach=None if approach is None else _frozen(approach),
            final_approach_error_deg=final_approach_error_deg,
            blocked_steps=blocked_steps,
            fallback_steps=fallback_steps,
            method=method,
            recovered_from=recovered_from,
            search_iterations=search_iterations,
            failure=failure,
        )

    @classmethod
    def jump(
        cls,
        status: Status,
        target_cm: tuple[float, float, float],
        q: np.ndarray,
        ee_cm: tuple[float, float, float],
        start: JumpStart,
        search_iterations: int = 0,
        failure: IKFailure | None = None,
    ) -> IKResult:
        """The record of a solve that found joints, not a path: one update, start → ``q``.

        Args:
            status: As the solver ended.
            target_cm: The target [cm].
            q: The solution, every joint, model units, read-only, (n,).
            ee_cm: The TCP at ``q`` [cm].
            start: The solver, the start and the chain's constants.
            search_iterations: The solver's own updates, none of them in the path [-].
            failure: Why it cannot be sent; given when not converged.

        The fast solves return one of these per call, in about the time a closed form
        takes: the record skips the dataclass ``__init__`` (its frozen ``setattr`` per
        field costs as much as the solve) and sets its other fields on first use (then
        they are kept). It reads like any other record.
        """
        self = object.__new__(cls)
        fields: dict[str, object] = {"status": status, "q": q, "_jump": (target_cm, ee_cm, start)}
        if search_iterations:  # else the class's default, as for every field not set
            fields["search_iterations"] = search_iterations
        if failure is not None:
            fields["failure"] = failure
        object.__setattr__(self, "__dict__", fields)
        return self

    if not TYPE_CHECKING:  # seen by mypy, it would accept any attribute name

        def __getattr__(self, name: str) -> Any:
            # Only reached for a name not in the instance: a jump's other fields, set now.
            jump = self.__dict__.get("_jump")
            if jump is None or name not in _JUMP_FIELDS:
                raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
            target_cm, ee_cm, start = jump
            target = _frozen(target_cm)
            ee_path = _frozen((start.ee_cm, ee_cm))
            diff = ee_path - target
            errors = np.sqrt(np.einsum("ij,ij->i", diff, diff))
            errors.flags.writeable = False
            self.__dict__.update(
                {
                    "solver": start.solver,
                    "iterations": 1,
                    "joint_names": start.joint_names,
                    "scale": start.scale,
                    "initial_error_cm": float(errors[0]),
                    "final_error_cm": float(errors[-1]),
                    "target_cm": target,
                    "ee_cm": ee_path[-1],
                    "q_path": _frozen((start.q, self.q)),
                    "ee_path_cm": ee_path,
                    "error_path_cm": errors,
                }
            )
            return self.__dict__[name]

    @property
    def converged(self) -> bool:
        """Whether the error fell below the tolerance."""
        return self.status == "converged"

    @property
    def q_config(self) -> np.ndarray:
        """Final joints in config units (deg, or cm for a prismatic joint), (n,)."""
        return self.q / self.scale

    @property
    def joints(self) -> dict[str, float]:
        """Final joints by name [deg, or cm for a prismatic joint]."""
        return {n: float(v) for n, v in zip(self.joint_names, self.q_config, strict=True)}

    @property
    def path_deviation_cm(self) -> float:
        """Largest distance of the TCP path from the straight segment start → target [cm]."""
        return path_deviation_cm(self.ee_path_cm, self.target_cm)

    def summary(self) -> dict[str, object]:
        """The CLI's JSON record: status, method, iterations, errors, joints, TCP [cm].

        Joints are in degrees (centimetres for a prismatic joint), each one's unit in
        ``joint_units`` (as ``mearm fk --json`` gives them); the approach error in degrees,
        ``None`` without an approach; ``failure_kind`` and ``failure`` ``None`` when
        converged.
        """
        return {
            "status": self.status,
            "method": self.method,
            "failure_kind": None if self.failure is None else self.failure.kind,
            "failure": None if self.failure is None else self.failure.message,
            "iterations": self.iterations,
            "initial_error_cm": self.initial_error_cm,
            "final_error_cm": self.final_error_cm,
            "final_approach_error_deg": self.final_approach_error_deg,
            "joints": self.joints,
            "joint_units": joint_units(self.joint_names, self.scale),
            "ee_cm": [float(v) for v in self.ee_cm],
        }
