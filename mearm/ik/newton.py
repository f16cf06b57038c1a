r"""Gauss–Newton IK for any arm: joints for a TCP target, fast; no path.

:class:`NewtonIK` is the generic solve :func:`~mearm.ik.fastest_solver` picks for an arm
that registers no closed form (for one that does, :class:`~mearm.ik.AnalyticSolver`). On
an arm with one it checks each target against it first, as every solver does.
Its record is one update from the start to the solution (:meth:`IKResult.jump`): the
path a servo follows comes from :class:`~mearm.ik.PdPij` (the paper's route generator);
this solves a target once, for a planner, a reachability check or a seed. It places the
TCP only (no approach direction).

It is Gauss–Newton on the actuated joints with the coupled Jacobian :math:`J C` (one
Pinocchio pass and one small SVD per iteration),

.. math:: \Delta q_a = (J C)^+ e, \qquad e = s_d - FK(q)

made a *bounded* step when it would cross a limit: each joint that would cross stops on
its limit and the others are solved again for what is left of e (at most m passes, m
the actuated joints); then halved until |e| falls.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from mearm.ik.pseudoinverse import PseudoInverse
from mearm.ik.result import IKResult, Status
from mearm.ik.solver import IKSolver, coupling_terms
from mearm.ik.target import IKTarget
from mearm.kinematics import ArmModel
from mearm.kinematics.errors import InvalidTargetError
from mearm.kinematics.model import CM_PER_M

#: Default tolerance: |e| below this [cm].
TOLERANCE_CM = 0.01
#: Halvings of a step that does not lower |e| before the solve stops as ``stalled``.
_MAX_HALVINGS = 10


class _Descent(NamedTuple):
    """One Gauss–Newton run: where it stopped, how, |e|² there [m²] and its updates."""

    q: list[float]
    status: Status
    err2: float
    e: list[float]
    iterations: int


class NewtonIK(IKSolver):
    """Gauss–Newton with bounded steps on the actuated joints (module docstring); any arm.

    Its settings are its own, not the controller config's (PD-PIJ's gains and cap).

    Args:
        model: The arm model.
        tolerance_cm: Converged when |e| is below this [cm].
        max_iterations: Updates before ``max_iterations`` [-], per start.
        cutoff: Singular values at or below this × the largest count as zero in J⁺ [-].
        restarts: Further starts tried when one stops short (a corner of the joint box
            can hold a local minimum): the middle of the box, then joints drawn from a
            fixed seed, the same for every solve [-].
        seed_table: About this many joint vectors on a grid over the actuated joints'
            box, with their TCPs: without a start a solve begins at the one whose TCP
            is nearest the target [-].
    """

    name = "Gauss-Newton"

    def __init__(
        self,
        model: ArmModel,
        tolerance_cm: float = TOLERANCE_CM,
        max_iterations: int = 50,
        cutoff: float = 1e-6,
        restarts: int = 16,
        seed_table: int = 512,
    ):
        super().__init__(model)
        if not tolerance_cm > 0:
            raise ValueError(f"tolerance_cm must be > 0, got {tolerance_cm!r}")
        if max_iterations < 1:
            raise ValueError(f"max_iterations must be >= 1, got {max_iterations!r}")
        chain = self.chain
        self.tolerance_cm = float(tolerance_cm)
        self.max_iterations = int(max_iterations)
        self._tol2 = (self.tolerance_cm / CM_PER_M) ** 2
        self._pin_model = model.model
        self._data = model.model.createData()
        self._frame_id = model.tcp_frame_id
        self._tcp = self._data.oMf[self._frame_id].translation  # a view, updated in place
        self._pinv = PseudoInverse(3, chain.m, cutoff).svd
        self._C = chain.C
        self._lower, self._upper = chain.lower.tolist(), chain.upper.tolist()
        self._act = chain.actuated_index.tolist()
        self._passive = coupling_terms(chain)
        rng = np.random.default_rng(0)
        lo_a, hi_a = chain.actuated_lower, chain.actuated_upper
        seeds = [(lo_a + hi_a) / 2] + list(rng.uniform(lo_a, hi_a, (max(restarts - 1, 0), chain.m)))
        self._restarts = [chain.full(s).tolist() for s in seeds[:restarts]]
        # the seed table: a grid over the actuated joints' box and its TCPs [m]
        per_joint = max(2, round(seed_table ** (1 / chain.m)))
        axes = [np.linspace(a, b, per_joint + 2)[1:-1] for a, b in zip(lo_a, hi_a, strict=True)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, chain.m)
        table = [chain.full(g) for g in grid]
        self._table_q = [q.tolist() for q in table]
        tcp = np.array([model.fk_cm(q) for q in table]) / CM_PER_M  # (K, 3) [m]
        # nearest TCP to t: argmin |p|² − 2 p·t (|t|² is the same for all), one product
        self._table_norm2 = np.einsum("ij,ij->i", tcp, tcp)  # (K,) [m²]
        self._table_minus_2tcp = np.ascontiguousarray(-2.0 * tcp.T)  # (3, K) [m]

    def _measure(self, q: list[float], t: tuple[float, ...]) -> tuple[list[float], np.ndarray]:
        """Error e [m] (list) and the coupled Jacobian J C (3, m) at ``q``."""
        J6 = pin.computeFrameJacobian(
            self._pin_model, self._data, np.array(q), self._frame_id, pin.LOCAL_WORLD_ALIGNED
        )
        p = self._tcp.tolist()
        return [t[0] - p[0], t[1] - p[1], t[2] - p[2]], J6[:3].dot(self._C)

    def _couple(self, q: list[float]) -> bool:
        """Set the passive joints of ``q`` in place; whether all are within their limits."""
        lo, hi = self._lower, self._upper
        ok = True
        for i, offset, terms in self._passive:
            v = offset
            for j, coef in terms:
                v += coef * q[j]
            q[i] = v
            ok = ok and lo[i] <= v <= hi[i]
        return ok

    def _bounded_step(self, q: list[float], Jc: np.ndarray, e: list[float]) -> list[float]:
        """The actuated step (m,) for ``Jc Δ ≈ e``, joints that would cross stopping on it.

        A joint whose step crosses its limit is fixed there, and the free ones are solved
        again for what is left; at most m passes. Small and bounded: not the exact box
        least squares, which the iteration does not need.
        """
        lo, hi, act = self._lower, self._upper, self._act
        m = len(act)
        fixed: dict[int, float] = {}
        b = np.array(e)
        dq = self._pinv.compute(Jc).solve(b).tolist()
        for _ in range(m):
            crossing = {}
            for k, i in enumerate(act):
                if k in fixed:
                    continue
                v = q[i] + dq[k]
                if v < lo[i]:
                    crossing[k] = lo[i] - q[i]
                elif v > hi[i]:
                    crossing[k] = hi[i] - q[i]
            if not crossing:
                break
            fixed.update(crossing)
            if len(fixed) == m:
                break
            J_free = Jc.copy()
            rest = b.copy()
            for k, d in fixed.items():
                rest -= J_free[:, k] * d
                J_free[:, k] = 0.0
            dq = self._pinv.compute(J_free).solve(rest).tolist()
        for k, d in fixed.items():
            dq[k] = d
        return dq

    def solve(
        self, target: IKTarget | npt.ArrayLike, q_start: npt.ArrayLike | None = None
    ) -> IKResult:
        """Iterate from ``q_start`` to ``target`` (see :class:`IKSolver`).

        Without a start, from the seed table's entry whose TCP is nearest the target
        (the record's path still starts at home). If it stops short, from each restart
        in turn; the first that converges is returned, else the closest stop.
        ``search_iterations`` counts every start's updates.

        On an arm with a closed form the target is first checked against it, as by every
        solver: one out of reach within the limits raises, where on an arm without one the
        result says how the search stopped short.

        Raises:
            InvalidTargetError: also for a target with an approach direction.
            UnreachableTargetError: out of reach within the limits (an arm with a closed
                form; see :meth:`IKSolver.solve`).
        """
        if isinstance(target, IKTarget) and target.approach is not None:
            raise InvalidTargetError(
                f"NewtonIK places the TCP only, got the approach {target.approach}: "
                "use PdPij or MinkSolver for an approach direction"
            )
        x, y, z = self.position_cm(target)
        if self._solve_closed_form is not None:
            # the arm's closed form answers reach as every solver's checks do (prepare):
            # an unreachable target raises here, not after every restart has stopped short
            self._solve_closed_form((x, y, z))
        start = self._jump_start(q_start)
        t = (x / CM_PER_M, y / CM_PER_M, z / CM_PER_M)
        if q_start is None:
            d2 = self._table_norm2 + np.dot(t, self._table_minus_2tcp)  # |p − t|² − |t|²
            q = list(self._table_q[int(np.argmin(d2))])
        else:
            q = start.q.tolist()
        best = self._descend(q, t)
        total = best.iterations
        for seed in self._restarts:
            if best.status == "converged":
                break
            run = self._descend(list(seed), t)
            total += run.iterations
            if run.status == "converged" or run.err2 < best.err2:
                best = run
        e = best.e
        ee = ((t[0] - e[0]) * CM_PER_M, (t[1] - e[1]) * CM_PER_M, (t[2] - e[2]) * CM_PER_M)
        return self._jump(best.status, (x, y, z), best.q, ee, start, total)

    def _descend(self, q: list[float], t: tuple[float, float, float]) -> _Descent:
        """Gauss–Newton from ``q`` (n,) [model units] towards ``t`` [m]."""
        lo, hi, act, tol2 = self._lower, self._upper, self._act, self._tol2
        e, Jc = self._measure(q, t)
        err2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2]
        status: Status = "max_iterations"
        k = 0
        while True:
            if err2 < tol2:
                status = "converged"
                break
            if k == self.max_iterations:
                break
            dq = self._bounded_step(q, Jc, e)
            alpha = 1.0
            for _ in range(_MAX_HALVINGS + 1):
                cand = list(q)
                for j, i in enumerate(act):  # clip: q + (hi − q) may round one ulp past hi
                    cand[i] = min(max(q[i] + alpha * dq[j], lo[i]), hi[i])
                if self._couple(cand):
                    e_new, Jc_new = self._measure(cand, t)
                    err2_new = e_new[0] ** 2 + e_new[1] ** 2 + e_new[2] ** 2
                    if err2_new < err2:
                        break
                alpha *= 0.5
            else:
                status = "stalled"
                break
            q, e, Jc, err2 = cand, e_new, Jc_new, err2_new
            k += 1
        return _Descent(q, status, err2, e, k)
