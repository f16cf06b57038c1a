"""Kinematics of any arm described as data.

The chain, the DH reference, the URDF, the Pinocchio model, and closed forms as plug-ins.
"""

from mearm.kinematics.chain import Chain
from mearm.kinematics.closed_form import (
    CLOSED_FORMS,
    ClosedForm,
    PlanarWrist,
    as_target_cm,
    check_in_box,
    check_target,
    closed_form_for,
    register_closed_form,
)
from mearm.kinematics.dh import dh_fk, dh_frames, dh_jacobian, dh_tcp_frame
from mearm.kinematics.model import CM_PER_M, ArmModel
from mearm.kinematics.urdf import TCP_FRAME, generate_urdf, jaw_joint_names

__all__ = [
    "CLOSED_FORMS",
    "CM_PER_M",
    "TCP_FRAME",
    "ArmModel",
    "Chain",
    "ClosedForm",
    "PlanarWrist",
    "as_target_cm",
    "check_in_box",
    "check_target",
    "closed_form_for",
    "dh_fk",
    "dh_frames",
    "dh_jacobian",
    "dh_tcp_frame",
    "generate_urdf",
    "jaw_joint_names",
    "register_closed_form",
]
