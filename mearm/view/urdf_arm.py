"""The arm as Pinocchio's meshcat visualiser draws it: its URDF with the jaws free."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from mearm.kinematics import ArmModel, jaw_joint_names
from mearm.view.viewpoint import M_PER_CM


class UrdfArm:
    """The URDF with its jaw joints free, and where each joint's value goes in its q."""

    def __init__(self, model: ArmModel):
        self.full = pin.buildModelFromXML(model.urdf)
        self.visual = pin.buildGeomFromUrdfString(self.full, model.urdf, pin.GeometryType.VISUAL)
        self.chain_idx = np.array(
            [self.full.joints[self.full.getJointId(n)].idx_q for n in model.chain.names]
        )
        jaws = [n for n in jaw_joint_names(model.arm) if self.full.existJointName(n)]
        self.jaw_idx = np.array([self.full.joints[self.full.getJointId(n)].idx_q for n in jaws])

    def q(self, q_chain: np.ndarray, opening_cm: float) -> np.ndarray:
        """The URDF's q: the chain's joints, each jaw at half the opening [m]."""
        q = pin.neutral(self.full)
        q[self.chain_idx] = q_chain
        for i in self.jaw_idx.tolist():
            half = opening_cm / 2.0 * M_PER_CM
            q[i] = min(max(half, self.full.lowerPositionLimit[i]), self.full.upperPositionLimit[i])
        return q
