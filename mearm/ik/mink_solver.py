r"""The mink cross-check: the arm in MuJoCo, solved as a QP with the coupling exact.

An independent route to the joint solution :class:`~mearm.ik.PdPij` finds, for any arm:
the arm's chain built for MuJoCo from its description by the twin's builder
(:func:`mearm.kinematics.mjspec.arm_spec`, not through the URDF Pinocchio reads), a
:class:`mink.FrameTask` on a ``tcp`` site, :class:`mink.ConfigurationLimit` for the joint
limits and every passive joint's coupling as an equality constraint of every QP. MuJoCo
equalities cannot express an affine function of several joints, so the coupling is a
small custom task, :class:`CouplingTask`, passed to :func:`mink.solve_ik` as a
constraint: ``A Δq = −e`` restores it after every step.

The chain has no jaws, so the MuJoCo joints are exactly the chain's, in order; its
``tcp`` site sits where Pinocchio's ``tcp`` frame is.

Orientation. The site's z axis is the tool's approach axis. Without an approach the frame
task's orientation cost is zero. With one, the target rotation is the site's current
rotation turned by the smallest rotation taking the approach axis onto the desired
direction, so the orientation error is that rotation alone; its cost is zero about the
site's z axis, so a roll about the approach axis is free (and, as the QP's least-norm
step, stays where it starts).

The frame task runs dead-beat steps (gain 1, ``dt`` = 1): this solver is a cross-check of
where PD-PIJ arrives, not of its path, and converges in a handful of QPs.
"""

from __future__ import annotations

import math

import mink
import mujoco
import numpy as np
import numpy.typing as npt
import qpsolvers

from mearm.config import ControllerConfig
from mearm.ik.errors import QPSolverError
from mearm.ik.result import IKResult, Status
from mearm.ik.solver import APPROACH_TOLERANCE_DEG, APPROACH_WEIGHT_CM, IKSolver
from mearm.ik.target import IKTarget
from mearm.kinematics import TCP_FRAME, ArmModel, Chain
from mearm.kinematics.errors import ModelError
from mearm.kinematics.mjspec import arm_spec, quat
from mearm.kinematics.model import CM_PER_M

TCP_SITE = TCP_FRAME
_DT = 1.0  # mink returns Δq / dt; with dt = 1 the velocity is the step


def mujoco_model(model: ArmModel) -> mujoco.MjModel:
    """The arm's chain in MuJoCo with the ``tcp`` site's z axis along the approach axis.

    The twin's own chain (:func:`~mearm.kinematics.mjspec.arm_spec`): the joints exactly
    the chain's, in order, no jaws.

    Raises:
        ModelError: MuJoCo refuses the model, or its joints are not the chain's.
    """
    spec = arm_spec(model.arm)
    spec.compiler.boundmass = spec.compiler.boundinertia = 1e-9  # kinematics only
    # the site's z axis is the tool's approach axis, so a roll about it is one cost entry
    spec.site(TCP_SITE).quat = quat(_turn_onto(np.array([0.0, 0.0, 1.0]), model.approach_axis))
    try:
        mj_model = spec.compile()
    except ValueError as exc:
        raise ModelError(f"MuJoCo refused the arm's model: {exc}") from None
    names = tuple(mj_model.joint(i).name for i in range(mj_model.njnt))
    if names != model.chain.names:
        raise ModelError(
            f"MuJoCo model joints are {list(names)}; expected {list(model.chain.names)}"
        )
    return mj_model


class CouplingTask(mink.Task):
    r"""Every passive joint's coupling as one task row each.

    .. math:: e(q) = q_p - C_p\,q_a - c_p, \qquad J = [\,I_p \text{ at } p\,;\,
              -C_p \text{ at } a\,]

    (the paper's wrist: e = θ4 + θ2 + θ3, J = [0, 1, 1, 1]). Passed in ``constraints``
    of :func:`mink.solve_ik` it is met exactly by every step.

    Args:
        model: MuJoCo model whose joints are the chain's, in order.
        chain: The chain (coupling matrix in model units).
        gain: Task gain in [0, 1]; 1 closes any residual in one step.
    """

    def __init__(self, model: mujoco.MjModel, chain: Chain, gain: float = 1.0):
        passive = chain.passive_index.tolist()
        self.k = len(passive)
        super().__init__(cost=np.ones(self.k), gain=gain)
        qpos = [int(model.joint(name).qposadr[0]) for name in chain.names]
        dof = [int(model.joint(name).dofadr[0]) for name in chain.names]
        act = chain.actuated_index.tolist()
        self._qpos_ids = np.array(qpos)
        self._passive = passive
        # e = A q − c_p with A the passive rows of (I − C S), S selecting the actuated
        self._A = np.zeros((self.k, chain.n))
        for r, i in enumerate(passive):
            self._A[r, i] = 1.0
            for k, j in enumerate(act):
                self._A[r, j] -= chain.C[i, k]
        self._offset = chain.c[passive]
        self._jacobian = np.zeros((self.k, model.nv))
        self._jacobian[:, dof] = self._A

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        """Each passive joint's distance from its coupling [model units], (k,)."""
        return self._A @ configuration.data.qpos[self._qpos_ids] - self._offset

    def compute_jacobian(self, configuration: mink.Configuration) -> np.ndarray:
        """(k, nv): 1 on the passive joint, −C on the actuated ones."""
        return self._jacobian


def _turn_onto(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation (3, 3) taking unit vector ``a`` onto unit vector ``b``."""
    axis = np.cross(a, b)
    s, c = float(np.linalg.norm(axis)), float(np.dot(a, b))
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        # opposite: half a turn about any axis across a
        perp = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(perp) < 1e-6:
            perp = np.cross(a, [0.0, 1.0, 0.0])
        perp /= np.linalg.norm(perp)
        return 2.0 * np.outer(perp, perp) - np.eye(3)
    return mink.SO3.exp(axis / s * math.atan2(s, c)).as_matrix()


class MinkSolver(IKSolver):
    """IK with mink on MuJoCo: coupling held exactly, joint limits respected.

    Args:
        model: The arm model; its URDF is what MuJoCo loads.
        config: Tolerance, iteration cap, stall window and ``qp_solver``.

    Raises:
        QPSolverError: ``config.qp_solver`` is not an installed qpsolvers backend.
    """

    name = "mink"

    def __init__(self, model: ArmModel, config: ControllerConfig):
        super().__init__(model, config)
        config = self.config  # checked by IKSolver; None: the defaults
        if config.qp_solver not in qpsolvers.available_solvers:
            raise QPSolverError(config.qp_solver, qpsolvers.available_solvers)
        self.mj_model = mujoco_model(model)
        self.configuration = mink.Configuration(self.mj_model)
        self._site_id = self.mj_model.site(TCP_SITE).id
        self._position_task = mink.FrameTask(
            TCP_SITE, "site", position_cost=1.0, orientation_cost=0.0, gain=1.0
        )
        # one radian of approach weighs as much as APPROACH_WEIGHT_CM of position; a roll
        # about the approach axis (the site's z) costs nothing
        w = APPROACH_WEIGHT_CM / CM_PER_M
        self._approach_task = mink.FrameTask(
            TCP_SITE, "site", position_cost=1.0, orientation_cost=[w, w, 0.0], gain=1.0
        )
        self._limits = [mink.ConfigurationLimit(self.mj_model)]
        coupling = CouplingTask(self.mj_model, self.chain)
        self._constraints = [coupling] if coupling.k else []

    def solve(
        self, target: IKTarget | npt.ArrayLike, q_start: npt.ArrayLike | None = None
    ) -> IKResult:
        """Iterate mink QPs from ``q_start`` to ``target``; see :class:`IKSolver`."""
        target, q0, _ = self.prepare(target, q_start)
        cfg = self.config
        t = target.position / CM_PER_M
        tol2 = cfg.tolerance_cm2 / CM_PER_M**2
        a_d = None if target.approach is None else np.array(target.approach)
        cos_tol = math.cos(math.radians(APPROACH_TOLERANCE_DEG))
        z = np.array([0.0, 0.0, 1.0])  # the approach axis in the site frame
        conf, data = self.configuration, self.configuration.data
        task = self._position_task if a_d is None else self._approach_task
        lower, upper = self.chain.lower, self.chain.upper
        conf.update(q0)

        def measure() -> tuple[float, bool, np.ndarray]:
            R = data.site_xmat[self._site_id].reshape(3, 3)
            err2 = float(np.sum((t - data.site_xpos[self._site_id]) ** 2))
            met = a_d is None or float(R[:, 2] @ a_d) >= cos_tol
            return err2, met, R.copy()

        q_path, ee_path = [q0], [data.site_xpos[self._site_id].copy()]
        err2, met, R = measure()
        mark_k, mark_err2 = 0, err2
        status: Status = "max_iterations"
        for k in range(1, cfg.max_iterations + 2):
            if err2 < tol2 and met:
                status = "converged"
                break
            if k > cfg.max_iterations:
                break
            if a_d is not None:
                R = _turn_onto(R @ z, a_d) @ R
            task.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(R), t))
            try:
                v = mink.solve_ik(
                    conf,
                    [task],
                    _DT,
                    cfg.qp_solver,
                    limits=self._limits,
                    constraints=self._constraints,
                )
            except mink.NoSolutionFound:
                status = "stalled"
                break
            if not np.all(np.isfinite(v)):
                status = "stalled"
                break
            conf.integrate_inplace(v, _DT)
            q = data.qpos.copy()
            if not self.chain.within_limits(q, 0.0):
                # the QP meets its limit rows to its solver's tolerance only (~1e-9 rad)
                q = np.clip(q, lower, upper)
                conf.update(q)
            q_path.append(q)
            ee_path.append(data.site_xpos[self._site_id].copy())
            err2, met, R = measure()
            if k - mark_k >= cfg.stall_iterations:
                if err2 > (1.0 - 1e-6) ** 2 * mark_err2:
                    status = "stalled"
                    break
                mark_k, mark_err2 = k, err2
        return self._result(status, target, np.array(q_path), np.array(ee_path) * CM_PER_M)
