r"""The arm's chain as a MuJoCo model (:class:`mujoco.MjSpec`): one builder for every user.

The physical twin (:mod:`mearm.sim.twin.mjcf`) dresses this chain in shapes, servos, jaws and
a scene; the mink cross-check (:mod:`mearm.ik.mink_solver`) solves on it bare. Both start
here, from the arm description, so their joints, frames and TCP are one construction.

Body ``link_<joint>`` carries joint i (``hinge`` for a revolute joint, ``slide`` for a
prismatic one, about its own z axis, within the joint's limits); its pose in the previous
body is the fixed part of DH row i−1, ``DHRow.transform(0)`` =
:math:`R_z(\theta_0)T_z(d)T_x(a)R_x(\alpha)`, exactly as in the URDF
(:mod:`mearm.kinematics.urdf`), so MuJoCo's FK is the DH product. A body ``tcp`` with a
site ``tcp`` sits at the tool centre point (:func:`tcp_in_last`). Metres, radians.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import numpy.typing as npt

from mearm.config import ArmDescription
from mearm.kinematics.bodies import M_PER_CM, fixed_part
from mearm.kinematics.chain import Chain
from mearm.kinematics.urdf import TCP_FRAME


def tcp_in_last(arm: ArmDescription) -> np.ndarray:
    """The TCP's pose in the last joint's frame, (4, 4) [m].

    The last DH row's fixed part and the tool's ``tcp_cm`` offset, axes as the row's end.
    """
    T_last = fixed_part(arm.joints[-1])
    T = np.eye(4)
    T[:3, :3] = T_last[:3, :3]
    T[:3, 3] = T_last[:3, 3] + T_last[:3, :3] @ (np.asarray(arm.tool.tcp_cm) * M_PER_CM)
    return T


def exact(values: npt.ArrayLike) -> np.ndarray:
    """``values`` with round-off under 1e-15 made zero: a level axis stays exactly level."""
    v = np.array(values, dtype=float)
    v[np.abs(v) < 1e-15] = 0.0
    return v + 0.0  # (no -0.0)


def yaw_quat(yaw_rad: float) -> np.ndarray:
    r"""The unit quaternion (w, x, y, z) of a turn by ``yaw_rad`` about the vertical [rad].

    .. math:: q = (\cos\tfrac{\psi}{2}, 0, 0, \sin\tfrac{\psi}{2})
    """
    return np.array([math.cos(yaw_rad / 2), 0.0, 0.0, math.sin(yaw_rad / 2)])


def quat(R: np.ndarray) -> np.ndarray:
    """A rotation matrix's unit quaternion (w, x, y, z), as MuJoCo writes it."""
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=float).reshape(9))
    return exact(q)


def arm_spec(arm: ArmDescription, *, name: str | None = None) -> mujoco.MjSpec:
    """The chain from base to TCP: a body per joint, the joint in it, and the ``tcp`` site.

    Only the kinematics: no geoms, masses, actuators or jaws (the caller adds what it
    needs; a model with no masses compiles with ``compiler.boundmass`` set).

    Args:
        arm: The arm description.
        name: The model's name (default: the arm's).
    """
    spec = mujoco.MjSpec()
    spec.modelname = name or arm.name
    spec.compiler.degree = False
    spec.compiler.autolimits = True
    chain = Chain.from_description(arm)
    limits = arm.joint_limits()
    parent, T_prev = spec.worldbody.add_body(name="base_link"), np.eye(4)
    for i, joint in enumerate(arm.joints):
        body = parent.add_body(
            name=f"link_{joint.name}", pos=exact(T_prev[:3, 3]), quat=quat(T_prev[:3, :3])
        )
        scale = float(chain.scale[i])
        body.add_joint(
            name=joint.name,
            type=mujoco.mjtJoint.mjJNT_HINGE
            if joint.type == "revolute"
            else mujoco.mjtJoint.mjJNT_SLIDE,
            axis=[0.0, 0.0, 1.0],
            range=[limits[joint.name].min * scale, limits[joint.name].max * scale],
        )
        parent, T_prev = body, fixed_part(joint)
    T = tcp_in_last(arm)
    tcp = parent.add_body(name=TCP_FRAME, pos=exact(T[:3, 3]), quat=quat(T[:3, :3]))
    site = tcp.add_site(name=TCP_FRAME, rgba=[1.0, 0.0, 1.0, 1.0], group=4)
    site.size[0] = 0.004
    return spec


__all__ = ["arm_spec", "exact", "quat", "tcp_in_last"]
