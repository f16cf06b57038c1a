r"""Many position targets at once: joints for each, or word that none were found.

For the callers that ask about many targets and need no path — a reach check over a
grid, seeds for a recovery, a workspace map — :func:`solve_batch` answers all of them in
one call. An arm that registers a closed form gets it, target by target (exact, about a
microsecond each); any other arm gets Gauss–Newton run on arrays: every target from
every seed at once, the DH product (:mod:`mearm.kinematics.dh`) and its Jacobian
evaluated for all of them in a few NumPy operations an iteration,

.. math:: \Delta q_a = (J C)^\top \left(J C (J C)^\top + \lambda^2 I\right)^{-1} e,
          \qquad e = s_d - FK(q)

the actuated joints clipped to their limits, a step halved until |e| falls and the
passive joints stay within theirs. A target is reached when one of its seeds brings
|e| below the tolerance; its other seeds then stop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mearm.config.base import short_repr
from mearm.ik.solver import APPROACH_TOLERANCE_DEG, APPROACH_WEIGHT_CM, require_model
from mearm.kinematics import ArmModel, closed_form_for
from mearm.kinematics.errors import InvalidTargetError, UnreachableTargetError

#: Default tolerance: a target is reached when |e| is below this [cm].
TOLERANCE_CM = 0.01
#: Seeds per target of the Gauss–Newton batch: home, the middle of the joint box, then
#: joints drawn from :data:`SEED` [-].
SEEDS = 16
#: The random generator's seed for the seeds: the same targets give the same answer.
SEED = 0
#: Iterations of the Gauss–Newton batch [-].
MAX_ITERATIONS = 60
#: Damping λ of the step [cm]: keeps it finite at a singular pose.
DAMPING_CM = 1e-3
#: Halvings of a step that does not lower |e| before a seed stops.
MAX_HALVINGS = 8


@dataclass(frozen=True)
class BatchSolution:
    """Joints for each of N targets, where found.

    Attributes:
        q: Every joint, model units, (N, n); NaN rows where not reached.
        reached: Whether joints within the limits put the TCP within the tolerance of
            the target (and its approach axis within that of the approach), (N,).
        error_cm: |e| of the best joints found [cm], (N,); 0 for a closed form's
            solution, inf where a closed form found none.
    """

    q: np.ndarray
    reached: np.ndarray
    error_cm: np.ndarray


def solve_batch(
    model: ArmModel,
    targets_cm: npt.ArrayLike,
    approach: npt.ArrayLike | None = None,
    *,
    tolerance_cm: float = TOLERANCE_CM,
    tolerance_deg: float = APPROACH_TOLERANCE_DEG,
    seeds: int = SEEDS,
    max_iterations: int = MAX_ITERATIONS,
) -> BatchSolution:
    """Joints putting the TCP at each target, within the limits (module docstring).

    Args:
        model: The arm model.
        targets_cm: (N, 3) positions in the base frame [cm]; the target box is not
            checked (a map may look past it).
        approach: The direction the tool's approach axis must point along (base frame),
            (3,) for every target or (N, 3); ``None``: position only. A closed form
            places the position only: with one, the approach is not checked.
        tolerance_cm: Reached when |e| is below this [cm] (Gauss–Newton).
        tolerance_deg: ... and the approach axis within this angle [deg].
        seeds: Starts per target (Gauss–Newton) [-].
        max_iterations: Updates per start (Gauss–Newton) [-].

    Raises:
        InvalidTargetError: targets that are not (N, 3) finite numbers (one target too
            is a list of one), or an approach that is not a finite non-zero (3,) or (N, 3).
        ModelError: ``model`` is not an :class:`ArmModel` (pass ``ArmModel(config.arm)``).
    """
    require_model(model, "solve_batch")
    try:
        targets = np.asarray(targets_cm, dtype=float)
    except (TypeError, ValueError):
        raise InvalidTargetError(
            f"targets_cm must be (N, 3) finite numbers [cm], got {short_repr(targets_cm)}"
        ) from None
    if targets.ndim != 2 or targets.shape[1] != 3 or not np.isfinite(targets).all():
        what = (
            f"shape {targets.shape}" if np.isfinite(targets).all() else "a value that is not finite"
        )
        one = " (one target: [[x, y, z]])" if targets.shape == (3,) else ""
        raise InvalidTargetError(f"targets_cm must be (N, 3) finite numbers [cm], got {what}{one}")
    closed_form = closed_form_for(model.arm)
    if closed_form is not None:
        return _closed_form_batch(model, closed_form.solve_list, targets)
    directions = None
    if approach is not None:
        try:
            a = np.broadcast_to(np.asarray(approach, dtype=float), targets.shape)
        except (TypeError, ValueError):
            a = np.full(targets.shape, np.nan)  # not numbers, or neither (3,) nor (N, 3)
        norm = np.linalg.norm(a, axis=1, keepdims=True)
        if not (np.isfinite(a).all() and (norm > 1e-9).all()):
            raise InvalidTargetError(
                "approach must be finite non-zero 3-vectors, (3,) or one per target "
                f"({len(targets)}, 3), got {short_repr(approach)}"
            )
        directions = a / norm
    return _newton_batch(
        model, targets, directions, tolerance_cm, tolerance_deg, seeds, max_iterations
    )


def _closed_form_batch(model: ArmModel, solve: object, targets: np.ndarray) -> BatchSolution:
    """The closed form target by target: exact, so no tolerance and no seeds."""
    n = model.chain.n
    q = np.full((len(targets), n), np.nan)
    reached = np.zeros(len(targets), bool)
    for k, t in enumerate(targets.tolist()):
        try:
            q[k] = solve(t)  # type: ignore[operator]
        except UnreachableTargetError:
            continue
        reached[k] = True
    return BatchSolution(q, reached, np.where(reached, 0.0, np.inf))


class _DHBatch:
    """The DH product and its position Jacobian for many joint vectors at once [cm]."""

    def __init__(self, model: ArmModel):
        arm = model.arm
        self.theta0 = np.radians([j.dh.theta_deg for j in arm.joints])
        self.d0 = np.array([j.dh.d_cm for j in arm.joints])
        self.a = np.array([j.dh.a_cm for j in arm.joints])
        alpha = np.radians([j.dh.alpha_deg for j in arm.joints])
        self.ca, self.sa = np.cos(alpha), np.sin(alpha)
        self.prismatic = model.chain.prismatic
        self.tcp = np.asarray(arm.tool.tcp_cm, dtype=float)

    def fk_and_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """TCP (P, 3) [cm], its rotation (P, 3, 3) and the Jacobian (P, 6, n) of ``q`` (P, n).

        The Jacobian's rows: linear [cm per model unit], then angular [rad per rad].
        """
        P, n = q.shape
        theta = self.theta0 + np.where(self.prismatic, 0.0, q)
        d = self.d0 + np.where(self.prismatic, q * 100.0, 0.0)
        ct, st = np.cos(theta), np.sin(theta)
        R = np.broadcast_to(np.eye(3), (P, 3, 3))
        o = np.zeros((P, 3))
        origins, axes = [], []
        for i in range(n):
            origins.append(o)
            axes.append(R[:, :, 2])
            ca, sa, c, s = self.ca[i], self.sa[i], ct[:, i], st[:, i]
            # Rz(θ) Rx(α) and the translation (a cos θ, a sin θ, d) of the row
            Ri = np.empty((P, 3, 3))
            Ri[:, 0, 0], Ri[:, 0, 1], Ri[:, 0, 2] = c, -ca * s, sa * s
            Ri[:, 1, 0], Ri[:, 1, 1], Ri[:, 1, 2] = s, ca * c, -sa * c
            Ri[:, 2, 0], Ri[:, 2, 1], Ri[:, 2, 2] = 0.0, sa, ca
            step = np.stack((self.a[i] * c, self.a[i] * s, d[:, i]), axis=1)
            o = o + np.einsum("pij,pj->pi", R, step)
            R = R @ Ri
        tcp = o + R @ self.tcp
        J = np.zeros((P, 6, n))
        for i in range(n):
            z = axes[i]
            if self.prismatic[i]:
                J[:, :3, i] = z * 100.0
            else:
                J[:, :3, i] = np.cross(z, tcp - origins[i])
                J[:, 3:, i] = z
        return tcp, R, J


def _newton_batch(
    model: ArmModel,
    targets: np.ndarray,
    approach: np.ndarray | None,
    tolerance_cm: float,
    tolerance_deg: float,
    seeds: int,
    max_iterations: int,
) -> BatchSolution:
    """Damped Gauss–Newton from ``seeds`` starts per target, all at once."""
    chain = model.chain
    N, m = len(targets), chain.m
    lo_a, hi_a = chain.actuated_lower, chain.actuated_upper
    rng = np.random.default_rng(SEED)
    starts = np.vstack(
        [chain.actuated_of(chain.home), (lo_a + hi_a) / 2, rng.uniform(lo_a, hi_a, (seeds, m))]
    )[:seeds]
    K = len(starts)
    dh = _DHBatch(model)
    C, c = chain.C, chain.c
    lower, upper = chain.lower - 1e-9, chain.upper + 1e-9
    axis = model.approach_axis
    w = APPROACH_WEIGHT_CM
    rows = 3 if approach is None else 6
    tol2, cos_tol = tolerance_cm**2, math.cos(math.radians(tolerance_deg))
    # every (target, seed) pair, target-major: pair p is target p // K
    owner = np.repeat(np.arange(N), K)
    goal = targets[owner]
    goal_a = None if approach is None else approach[owner]

    def measure(q_full: np.ndarray, at: np.ndarray) -> tuple[np.ndarray, ...]:
        """Residual (A, rows), |e|², whether the tolerances hold, J C (A, rows, m), |e_p|²."""
        p, R, J6 = dh.fk_and_jacobian(q_full)
        e_p = goal[at] - p
        err2_p = np.einsum("pi,pi->p", e_p, e_p)
        if goal_a is None:
            return e_p, err2_p, err2_p < tol2, J6[:, :3] @ C, err2_p
        a = R @ axis
        # d a / dt = ω × a: the approach rows of the Jacobian are −[a]× J_ω
        J_a = -np.cross(a[:, :, None], J6[:, 3:], axis=1)
        e = np.concatenate((e_p, w * (goal_a[at] - a)), axis=1)
        J = np.concatenate((J6[:, :3], w * J_a), axis=1) @ C
        met = (err2_p < tol2) & (np.einsum("pi,pi->p", a, goal_a[at]) > cos_tol)
        return e, np.einsum("pi,pi->p", e, e), met, J, err2_p

    every = np.arange(len(owner))
    q = np.tile(starts, (N, 1))
    e, err2, met, J, err2_p = measure(q @ C.T + c, every)
    alpha = np.ones(len(q))
    done = np.zeros(N, bool)
    done[owner[met]] = True
    active = np.flatnonzero(~done[owner])
    damping = np.eye(rows) * DAMPING_CM**2
    for _ in range(max_iterations):
        if len(active) == 0:
            break
        qa = q[active]
        dq = _bounded_step(J[active], e[active], qa, lo_a, hi_a, damping)
        cand = np.clip(qa + alpha[active, None] * dq, lo_a, hi_a)
        full = cand @ C.T + c
        e_new, err2_new, met_new, J_new, err2_p_new = measure(full, active)
        ok = (err2_new < err2[active]) & np.all((full >= lower) & (full <= upper), axis=1)
        took = active[ok]
        q[took], e[took], err2[took], J[took] = cand[ok], e_new[ok], err2_new[ok], J_new[ok]
        met[took], err2_p[took] = met_new[ok], err2_p_new[ok]
        alpha[took] = 1.0
        alpha[active[~ok]] *= 0.5
        done[owner[took[met[took]]]] = True
        live = ~done[owner[active]] & (alpha[active] >= 0.5**MAX_HALVINGS)
        active = active[live]
    # per target: the first seed that met the tolerances, else the closest
    met_by, err2_by = met.reshape(N, K), err2.reshape(N, K)
    best = np.where(met_by.any(axis=1), met_by.argmax(axis=1), err2_by.argmin(axis=1))
    pick = np.arange(N) * K + best
    reached = np.any(met_by, axis=1)
    q_full = np.clip(q[pick] @ C.T + c, chain.lower, chain.upper)
    q_full[~reached] = np.nan
    return BatchSolution(q_full, reached, np.sqrt(err2_p[pick]))


def _bounded_step(
    J: np.ndarray,
    e: np.ndarray,
    q: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    damping: np.ndarray,
) -> np.ndarray:
    """The damped step (A, m) for residuals ``e`` (A, r), each joint stopping on its limit.

    A joint the step would take past a limit moves onto it and the other joints are
    solved again for what is left of e, at most m times (:class:`~mearm.ik.NewtonIK`'s
    bounded step, for all rows at once): a clipped step alone crawls along a limit.
    """

    def damped(J: np.ndarray, e: np.ndarray) -> np.ndarray:
        Jt = J.transpose(0, 2, 1)
        return (Jt @ np.linalg.solve(J @ Jt + damping, e[:, :, None]))[:, :, 0]

    dq = damped(J, e)
    fixed = np.zeros(q.shape, bool)
    held = np.zeros(q.shape)  # the fixed joints' moves onto their limits
    for _ in range(q.shape[1]):
        end = q + dq
        new = ~fixed & ((end < lower) | (end > upper))
        if not new.any():
            break
        held[new] = (np.clip(end, lower, upper) - q)[new]
        fixed |= new
        free = np.where(fixed[:, None, :], 0.0, J)
        rest = e - (J @ held[:, :, None])[:, :, 0]
        dq = np.where(fixed, held, damped(free, rest))
    return dq
