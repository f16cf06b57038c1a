r"""PD-PIJ: the paper's PD-controlled pseudoinverse-Jacobian IK (SPEC §3), on Pinocchio.

At iteration t, with target :math:`s_d`:

.. math::
    e_t = s_d - FK(\theta_t), \qquad
    \Delta s = k_p e_t + k_d (e_t - e_{t-1}) \quad (e_{-1} = e_0), \qquad
    \Delta\theta = J^+(\theta_t)\, \Delta s, \qquad \theta_{t+1} = \theta_t + \Delta\theta

until :math:`|e|^2` is below the tolerance. Two modes (SPEC §3):

- ``paper``: θ ∈ R⁴ and J is the 3×4 Jacobian of all four DH joints; after each update
  the coupling θ4 = −(θ2 + θ3) is imposed again, overwriting θ4's own update.
- ``coupled``: θ = (θ1, θ2, θ3) and :math:`J_c = J C`, the exact Jacobian through the
  coupling (:data:`mearm.kinematics.COUPLING`).

Limits. The paper's rule: a joint whose update would take it outside its limits gets
Δθ = 0 for that iteration. θ4 has no servo: its limits are derived from θ2's and θ3's
(``JointLimits.as_list``: [−(max2 + max3), −(min2 + min3)]), i.e. exactly the range of
−(θ2 + θ3) over their box, so once θ2 and θ3 pass the rule the re-imposed θ4 is within
its limits too. Should custom limits ever make it not so, θ2 and θ3 are held for that
iteration, which keeps θ4 where it was. The comparisons are written so that a NaN
component also fails them and is held: no joint vector the solver produces, intermediate
or returned, is outside the limits or non-finite.

Beyond the paper (``safeguard``, on by default; ``false`` runs the bare algorithm):

1. When the rule holds a joint, the update becomes the bounded least-squares step for
   the same Δs (:func:`~mearm.ik.bounded.bounded_lstsq` on :math:`J_c`): joints stop on
   their limits and the others make up what they can, instead of freezing a joint whose
   full update would overshoot (which can leave the arm stuck at an error of tens of cm).
2. An update that would not lower |e| (the paper's 4-joint step can point the wrong way
   once θ4's share is overwritten) is rejected and replaced by the bounded step along
   :math:`k_p e`, halved until |e| falls. If none does, the solve stops as ``stalled``.

So |e| never rises. On the paper's 24 demo routes neither case occurs, and ``paper``
mode reproduces the bare algorithm iteration for iteration.

Cost: one Pinocchio pass (``computeFrameJacobian``, which also places the EE frame) and
one 3×4 SVD per iteration, scalars in Python floats, the paths in flat lists: under
10 µs per iteration (``tools/bench.py``).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from mearm.config import ControllerConfig
from mearm.ik.bounded import bounded_lstsq
from mearm.ik.pseudoinverse import PseudoInverse
from mearm.ik.result import IKResult, Status
from mearm.ik.solver import IKSolver
from mearm.kinematics import COUPLING, ArmModel
from mearm.kinematics.model import CM_PER_M

_LWA = pin.LOCAL_WORLD_ALIGNED
#: Backtracking halvings the safeguard tries before declaring a stall (step ≥ 1/512).
_MAX_HALVINGS = 9
#: A stall is less than this relative fall of |e| over ``stall_iterations`` updates.
_STALL_RELATIVE = 1e-6


class PdPij(IKSolver):
    """The PD-PIJ solver (SPEC §3) in ``paper`` or ``coupled`` mode.

    Args:
        model: The arm model (Pinocchio model, ``ee`` frame, joint limits).
        config: Gains, tolerance, iteration cap, mode, SVD cutoff / damping, safeguard.

    Example::

        model = ArmModel(config.robot)
        result = PdPij(model, config.controller).solve(model.home_rad, [-10.99, 49.70, 12.76])
        result.status, result.iterations  # ('converged', 62)
    """

    def __init__(self, model: ArmModel, config: ControllerConfig):
        super().__init__(model, config)
        self.mode = config.mode
        self.name = f"pdpij-{self.mode}"
        self._pin_model = model.model
        self._data = model.model.createData()  # own data: solvers never share state
        self._frame_id = model.ee_frame_id
        # Pinocchio works in metres: J [m/rad], so λ [cm/rad] becomes λ/100.
        damping_m = config.damping / CM_PER_M
        cols = 4 if self.mode == "paper" else 3
        self._pinv = PseudoInverse(3, cols, config.singular_value_cutoff, damping_m)
        # a view into Pinocchio's data: the EE position after each call on self._data
        self._ee_translation = self._data.oMf[self._frame_id].translation
        self._lower = model.lower_rad.tolist()
        self._upper = model.upper_rad.tolist()

    def _fk_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """EE position [m], (3,), and the 3×4 position Jacobian [m/rad] at ``q``.

        The position is a view into Pinocchio's data, valid until the next call.
        """
        J = pin.computeFrameJacobian(self._pin_model, self._data, q, self._frame_id, _LWA)
        return self._data.oMf[self._frame_id].translation, J[:3]

    def _bounded_step(self, q: list[float], J: np.ndarray, ds: np.ndarray) -> list[float]:
        """``q`` moved by the bounded least-squares step for ``J_c Δθ ≈ ds`` (safeguard).

        Joints that would cross a limit stop on it and the others make up what they can,
        instead of the paper's rule freezing them. Returns ``q`` itself when even that
        would take θ4 out of its limits (possible only with non-derived θ4 limits).
        """
        lo, hi = self._lower, self._upper
        x = bounded_lstsq(
            J @ COUPLING, ds, [lo[i] - q[i] for i in range(3)], [hi[i] - q[i] for i in range(3)]
        ).tolist()
        # clip again: q + (hi − q) may round one ulp past hi
        a, b, c = (min(max(q[i] + x[i], lo[i]), hi[i]) for i in range(3))
        d = -(b + c)
        return [a, b, c, d] if lo[3] <= d <= hi[3] else list(q)

    def _descent_step(
        self, q: list[float], J: np.ndarray, e: np.ndarray, err2: float, target_m: np.ndarray
    ) -> tuple[list[float], list[float], np.ndarray, float] | None:
        """The safeguard's step when an update would not lower |e|.

        The bounded least-squares step along ``kp·e`` (the steepest the limits allow),
        halved until |e| falls. Returns the accepted ``(q, p [m], J, |e|² [m²])``, or
        ``None`` when no step lowers |e|: a stall against the limits.
        """
        full = np.array(self._bounded_step(q, J, self.config.kp * e))
        start = np.array(q)
        lo, hi = self._lower, self._upper
        alpha = 1.0
        for _ in range(_MAX_HALVINGS + 1):
            cand = (start + alpha * (full - start)).tolist()
            alpha *= 0.5
            a, b, c = (min(max(cand[i], lo[i]), hi[i]) for i in range(3))
            cand = [a, b, c, -(b + c)]
            if not lo[3] <= cand[3] <= hi[3] or cand == q:
                continue
            p, Jn = self._fk_jacobian(np.array(cand))
            en = target_m - p
            en2 = float(en @ en)
            if en2 < err2:
                return cand, p.tolist(), Jn, en2
        return None

    def solve(self, q_start_rad: npt.ArrayLike, target_cm: npt.ArrayLike) -> IKResult:
        """Run PD-PIJ from ``q_start_rad`` to ``target_cm``.

        Args:
            q_start_rad: Start (θ1, θ2, θ3) or (θ1..θ4) [rad]; θ4 must be −(θ2 + θ3).
            target_cm: Target (x, y, z) in the base frame [cm].

        Returns:
            The :class:`IKResult`, with the joint and EE path of every iteration.

        Raises:
            TargetOutsideBoxError: the target is outside the Table 3 box.
            UnreachableTargetError: the target is in the box but out of reach.
            JointLimitError: the start is outside the joint limits.
            InvalidJointsError, InvalidTargetError: malformed input.
        """
        q0, target_cm, _ = self.prepare(q_start_rad, target_cm)
        cfg = self.config
        t = target_cm / CM_PER_M
        tx, ty, tz = t.tolist()
        tol2 = cfg.tolerance_cm2 / CM_PER_M**2
        kpd, kd = cfg.kp + cfg.kd, cfg.kd
        n_max, window, safeguard = cfg.max_iterations, cfg.stall_iterations, cfg.safeguard
        stall_factor = (1.0 - _STALL_RELATIVE) ** 2
        paper = self.mode == "paper"
        lo0, lo1, lo2, lo3 = self._lower
        hi0, hi1, hi2, hi3 = self._upper
        # Hot loop: scalars in Python floats, one Pinocchio call and one SVD per
        # iteration; every small NumPy operation avoided here saves about a microsecond.
        model, data, frame_id = self._pin_model, self._data, self._frame_id
        frame_jacobian, C, array = pin.computeFrameJacobian, COUPLING, np.array
        # plain J⁺: Eigen's SVD called directly (its threshold is the cutoff); damped: DLS
        svd = None if cfg.damping > 0 else self._pinv.svd
        pinv = self._pinv.solve
        p_view = self._ee_translation  # follows every Pinocchio call on self._data

        q = q0.tolist()
        J = frame_jacobian(model, data, q0, frame_id, _LWA)[:3]
        p = p_view.tolist()
        ex, ey, ez = tx - p[0], ty - p[1], tz - p[2]
        err2 = ex * ex + ey * ey + ez * ez
        # flat lists: extending one is the cheapest append; one conversion at the end
        q_path, ee_path = list(q), list(p)
        q_extend, ee_extend = q_path.extend, ee_path.extend
        px, py, pz = ex, ey, ez  # e_{-1} = e_0: no derivative kick
        mark_k, mark_err2 = 0, err2
        blocked = fallbacks = 0
        status: Status = "max_iterations"
        k = 0
        while True:
            if err2 < tol2:
                status = "converged"
                break
            if k == n_max:
                break
            ds = array((kpd * ex - kd * px, kpd * ey - kd * py, kpd * ez - kd * pz))
            Jm = J if paper else J.dot(C)  # .dot: a third of @'s overhead at 3×4
            dq = svd.compute(Jm).solve(ds) if svd is not None else pinv(Jm, ds)
            da, db, dc = dq.tolist()[:3]
            # the paper's limit rule; a NaN fails the comparison and is held too
            a, b, c = q[0] + da, q[1] + db, q[2] + dc
            held = False
            if not lo0 <= a <= hi0:
                a, held = q[0], True
            if not lo1 <= b <= hi1:
                b, held = q[1], True
            if not lo2 <= c <= hi2:
                c, held = q[2], True
            d = -(b + c)
            if not lo3 <= d <= hi3:  # only with non-derived θ4 limits: hold θ2, θ3
                b, c, d, held = q[1], q[2], q[3], True
            cand = [a, b, c, d]
            if held:
                blocked += 1
                if safeguard:  # slide along the limit instead of freezing the joint
                    cand = self._bounded_step(q, J, ds)
            J_c = frame_jacobian(model, data, array(cand), frame_id, _LWA)[:3]
            p = p_view.tolist()
            fx, fy, fz = tx - p[0], ty - p[1], tz - p[2]
            err2_c = fx * fx + fy * fy + fz * fz
            if safeguard and not err2_c < err2:
                step = self._descent_step(q, J, array((ex, ey, ez)), err2, t)
                if step is None:
                    status = "stalled"
                    break
                cand, p, J_c, err2_c = step
                fx, fy, fz = tx - p[0], ty - p[1], tz - p[2]
                fallbacks += 1
            k += 1
            q_extend(cand)
            ee_extend(p)
            px, py, pz, ex, ey, ez = ex, ey, ez, fx, fy, fz
            q, J, err2 = cand, J_c, err2_c
            if k - mark_k >= window:
                if err2 > stall_factor * mark_err2:
                    status = "stalled"
                    break
                mark_k, mark_err2 = k, err2
        return IKResult.from_paths(
            status,
            self.name,
            target_cm,
            np.array(q_path).reshape(-1, 4),
            np.array(ee_path).reshape(-1, 3) * CM_PER_M,
            blocked_steps=blocked,
            fallback_steps=fallbacks,
        )
