r"""One interface for every IK solver: ``solver.solve(target, q_start) -> IKResult``.

Every solver — :class:`~mearm.ik.PdPij` (the paper's loop), :class:`~mearm.ik.MinkSolver`,
:class:`~mearm.ik.AnalyticSolver` (the arm's closed form) and
:class:`~mearm.ik.NewtonIK` (Gauss–Newton, any arm) — subclasses :class:`IKSolver`, takes
the same two arguments in the same order and returns an :class:`~mearm.ik.IKResult`:

    solver.solve(target, q_start=None)

The target first, because it is what a solve is for and every solver needs it; the start
second and optional, because not every solver needs one to find its answer (a closed form
needs none) and ``None`` means the home pose, as Robotics Toolbox's ``ik_LM(Tep, q0=…)``
and ikpy's ``inverse_kinematics(target, initial_position=None)`` have it. A start passed
first by mistake is refused before anything moves: joint angles read as centimetres fall
outside the target box.

Here too: the checks every solver makes before anything moves (the target box, the
closed form's reachability, the start), and the record they return.
"""

from __future__ import annotations

import abc
import math
import struct
import weakref

import numpy as np
import numpy.typing as npt

from mearm.config import ArmDescription, ControllerConfig
from mearm.errors import ConfigError, whole_config, wrong_argument
from mearm.ik.failure import IKFailure, blocking_joints
from mearm.ik.result import IKResult, JumpStart, Method, Status
from mearm.ik.target import IKTarget, approach_error_deg
from mearm.kinematics import ArmModel, Chain, check_in_box, closed_form_for
from mearm.kinematics.closed_form import scalar_target_cm
from mearm.kinematics.errors import InvalidJointsError, ModelError

#: A start's passive joints may differ from their coupling by this much [model units]
#: (1e-6 rad moves the TCP by under 1e-4 cm).
COUPLING_TOLERANCE = 1e-6
#: A start this close outside a limit [model units] counts as on it.
LIMIT_TOLERANCE = 1e-9
#: Weight of the approach error against the position error [cm per unit of the unit
#: vector difference]: 10 cm ≈ 0.17 cm per degree. Belongs in ``controller``.
APPROACH_WEIGHT_CM = 10.0
#: An approach target is met when the approach axis is within this angle [deg].
#: Belongs in ``controller``.
APPROACH_TOLERANCE_DEG = 0.5


def require_model(model: object, user: str) -> None:
    """Raise :class:`ModelError` unless ``model`` is an :class:`ArmModel`.

    The solvers read the model's chain and Pinocchio model at once: an arm's description
    or a whole config stopped there on an AttributeError that named neither.
    """
    if not isinstance(model, ArmModel):
        fix = (
            "ArmModel(config.arm)"
            if isinstance(model, ArmDescription) or whole_config(model)
            else None
        )
        raise ModelError(wrong_argument(user, "an ArmModel (ArmModel(config.arm))", model, fix))


def require_controller(config: object, user: str, *, optional: bool = False) -> None:
    """Raise :class:`ConfigError` unless ``config`` is the controller section.

    ``optional``: ``None`` (the section's defaults) is allowed too. Checked where a solver
    is built, once: never in a solve.
    """
    if isinstance(config, ControllerConfig) or (optional and config is None):
        return
    needs = "a ControllerConfig (the config's controller section)"
    fix = "config.controller" if whole_config(config) else None
    raise ConfigError(None, [wrong_argument(user, needs, config, fix)])


def start_joints(q_start: npt.ArrayLike, model: ArmModel) -> np.ndarray:
    """Validate a start pose and return it as a full, exactly coupled joint vector.

    Args:
        q_start: Every joint (n,) or the actuated ones (m,), model units (rad, or m for a
            prismatic joint).
        model: The arm (its chain: coupling and limits).

    Returns:
        (n,) joints, model units, within the limits, passive joints from their coupling.
        A start within the limits' 1e-9 tolerance is moved onto the limit.

    Raises:
        InvalidJointsError: not n or m finite numbers, or a passive value off its coupling.
        JointLimitError: a joint is outside its limits.
    """
    chain: Chain = model.chain
    n, m = chain.n, chain.m
    try:
        q = np.asarray(q_start, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InvalidJointsError(
            (), f"expected {n} or {m} joint values in model units, got {q_start!r}"
        ) from None
    values = q.tolist()
    if len(values) not in (n, m):
        names = ", ".join(chain.names)
        raise InvalidJointsError(
            values,
            f"expected {n} joint values ({names}) or the {m} actuated ones "
            f"({', '.join(chain.actuated)}), got {len(values)}",
        )
    if not all(map(math.isfinite, values)):
        raise InvalidJointsError(values, "joint values must be finite")
    q_act = q if len(values) == m and n != m else chain.actuated_of(q)
    if len(values) == n:
        coupled = chain.full(q_act)
        for i in chain.passive_index.tolist():
            residual = q[i] - coupled[i]
            if abs(residual) > COUPLING_TOLERANCE:
                raise InvalidJointsError(
                    values,
                    f"passive joint {chain.names[i]} = {q[i]:.6g} is {residual:.3g} off its "
                    f"coupling (tolerance {COUPLING_TOLERANCE:g}): pass {coupled[i]:.6g} or "
                    f"only the {m} actuated joints",
                )
    full = chain.full(q_act)
    if not chain.within_limits(full, LIMIT_TOLERANCE):
        model.check_limits(full, LIMIT_TOLERANCE)  # raises, naming the joint
    q_act = np.clip(q_act, chain.actuated_lower, chain.actuated_upper)
    # passive limits may be degrees converted: clip rather than trust the product's last bit
    return np.clip(couple(chain, q_act.tolist()), chain.lower, chain.upper)


def coupling_terms(chain: Chain) -> list[tuple[int, float, list[tuple[int, float]]]]:
    """Each passive joint as ``(index, offset, [(actuated index in q, coefficient)])``.

    Only the non-zero coefficients, so the sum is the exact one a person would write
    (the paper's wrist: ``0 + (−1)·θ2 + (−1)·θ3``, bit for bit −(θ2 + θ3)). Built once
    per chain (a chain never changes): :func:`couple` runs on every step of a path.
    """
    return _coupling(chain)[1]


def _coupling(chain: Chain) -> tuple[list[int], list[tuple[int, float, list[tuple[int, float]]]]]:
    """The actuated joints' indices and :func:`coupling_terms` of ``chain``, cached."""
    cached = _COUPLINGS.get(chain)
    if cached is None:
        terms = []
        for i in chain.passive_index.tolist():
            row = [
                (int(chain.actuated_index[k]), float(chain.C[i, k]))
                for k in range(chain.m)
                if chain.C[i, k] != 0.0
            ]
            terms.append((i, float(chain.c[i]), row))
        cached = (chain.actuated_index.tolist(), terms)
        _COUPLINGS[chain] = cached
    return cached


#: Each live chain's coupling (:func:`_coupling`), dropped with the chain.
_COUPLINGS: weakref.WeakKeyDictionary[
    Chain, tuple[list[int], list[tuple[int, float, list[tuple[int, float]]]]]
] = weakref.WeakKeyDictionary()


def couple(chain: Chain, q_act: list[float]) -> np.ndarray:
    """Full joint vector (n,) from the actuated values (m,), sums as :func:`coupling_terms`."""
    actuated, terms = _coupling(chain)
    q = [0.0] * chain.n
    for k, i in enumerate(actuated):
        q[i] = q_act[k]
    for i, offset, row in terms:
        v = offset
        for j, coef in row:
            v += coef * q[j]
        q[i] = v
    return np.array(q)


class IKSolver(abc.ABC):
    """Base class: a solver takes the TCP from a start pose to a target (module docstring).

    Args:
        model: The arm model (geometry, chain, limits).
        config: The controller section of the config (default: its defaults).

    Attributes:
        closed_form: The arm's closed form (built once), or ``None`` for an arm without.
        max_iterations: The solver's iteration cap, which a failure message names [-].

    Raises:
        ModelError: ``model`` is not an :class:`ArmModel` (e.g. ``config.arm``: pass
            ``ArmModel(config.arm)``).
        ConfigError: ``config`` is not the controller section (e.g. a whole config: pass
            ``config.controller``).
    """

    #: Short name recorded in :attr:`IKResult.solver`.
    name: str = "ik"

    def __init__(self, model: ArmModel, config: ControllerConfig | None = None):
        require_model(model, type(self).__name__)
        require_controller(config, type(self).__name__, optional=True)
        self.model = model
        self.chain = model.chain
        self.config = config if config is not None else ControllerConfig()
        self.max_iterations = self.config.max_iterations
        self.closed_form = closed_form_for(model.arm)
        chain = self.chain
        # the checks of every solve in Python floats, their constants computed once
        cf = self.closed_form
        self._solve_closed_form = None if cf is None else cf.solve_checked
        self._n, self._m = chain.n, chain.m
        self._act_index = chain.actuated_index.tolist()
        self._terms = coupling_terms(chain)
        self._lo, self._hi = chain.lower.tolist(), chain.upper.tolist()
        box = model.arm.target_box
        self._box = tuple((r.min, r.max) for r in (box.x_cm, box.y_cm, box.z_cm))
        self._scale = chain.scale.copy()
        self._scale.setflags(write=False)
        # n floats as bytes: np.frombuffer of them is a read-only joint array made in one
        # step, cheaper than np.array and setflags on the fast path
        self._pack_joints = struct.Struct(f"{chain.n}d").pack
        self._home = start_joints(model.home, model)  # the start when none is given
        self._home.setflags(write=False)
        self._from_home = JumpStart(self.name, self._home, chain.names, self._scale, model.fk_cm)
        # the last start given and its record: the same start again costs one comparison
        self._last_start: tuple[bytes | None, JumpStart] = (None, self._from_home)

    @abc.abstractmethod
    def solve(
        self, target: IKTarget | npt.ArrayLike, q_start: npt.ArrayLike | None = None
    ) -> IKResult:
        """Take the TCP from ``q_start`` to ``target``.

        Args:
            target: An :class:`IKTarget`, or (x, y, z) in the base frame [cm] for a
                position alone.
            q_start: Every joint (n,) or the actuated ones (m,), model units (rad, or m
                for a prismatic joint); passive values must agree with their coupling.
                ``None``: the home pose. The result's path starts here.

        Returns:
            The :class:`IKResult`: status, final joints, the path and the figures.

        Raises:
            InvalidTargetError: the target is not three finite numbers (or a bad approach).
            TargetOutsideBoxError: outside the arm's target box.
            UnreachableTargetError: out of reach within the limits (arms with a closed
                form); an iterative solve that cannot reach returns a result that did not
                converge, with its :class:`~mearm.ik.IKFailure`.
            InvalidJointsError, JointLimitError: a bad start (:func:`start_joints`).

        Never raises for numerics: a solve that stops short says so in the result.
        """

    def position_cm(self, target: IKTarget | npt.ArrayLike) -> tuple[float, float, float]:
        """The target's position as three floats [cm], checked against the target box.

        Raises:
            InvalidTargetError: not three finite numbers.
            TargetOutsideBoxError: outside the arm's target box.
        """
        p = target.position_cm if isinstance(target, IKTarget) else scalar_target_cm(target)
        (x0, x1), (y0, y1), (z0, z1) = self._box
        if not (x0 <= p[0] <= x1 and y0 <= p[1] <= y1 and z0 <= p[2] <= z1):
            check_in_box(p, self.model.arm)  # raises, naming the axis and the range
        return p

    def prepare(
        self, target: IKTarget | npt.ArrayLike, q_start: npt.ArrayLike | None = None
    ) -> tuple[IKTarget, np.ndarray, np.ndarray | None]:
        """Check the target and the start before anything moves.

        Returns:
            ``(target, q_start, q_closed_form)``: the target, the full start (n,) in model
            units (home for ``None``), and the closed-form solution (n,) — ``None`` for an
            arm without one.

        Raises:
            See :meth:`solve`.
        """
        target = IKTarget.of(target)
        p = self.position_cm(target)
        q_solution = None
        if self._solve_closed_form is not None:
            q_solution = np.array(self._solve_closed_form(p))
        return target, self._start(q_start), q_solution

    def _jump_start(self, q_start: npt.ArrayLike | None) -> JumpStart:
        """The start of a jump record (:meth:`IKResult.jump`), checked.

        The record's start TCP is computed when first read; a start equal to the last
        one (a (n,) or (m,) float array) is not checked again.

        Raises:
            InvalidJointsError, JointLimitError: see :func:`start_joints`.
        """
        if q_start is None:
            return self._from_home
        key = b""
        if type(q_start) is np.ndarray and q_start.dtype == float and q_start.ndim == 1:
            key = q_start.tobytes()
            last = self._last_start
            if key == last[0]:
                return last[1]
        q0 = self._start(q_start)
        q0.setflags(write=False)
        start = JumpStart(self.name, q0, self.chain.names, self._scale, self.model.fk_cm)
        if key:
            self._last_start = (key, start)
        return start

    def _jump(
        self,
        status: Status,
        target_cm: tuple[float, float, float],
        q: list[float],
        ee_cm: tuple[float, float, float],
        start: JumpStart,
        search_iterations: int = 0,
    ) -> IKResult:
        """The record of a solve that found joints ``q`` (n floats), not a path.

        See :meth:`IKResult.jump`. One that did not converge carries its
        :class:`IKFailure`.
        """
        q_array = np.frombuffer(self._pack_joints(*q))
        failure = None
        if status != "converged":
            failure = self.stop_failure(status, q_array, IKTarget(target_cm))
        return IKResult.jump(status, target_cm, q_array, ee_cm, start, search_iterations, failure)

    def _start(self, q_start: npt.ArrayLike | None) -> np.ndarray:
        """:func:`start_joints` in Python floats for a valid start; itself otherwise.

        The same values bit for bit (the same clipping, the same coupling sums); any start
        that is not plainly valid goes to :func:`start_joints`, which raises or clips.
        ``None`` is the home pose.
        """
        if q_start is None:
            return self._home.copy()
        n, m, act, lo, hi = self._n, self._m, self._act_index, self._lo, self._hi
        plain = isinstance(q_start, np.ndarray) and q_start.ndim == 1 and q_start.dtype == float
        q = q_start.tolist() if plain else None  # type: ignore[union-attr]
        if q is None or len(q) not in (n, m) or not math.isfinite(sum(q)):
            return start_joints(q_start, self.model)
        full = len(q) == n
        out = list(q) if full else [0.0] * n
        if not full:
            for k, i in enumerate(act):
                out[i] = q[k]
        for i, offset, terms in self._terms:
            v = offset
            for j, coef in terms:
                v += coef * out[j]
            if full and abs(q[i] - v) > COUPLING_TOLERANCE:
                return start_joints(q_start, self.model)
            out[i] = v
        for i in range(n):
            if not lo[i] - LIMIT_TOLERANCE <= out[i] <= hi[i] + LIMIT_TOLERANCE:
                return start_joints(q_start, self.model)
        for i in act:
            out[i] = min(max(out[i], lo[i]), hi[i])
        for i, offset, terms in self._terms:
            v = offset
            for j, coef in terms:
                v += coef * out[j]
            out[i] = min(max(v, lo[i]), hi[i])
        return np.array(out)

    def stop_failure(self, status: Status, q: npt.ArrayLike, target: IKTarget) -> IKFailure:
        """Why a solve that ended at ``q`` (model units, (n,)) with ``status`` stopped short.

        Classified by :func:`~mearm.ik.failure.blocking_joints` on the error the solvers
        minimise (position [cm] and, with an approach, the weighted direction error).
        """
        model, chain = self.model, self.chain
        q = np.asarray(q, dtype=float)
        p, J = model.fk_and_jacobian(q)
        e = target.position - p
        error_cm = float(np.linalg.norm(e))
        if target.approach is not None:
            a, J_a = model.approach_jacobian(q)
            J = np.vstack((J, APPROACH_WEIGHT_CM * J_a))
            e = np.concatenate((e, APPROACH_WEIGHT_CM * (np.asarray(target.approach) - a)))
        kind, blocked = blocking_joints(J @ chain.C, e, q, chain)
        if status == "max_iterations":
            text = (
                f"the solver reached its iteration cap ({self.max_iterations}) "
                f"{error_cm:.3f} cm from the target"
            )
        else:
            text = f"the solver stalled {error_cm:.3f} cm from the target"
        if target.approach is not None:
            off = approach_error_deg(model.approach(q), target.approach)
            if not off < APPROACH_TOLERANCE_DEG:
                text += f", the approach {off:.1f} deg off"
        if kind == "limit":
            held = ", ".join(
                f"{chain.names[i]} at {q[i] / chain.scale[i]:.4g} {chain.unit(i)}" for i in blocked
            )
            text += f": the joint limits block every way closer ({held})"
        elif kind == "singular" and target.approach is None:
            text += (
                ": at a singular pose no joint motion reduces the error "
                "(is the target out of reach?)"
            )
        elif kind == "singular" and error_cm * error_cm < self.config.tolerance_cm2:
            text += (
                ": the TCP is at the target, but no joint motion turns the approach closer "
                "(the arm cannot point it that way there)"
            )
        elif kind == "singular":
            text += (
                ": at a singular pose no joint motion reduces the error (is the target out "
                "of reach, or the approach one the arm cannot take there?)"
            )
        return IKFailure(kind, text)

    def _result(
        self,
        status: Status,
        target: IKTarget,
        q_path: np.ndarray,
        ee_path_cm: np.ndarray,
        *,
        method: Method = "direct",
        recovered_from: Status | None = None,
        failure: IKFailure | None = None,
        **counts: int,
    ) -> IKResult:
        """The record, with the final approach error when the target has an approach.

        A result that did not converge carries its :class:`IKFailure` (classified here
        unless given).
        """
        error_deg = None
        if target.approach is not None:
            error_deg = approach_error_deg(self.model.approach(q_path[-1]), target.approach)
        if status != "converged" and failure is None:
            failure = self.stop_failure(status, q_path[-1], target)
        return IKResult.from_paths(
            status,
            self.name,
            target.position,
            q_path,
            ee_path_cm,
            joint_names=self.chain.names,
            scale=self.chain.scale,
            approach=None if target.approach is None else np.array(target.approach),
            final_approach_error_deg=error_deg,
            method=method,
            recovered_from=recovered_from,
            failure=None if status == "converged" else failure,
            **counts,
        )
