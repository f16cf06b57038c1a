r"""PD-PIJ: the paper's PD-controlled pseudoinverse-Jacobian IK (paper §3), for any arm.

At iteration t, with target :math:`s_d`:

.. math::
    e_t = s_d - FK(\theta_t), \qquad
    \Delta s = k_p e_t + k_d (e_t - e_{t-1}) \quad (e_{-1} = e_0), \qquad
    \Delta\theta = J^+(\theta_t)\, \Delta s, \qquad \theta_{t+1} = \theta_t + \Delta\theta

until :math:`|e|^2` is below the tolerance. With ``n`` joints of which ``m`` are actuated
and the coupling :math:`q = C q_a + c` (:class:`~mearm.kinematics.Chain`), two modes:

- ``paper``: θ holds all n joints and J is the 3×n Jacobian; after each update every
  passive joint is set from its coupling again, overwriting its own update (the paper's
  θ4 = −(θ2 + θ3)).
- ``coupled``: θ = :math:`q_a` and :math:`J_c = J C`, the exact Jacobian through the
  coupling.

Approach. A target with an approach direction :math:`a_d` (the tool's approach axis
:math:`a(\theta)` must point along it) stacks a weighted direction error under the
position error, and the approach Jacobian :math:`J_a` (:meth:`ArmModel.approach_jacobian`)
under J:

.. math:: e = \begin{bmatrix} s_d - s \\ w (a_d - a) \end{bmatrix}, \qquad
          J = \begin{bmatrix} J_s \\ w J_a \end{bmatrix}

with w = :data:`~mearm.ik.solver.APPROACH_WEIGHT_CM` [cm]. It has converged when
:math:`|s_d - s|^2` is below the tolerance and the angle between a and :math:`a_d` below
:data:`~mearm.ik.solver.APPROACH_TOLERANCE_DEG`. A rotation about the approach axis
changes neither error, so J⁺ (the least-norm step) leaves such a joint (a wrist roll)
where it starts.

Limits. The paper's rule: an actuated joint whose update would take it outside its limits
gets Δθ = 0 for that iteration. A passive joint's limits default to the range of its
coupling over the actuated joints' box, so once they pass the rule it is within its
limits too. Should custom limits make it not so, the actuated joints it depends on are
held for that iteration, which keeps it where it was. The comparisons are written so that
a NaN component also fails them and is held: no joint vector the solver produces,
intermediate or returned, is outside the limits or non-finite.

Beyond the paper (``safeguard``, on by default; ``false`` runs the bare algorithm):

1. When the rule holds a joint, the update becomes the bounded least-squares step for
   the same Δs (:func:`~mearm.ik.bounded.bounded_lstsq` on :math:`J C`): joints stop on
   their limits and the others make up what they can, instead of freezing a joint whose
   full update would overshoot (which can leave the arm stuck at an error of tens of cm).
2. An update that would not lower |e| (the paper's n-joint step can point the wrong way
   once the passive joints' share is overwritten) is rejected and replaced by the bounded
   step along :math:`k_p e`, halved until |e| falls. If none does, the solve stops as
   ``stalled``.

So along PD-PIJ's own updates |e| never rises. On the paper's 24 demo routes neither
case occurs, and ``paper`` mode reproduces the bare algorithm iteration for iteration.

Recovery (:mod:`mearm.ik.recovery`; on with the safeguard, or by the ``recover``
argument). PD-PIJ is local: from a start against the limits the target can lie behind a
corner of the joint box that no descent leaves, and the solve stops short (``stalled``,
or ``max_iterations``). The attempt is then discarded — none of it is sent — and the
path becomes a joint-space move from the start, at the controller's pace, to a
solution: the closed form's where the arm registers one, else one PD-PIJ reaches from
other starts (multi-start). The record says so (``method``, ``recovered_from``);
``iterations`` counts the path's updates and ``search_iterations`` the discarded ones.
A solve PD-PIJ converges on by itself is never touched, so the demo's iteration counts
stay the paper's. If nothing reaches, the record is PD-PIJ's own, not converged, with
its :class:`~mearm.ik.IKFailure`.

Cost: one Pinocchio pass (``computeFrameJacobian``, which also places the TCP frame) and
one small SVD per iteration, scalars in Python floats, the paths in flat lists: about
10 µs per iteration (``tools/bench.py``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from mearm.config import ControllerConfig
from mearm.ik import recovery
from mearm.ik.bounded import bounded_lstsq
from mearm.ik.failure import IKFailure
from mearm.ik.pseudoinverse import PseudoInverse
from mearm.ik.reach import ReachBound
from mearm.ik.result import IKResult, Status
from mearm.ik.solver import (
    APPROACH_TOLERANCE_DEG,
    APPROACH_WEIGHT_CM,
    IKSolver,
    coupling_terms,
    require_controller,
    require_model,
)
from mearm.ik.target import IKTarget
from mearm.kinematics import ArmModel
from mearm.kinematics.model import CM_PER_M

_LWA = pin.LOCAL_WORLD_ALIGNED
#: Backtracking halvings the safeguard tries before declaring a stall (step ≥ 1/512).
_MAX_HALVINGS = 9
#: A stall is less than this relative fall of |e| over ``stall_iterations`` updates.
_STALL_RELATIVE = 1e-6

#: One evaluation: TCP [m] (list), stacked J, stacked error e (list), |e_pos|² [m²],
#: |e|² [m²] (the safeguard's merit) and whether the approach is met.
_Measure = tuple[list[float], np.ndarray, list[float], float, float, bool]


class _Run(NamedTuple):
    """PD-PIJ's own updates from one start.

    The status, the flat joint [model units] and TCP [m] paths (row after row), and the
    limit rule's and the safeguard's counts.
    """

    status: Status
    q_path: list[float]
    ee_path: list[float]
    blocked: int
    fallbacks: int


class PdPij(IKSolver):
    """The PD-PIJ solver (paper §3) in ``paper`` or ``coupled`` mode, for any arm.

    Args:
        model: The arm model (Pinocchio model, ``tcp`` frame, chain, limits).
        config: Gains, tolerance, iteration cap, mode, SVD cutoff / damping, safeguard.
        recover: Whether a solve that stops short is recovered (module docstring);
            ``None`` (the default) follows ``config.safeguard``, so ``safeguard: false``
            still runs the bare paper algorithm.

    Attributes:
        recover: Whether stops are recovered.

    Raises:
        ModelError: ``model`` is not an :class:`ArmModel` (pass ``ArmModel(config.arm)``).
        ConfigError: ``config`` is not the controller section (pass ``config.controller``).

    Example::

        model = ArmModel(config.arm)
        result = PdPij(model, config.controller).solve([-10.99, 49.70, 12.76], model.home)
        result.status, result.iterations  # ('converged', 62)
    """

    def __init__(self, model: ArmModel, config: ControllerConfig, *, recover: bool | None = None):
        require_model(model, "PdPij")
        require_controller(config, "PdPij")
        self.name = f"pdpij-{config.mode}"
        super().__init__(model, config)
        self.recover = config.safeguard if recover is None else recover
        self._recovery = recovery.Recovery(
            model.chain, model.home, model.arm.target_box.z_cm.min, config
        )
        self._reach = ReachBound(model, config.tolerance_cm2, APPROACH_TOLERANCE_DEG)
        self.mode = config.mode
        self._pin_model = model.model
        self._data = model.model.createData()  # own data: solvers never share state
        self._frame_id = model.tcp_frame_id
        chain = self.chain
        # Pinocchio works in metres: J [m/rad], so λ [cm/rad] becomes λ/100.
        damping_m = config.damping / CM_PER_M
        cols = chain.n if self.mode == "paper" else chain.m
        self._pinv = {
            rows: PseudoInverse(rows, cols, config.singular_value_cutoff, damping_m)
            for rows in (3, 6)
        }
        # views into Pinocchio's data: the TCP pose after each call on self._data
        self._tcp_translation = self._data.oMf[self._frame_id].translation
        self._tcp_rotation = self._data.oMf[self._frame_id].rotation
        self._axis = model.approach_axis
        self._C = chain.C
        self._lower = chain.lower.tolist()
        self._upper = chain.upper.tolist()
        self._act = chain.actuated_index.tolist()
        self._passive = coupling_terms(chain)

    # ----------------------------------------------------------------- pieces

    def _measure(self, q: np.ndarray, t: list[float], a_d: tuple[float, ...] | None) -> _Measure:
        """Evaluate the TCP, the (stacked) Jacobian and error at ``q``; see ``_Measure``."""
        J6 = pin.computeFrameJacobian(self._pin_model, self._data, q, self._frame_id, _LWA)
        p = self._tcp_translation.tolist()
        ex, ey, ez = t[0] - p[0], t[1] - p[1], t[2] - p[2]
        err2 = ex * ex + ey * ey + ez * ez
        if a_d is None:
            return p, J6[:3], [ex, ey, ez], err2, err2, True
        w = APPROACH_WEIGHT_CM / CM_PER_M
        a = self._tcp_rotation.dot(self._axis)
        J = np.vstack((J6[:3], (-w) * pin.skew(a).dot(J6[3:])))
        al = a.tolist()
        fx, fy, fz = w * (a_d[0] - al[0]), w * (a_d[1] - al[1]), w * (a_d[2] - al[2])
        cos = al[0] * a_d[0] + al[1] * a_d[1] + al[2] * a_d[2]
        met = cos >= math.cos(math.radians(APPROACH_TOLERANCE_DEG))
        return p, J, [ex, ey, ez, fx, fy, fz], err2, err2 + fx * fx + fy * fy + fz * fz, met

    def _couple(self, cand: list[float], q: list[float]) -> tuple[list[float], bool]:
        """Set the passive joints of ``cand`` from its actuated ones, in place.

        A passive joint leaving its limits holds the actuated joints it depends on
        (their values in ``q``). Returns ``(cand, held)``; ``cand`` is ``q`` itself if
        even that cannot keep every passive joint within its limits.
        """
        lo, hi = self._lower, self._upper
        held = False
        for _ in range(len(self._passive) + 1):
            bad = None
            for i, offset, terms in self._passive:
                v = offset
                for j, coef in terms:
                    v += coef * cand[j]
                cand[i] = v
                if not lo[i] <= v <= hi[i]:
                    bad = terms
                    break
            if bad is None:
                return cand, held
            held = True
            if all(cand[j] == q[j] for j, _ in bad):
                break
            for j, _ in bad:
                cand[j] = q[j]
        return list(q), True

    def _bounded_step(self, q: list[float], J: np.ndarray, ds: np.ndarray) -> list[float]:
        """``q`` moved by the bounded least-squares step for ``J C Δq_a ≈ ds`` (safeguard).

        Joints that would cross a limit stop on it and the others make up what they can,
        instead of the paper's rule freezing them. Returns ``q`` itself when even that
        would take a passive joint out of its limits (possible only with custom limits).
        """
        lo, hi, act = self._lower, self._upper, self._act
        x = bounded_lstsq(
            J @ self._C, ds, [lo[i] - q[i] for i in act], [hi[i] - q[i] for i in act]
        ).tolist()
        cand = list(q)
        for k, i in enumerate(act):  # clip again: q + (hi − q) may round one ulp past hi
            cand[i] = min(max(q[i] + x[k], lo[i]), hi[i])
        cand, held = self._couple(cand, q)
        return list(q) if held else cand

    def _descent_step(
        self,
        q: list[float],
        J: np.ndarray,
        e: list[float],
        merit: float,
        t: list[float],
        a_d: tuple[float, ...] | None,
    ) -> tuple[list[float], _Measure] | None:
        """The safeguard's step when an update would not lower |e|.

        The bounded least-squares step along ``kp·e`` (the steepest the limits allow),
        halved until |e| falls. Returns the accepted ``(q, measure)``, or ``None`` when no
        step lowers |e|: a stall against the limits.
        """
        full = self._bounded_step(q, J, self.config.kp * np.array(e))
        lo, hi = self._lower, self._upper
        alpha = 1.0
        for _ in range(_MAX_HALVINGS + 1):
            cand = list(q)
            for i in self._act:
                cand[i] = min(max(q[i] + alpha * (full[i] - q[i]), lo[i]), hi[i])
            alpha *= 0.5
            cand, held = self._couple(cand, q)
            if held or cand == q:
                continue
            measure = self._measure(np.array(cand), t, a_d)
            if measure[4] < merit:
                return cand, measure
        return None

    # ----------------------------------------------------------------- solve

    def solve(
        self, target: IKTarget | npt.ArrayLike, q_start: npt.ArrayLike | None = None
    ) -> IKResult:
        """Run PD-PIJ from ``q_start`` to ``target``; recover if it stops short.

        Args:
            target: An :class:`IKTarget` (position [cm] and optional approach), or
                (x, y, z) [cm].
            q_start: Every joint (n,) or the actuated ones (m,), model units; passive
                values must agree with their coupling. ``None``: home.

        Returns:
            The :class:`IKResult`, with the joint and TCP path of every update. Its
            ``method`` says how the path was made: ``direct`` (PD-PIJ's own updates), or
            ``closed_form`` / ``multi_start`` (the recovery, see :attr:`recover`).

        Raises:
            TargetOutsideBoxError: the target is outside the arm's target box.
            UnreachableTargetError: out of reach (arms with a closed form).
            JointLimitError: the start is outside the joint limits.
            InvalidJointsError, InvalidTargetError: malformed input.
        """
        target, q0, q_solution = self.prepare(target, q_start)
        t = (target.position / CM_PER_M).tolist()
        run = self._iterate(q0, t, target.approach)
        if run.status != "converged" and self.recover:
            return self._recover(q0, t, target, q_solution, run)
        return self._run_result(run, target)

    def _run_result(
        self, run: _Run, target: IKTarget, searched: int = 0, failure: IKFailure | None = None
    ) -> IKResult:
        """The record of PD-PIJ's own updates (``method`` ``direct``)."""
        n = self.chain.n
        return self._result(
            run.status,
            target,
            np.array(run.q_path).reshape(-1, n),
            np.array(run.ee_path).reshape(-1, 3) * CM_PER_M,
            blocked_steps=run.blocked,
            fallback_steps=run.fallbacks,
            search_iterations=searched,
            failure=failure,
        )

    # ----------------------------------------------------------------- recovery

    def _met(self, t: list[float], a_d: tuple[float, ...] | None) -> recovery.Measure:
        tol2 = self.config.tolerance_cm2 / CM_PER_M**2

        def measure(q: np.ndarray) -> tuple[list[float], bool]:
            p, _, _, err2, _, met = self._measure(q, t, a_d)
            return p, err2 < tol2 and met

        return measure

    def _recover(
        self,
        q0: np.ndarray,
        t: list[float],
        target: IKTarget,
        q_solution: np.ndarray | None,
        run: _Run,
    ) -> IKResult:
        """The record of the recovery's move after PD-PIJ stopped short (``run``).

        If no solution has a safe move (:class:`~mearm.ik.recovery.Recovery`), PD-PIJ's
        own record, not converged, with its failure.
        """
        a_d = target.approach
        measure = self._met(t, a_d)
        n = self.chain.n

        def solve_from(seed: np.ndarray) -> tuple[np.ndarray | None, int]:
            attempt = self._iterate(seed, t, a_d, safeguard=False)
            goal = np.array(attempt.q_path[-n:]) if attempt.status == "converged" else None
            return goal, len(attempt.q_path) // n - 1

        closed = q_solution if q_solution is not None and measure(q_solution)[1] else None
        if closed is None and self._reach.beyond(t, a_d):
            # no pose meets the stopping rule: every seed would run to its cap and fail
            failure = self.stop_failure(run.status, run.q_path[-n:], target)
            return self._run_result(run, target, len(run.q_path) // n - 1, failure)
        tcp0 = self._measure(q0, t, a_d)[0]
        found = self._recovery.find(
            q0, tcp0[2] * CM_PER_M, t[2] * CM_PER_M, closed, measure, solve_from
        )
        searched = len(run.q_path) // n - 1 + found.searched
        if found.path is None:
            failure = self.stop_failure(run.status, run.q_path[-n:], target)
            if found.floor_cm is not None:
                failure = IKFailure(
                    failure.kind,
                    f"{failure.message}; every joint-space move to a solution would take the "
                    f"TCP below z = {found.floor_cm:.4g} cm",
                )
            return self._run_result(run, target, searched, failure)
        q_rows, tcp_rows = found.path
        return self._result(
            "converged",
            target,
            np.vstack([q0, *q_rows]),
            np.array([tcp0, *tcp_rows]) * CM_PER_M,
            method=found.method,
            recovered_from=run.status,
            search_iterations=searched,
        )

    # ----------------------------------------------------------------- iterate

    def _iterate(  # noqa: PLR0915 (the paper's loop, step by step, reads as one)
        self,
        q0: np.ndarray,
        t: list[float],
        a_d: tuple[float, ...] | None,
        *,
        safeguard: bool | None = None,
    ) -> _Run:
        """PD-PIJ's own updates from ``q0`` (n,) towards ``t`` [m]: the paper's loop.

        ``safeguard`` overrides the config's (the multi-start's seeds run without).
        """
        cfg = self.config
        rows = 3 if a_d is None else 6
        tol2 = cfg.tolerance_cm2 / CM_PER_M**2
        kpd, kd = cfg.kp + cfg.kd, cfg.kd
        n_max, window = cfg.max_iterations, cfg.stall_iterations
        safeguard = cfg.safeguard if safeguard is None else safeguard
        stall_factor = (1.0 - _STALL_RELATIVE) ** 2
        paper = self.mode == "paper"
        lo, hi, act = self._lower, self._upper, self._act
        # Hot loop: scalars in Python floats, one Pinocchio call and one SVD per
        # iteration; every small NumPy operation avoided here saves about a microsecond.
        C, array, measure, couple = self._C, np.array, self._measure, self._couple
        # plain J⁺: Eigen's SVD called directly (its threshold is the cutoff); damped: DLS
        svd = None if cfg.damping > 0 else self._pinv[rows].svd
        pinv = self._pinv[rows].solve
        steps = range(rows)

        q = q0.tolist()
        p, J, e, err2, merit, met = measure(q0, t, a_d)
        # flat lists: extending one is the cheapest append; one conversion at the end
        q_path, ee_path = list(q), list(p)
        q_extend, ee_extend = q_path.extend, ee_path.extend
        e_prev = e  # e_{-1} = e_0: no derivative kick
        mark_k, mark_merit = 0, merit
        blocked = fallbacks = 0
        status: Status = "max_iterations"
        k = 0
        while True:
            if err2 < tol2 and met:
                status = "converged"
                break
            if k == n_max:
                break
            ds = array([kpd * e[i] - kd * e_prev[i] for i in steps])
            Jm = J if paper else J.dot(C)  # .dot: a third of @'s overhead at 3×4
            dq = (svd.compute(Jm).solve(ds) if svd is not None else pinv(Jm, ds)).tolist()
            # the paper's limit rule; a NaN fails the comparison and is held too
            cand = list(q)
            held = False
            for j, i in enumerate(act):
                v = q[i] + (dq[i] if paper else dq[j])
                if lo[i] <= v <= hi[i]:
                    cand[i] = v
                else:
                    held = True
            cand, held_passive = couple(cand, q)
            if held or held_passive:
                blocked += 1
                if safeguard:  # slide along the limit instead of freezing the joint
                    cand = self._bounded_step(q, J, ds)
            new = measure(array(cand), t, a_d)
            if safeguard and not new[4] < merit:
                step = self._descent_step(q, J, e, merit, t, a_d)
                if step is None:
                    status = "stalled"
                    break
                cand, new = step
                fallbacks += 1
            k += 1
            q_extend(cand)
            ee_extend(new[0])
            e_prev = e
            q = cand
            _, J, e, err2, merit, met = new
            if k - mark_k >= window:
                if merit > stall_factor * mark_merit:
                    status = "stalled"
                    break
                mark_k, mark_merit = k, merit
        return _Run(status, q_path, ee_path, blocked, fallbacks)
