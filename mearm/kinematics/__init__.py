"""Kinematics: the DH reference, the URDF it generates, the Pinocchio model, the closed form."""

from mearm.kinematics.analytic import analytic_ik_deg, as_target_cm, check_in_box, check_target
from mearm.kinematics.dh import dh_fk, dh_frames, dh_jacobian, dh_transform
from mearm.kinematics.model import COUPLING, ArmModel, couple
from mearm.kinematics.urdf import dh_to_urdf

__all__ = [
    "COUPLING",
    "ArmModel",
    "analytic_ik_deg",
    "as_target_cm",
    "check_in_box",
    "check_target",
    "couple",
    "dh_fk",
    "dh_frames",
    "dh_jacobian",
    "dh_to_urdf",
    "dh_transform",
]
