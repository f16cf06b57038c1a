"""Kinematics of any arm described as data.

The chain, the DH reference, the URDF, the Pinocchio model, and closed forms as plug-ins.

The model (:class:`ArmModel`) imports Pinocchio and coal (about 0.13 s of CPU) and is
loaded on first use: what needs only the chain, the URDF, a body's size or an error of
:mod:`mearm.kinematics.errors` (the work area of ``mearm detect``, the hardware's joint
limits) does not pay for them.
"""

from typing import TYPE_CHECKING

from mearm._lazy import lazy_exports
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
from mearm.kinematics.urdf import TCP_FRAME, generate_urdf, jaw_joint_names

if TYPE_CHECKING:  # typed for the checker, imported on first use (_LAZY)
    from mearm.kinematics.model import CM_PER_M, ArmModel

_LAZY = {"ArmModel": "mearm.kinematics.model", "CM_PER_M": "mearm.kinematics.model"}

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

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals(), __all__)
