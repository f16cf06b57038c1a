"""The arm model on Pinocchio: FK of the ``ee`` frame and its position Jacobians.

Joint vectors are in radians and hold all four DH joints, ``q = (θ1, θ2, θ3, θ4)``,
with θ4 = −(θ2 + θ3) on the real arm (SPEC §2). Positions are in centimetres, the unit
of the DH table, although the URDF itself is in metres.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from mearm.config import JOINT_NAMES, RobotConfig
from mearm.exceptions import JointLimitError, ModelError
from mearm.kinematics.urdf import dh_to_urdf

CM_PER_M = 100.0

#: Coupling matrix, q = C · (θ1, θ2, θ3): θ4 = −(θ2 + θ3) (SPEC §3, ``coupled`` mode).
COUPLING = np.array(
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, -1.0]]
)  # (4, 3)


def couple(q3: npt.ArrayLike) -> np.ndarray:
    """Full joint vector (θ1..θ4) from the actuated (θ1, θ2, θ3); works in rad or deg."""
    return COUPLING @ np.asarray(q3, dtype=float)


class ArmModel:
    """Pinocchio model of the arm, built from the URDF the DH table generates.

    Args:
        robot: Geometry and limits (the ``robot`` section of the config).
        urdf_path: Load this URDF instead of generating one from ``robot``. Its joint
            names must be ``joint1``..``joint4`` and it must have an ``ee`` frame.
    """

    def __init__(self, robot: RobotConfig, urdf_path: str | Path | None = None):
        self.robot = robot
        if urdf_path is None:
            self.urdf = dh_to_urdf(robot)
        else:
            try:
                self.urdf = Path(urdf_path).read_text(encoding="utf-8")
            except OSError as exc:
                raise ModelError(f"cannot read URDF {urdf_path}: {exc}") from None
        try:
            self.model = pin.buildModelFromXML(self.urdf)
        except (RuntimeError, ValueError) as exc:
            raise ModelError(f"Pinocchio could not parse the URDF: {exc}") from None
        names = list(self.model.names)[1:]
        if names != list(JOINT_NAMES):
            raise ModelError(f"URDF joints are {names}; expected {list(JOINT_NAMES)}")
        if not self.model.existFrame("ee"):
            raise ModelError("URDF has no 'ee' frame")
        self.data = self.model.createData()
        self.ee_frame_id = self.model.getFrameId("ee")
        limits = robot.joint_limits_deg.as_list()
        #: Joint limits [deg] and [rad], (4,) each; joint 4's follow from the coupling.
        self.lower_deg = np.array([lim.min for lim in limits])
        self.upper_deg = np.array([lim.max for lim in limits])
        self.lower_rad = np.radians(self.lower_deg)
        self.upper_rad = np.radians(self.upper_deg)

    @property
    def home_rad(self) -> np.ndarray:
        """Home pose (θ1..θ4) [rad], (4,)."""
        return np.radians(self.robot.home_joints_deg)

    def fk_cm(self, q_rad: npt.ArrayLike) -> np.ndarray:
        """Position of the ``ee`` frame in the base frame [cm], (3,)."""
        q = np.asarray(q_rad, dtype=float)
        pin.framesForwardKinematics(self.model, self.data, q)
        return self.data.oMf[self.ee_frame_id].translation * CM_PER_M

    def fk_and_jacobian(self, q_rad: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        r"""EE position [cm], (3,), and position Jacobian [cm/rad], (3, 4), in one pass.

        The Jacobian is expressed in the base frame (``LOCAL_WORLD_ALIGNED``),
        :math:`\dot s = J \dot q`, equal to the paper's eq. 9.
        """
        q = np.asarray(q_rad, dtype=float)
        pin.computeJointJacobians(self.model, self.data, q)
        pin.updateFramePlacement(self.model, self.data, self.ee_frame_id)
        J = pin.getFrameJacobian(self.model, self.data, self.ee_frame_id, pin.LOCAL_WORLD_ALIGNED)
        return self.data.oMf[self.ee_frame_id].translation * CM_PER_M, J[:3] * CM_PER_M

    def jacobian(self, q_rad: npt.ArrayLike) -> np.ndarray:
        """Position Jacobian over all four joints [cm/rad], (3, 4) (``paper`` mode)."""
        return self.fk_and_jacobian(q_rad)[1]

    def coupled_jacobian(self, q_rad: npt.ArrayLike) -> np.ndarray:
        r"""Jacobian over (θ1, θ2, θ3) through the coupling [cm/rad], (3, 3).

        .. math:: J_c = J \, C
        """
        return self.jacobian(q_rad) @ COUPLING

    def within_limits(self, q_rad: npt.ArrayLike, tol_rad: float = 1e-9) -> bool:
        """Whether every joint is within its limits (with a small tolerance)."""
        q = np.asarray(q_rad, dtype=float)
        return bool(np.all(q >= self.lower_rad - tol_rad) and np.all(q <= self.upper_rad + tol_rad))

    def check_limits(self, q_rad: npt.ArrayLike, tol_rad: float = 1e-9) -> None:
        """Raise :class:`JointLimitError` for the first joint outside its limits."""
        q = np.asarray(q_rad, dtype=float)
        for i, name in enumerate(JOINT_NAMES[: len(q)]):
            if not (self.lower_rad[i] - tol_rad <= q[i] <= self.upper_rad[i] + tol_rad):
                raise JointLimitError(name, np.degrees(q[i]), self.lower_deg[i], self.upper_deg[i])
