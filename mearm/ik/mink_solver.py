"""The mink cross-check: the same URDF in MuJoCo, solved as a QP with the coupling exact.

An independent route to the same joint solution as :class:`~mearm.ik.PdPij`: the
generated URDF (:func:`mearm.kinematics.dh_to_urdf`) loaded by MuJoCo, a
:class:`mink.FrameTask` on the ``ee`` site (position only), :class:`mink.ConfigurationLimit`
for the joint limits and the coupling θ2 + θ3 + θ4 = 0 (SPEC §2) as an equality
constraint of every QP. MuJoCo equalities cannot express a three-joint sum, so the
coupling is a small custom task, :class:`CouplingTask`, passed to :func:`mink.solve_ik`
as a constraint: ``A Δq = −e`` restores the sum to 0 after every step.

MuJoCo's URDF import fuses the fixed ``ee`` link into ``link4``; an ``ee`` site is added
at that link's origin through :class:`mujoco.MjSpec` before compiling, so the site sits at
the DH end exactly where Pinocchio's ``ee`` frame is.

The frame task runs dead-beat steps (gain 1, ``dt`` = 1): this solver is a cross-check of
where PD-PIJ arrives, not of its path, and converges in a handful of QPs.
"""

from __future__ import annotations

import mink
import mujoco
import numpy as np
import numpy.typing as npt
import qpsolvers

from mearm.config import JOINT_NAMES, ControllerConfig
from mearm.exceptions import ModelError, QPSolverError
from mearm.ik.result import IKResult, Status
from mearm.ik.solver import IKSolver
from mearm.kinematics import ArmModel
from mearm.kinematics.model import CM_PER_M

EE_SITE = "ee"
_DT = 1.0  # mink returns Δq / dt; with dt = 1 the velocity is the step


def mujoco_model(model: ArmModel) -> mujoco.MjModel:
    """Compile the arm's URDF into MuJoCo, with an ``ee`` site at the DH end.

    Raises:
        ModelError: MuJoCo cannot load the URDF, or it has no ``ee`` link.
    """
    try:
        spec = mujoco.MjSpec.from_string(model.urdf)
    except ValueError as exc:
        raise ModelError(f"MuJoCo could not parse the URDF: {exc}") from None
    ee = spec.body(EE_SITE)
    if ee is None:
        raise ModelError("URDF has no 'ee' link to put the ee site on")
    ee.add_site(name=EE_SITE, pos=[0.0, 0.0, 0.0])
    mj_model = spec.compile()
    names = [mj_model.joint(i).name for i in range(mj_model.njnt)]
    if names != list(JOINT_NAMES):
        raise ModelError(f"MuJoCo model joints are {names}; expected {list(JOINT_NAMES)}")
    return mj_model


class CouplingTask(mink.Task):
    r"""The parallelogram's coupling θ2 + θ3 + θ4 = 0 as a one-row task (SPEC §2).

    .. math:: e(q) = \theta_2 + \theta_3 + \theta_4, \qquad J = [0, 1, 1, 1]

    Passed in ``constraints`` of :func:`mink.solve_ik` it is met exactly by every step.

    Args:
        model: MuJoCo model with hinge joints ``joint2``..``joint4``.
        gain: Task gain in [0, 1]; 1 closes any residual in one step.
    """

    k: int = 1

    def __init__(self, model: mujoco.MjModel, gain: float = 1.0):
        super().__init__(cost=np.ones(self.k), gain=gain)
        joints = [model.joint(name) for name in JOINT_NAMES[1:]]
        self._qpos_ids = np.array([int(j.qposadr[0]) for j in joints])
        self._jacobian = np.zeros((self.k, model.nv))
        self._jacobian[0, [int(j.dofadr[0]) for j in joints]] = 1.0

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        """θ2 + θ3 + θ4 [rad], (1,)."""
        return np.array([configuration.data.qpos[self._qpos_ids].sum()])

    def compute_jacobian(self, configuration: mink.Configuration) -> np.ndarray:
        """(1, nv): ones on the three coupled joints."""
        return self._jacobian


class MinkSolver(IKSolver):
    """Position IK with mink on MuJoCo, coupling held exactly, joint limits respected.

    Args:
        model: The arm model; its URDF is what MuJoCo loads.
        config: Tolerance, iteration cap, stall window and ``qp_solver``.

    Raises:
        QPSolverError: ``config.qp_solver`` is not an installed qpsolvers backend.
    """

    name = "mink"

    def __init__(self, model: ArmModel, config: ControllerConfig):
        super().__init__(model, config)
        if config.qp_solver not in qpsolvers.available_solvers:
            raise QPSolverError(config.qp_solver, qpsolvers.available_solvers)
        self.mj_model = mujoco_model(model)
        self.configuration = mink.Configuration(self.mj_model)
        self._site_id = self.mj_model.site(EE_SITE).id
        self._task = mink.FrameTask(
            EE_SITE, "site", position_cost=1.0, orientation_cost=0.0, gain=1.0
        )
        self._limits = [mink.ConfigurationLimit(self.mj_model)]
        self._coupling = CouplingTask(self.mj_model)

    def solve(self, q_start_rad: npt.ArrayLike, target_cm: npt.ArrayLike) -> IKResult:
        """Iterate mink QPs from ``q_start_rad`` to ``target_cm``; see :class:`IKSolver`."""
        q0, target_cm, _ = self.prepare(q_start_rad, target_cm)
        cfg = self.config
        t = target_cm / CM_PER_M
        tol2 = cfg.tolerance_cm2 / CM_PER_M**2
        conf, data, task = self.configuration, self.configuration.data, self._task
        conf.update(q0)
        q_path, ee_path = [q0], [data.site_xpos[self._site_id].copy()]
        err2 = float(np.sum((t - ee_path[0]) ** 2))
        mark_k, mark_err2 = 0, err2
        status: Status = "max_iterations"
        for k in range(1, cfg.max_iterations + 2):
            if err2 < tol2:
                status = "converged"
                break
            if k > cfg.max_iterations:
                break
            # the target turns with the site, so the task error is the position error only
            rotation = mink.SO3.from_matrix(data.site_xmat[self._site_id].reshape(3, 3))
            task.set_target(mink.SE3.from_rotation_and_translation(rotation, t))
            try:
                v = mink.solve_ik(
                    conf,
                    [task],
                    _DT,
                    cfg.qp_solver,
                    limits=self._limits,
                    constraints=[self._coupling],
                )
            except mink.NoSolutionFound:
                status = "stalled"
                break
            if not np.all(np.isfinite(v)):
                status = "stalled"
                break
            conf.integrate_inplace(v, _DT)
            q = data.qpos.copy()
            if not self.model.within_limits(q, tol_rad=0.0):
                # the QP meets its limit rows to its solver's tolerance only (~1e-9 rad)
                q = np.clip(q, self.model.lower_rad, self.model.upper_rad)
                conf.update(q)
            q_path.append(q)
            ee_path.append(data.site_xpos[self._site_id].copy())
            err2 = float(np.sum((t - ee_path[-1]) ** 2))
            if k - mark_k >= cfg.stall_iterations:
                if err2 > (1.0 - 1e-6) ** 2 * mark_err2:
                    status = "stalled"
                    break
                mark_k, mark_err2 = k, err2
        return IKResult.from_paths(
            status, self.name, target_cm, np.array(q_path), np.array(ee_path) * CM_PER_M
        )
