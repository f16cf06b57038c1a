r"""The DH product written the way the paper writes it: the independent reference.

.. math:: T_{0,n} = \prod_i R_z(\theta_i)\,T_z(d_i)\,T_x(a_i)\,R_x(\alpha_i)

followed by the tool's TCP offset. The Pinocchio model is checked against this, in
centimetres, for every arm.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from mearm.config import ArmDescription
from mearm.config.base import short_repr
from mearm.kinematics.chain import require_description
from mearm.kinematics.errors import InvalidJointsError


def dh_frames(arm: ArmDescription, q: npt.ArrayLike) -> list[np.ndarray]:
    """Frames T(0→0), T(0→1), …, T(0→n), each (4, 4), cm.

    Args:
        arm: The description.
        q: Every joint in model units (rad, or m for a prismatic joint), (n,).

    Raises:
        InvalidJointsError: ``q`` is not one finite number per joint.
        ModelError: ``arm`` is not an :class:`ArmDescription`.
    """
    require_description(arm, "the DH product")
    try:
        values = np.asarray(q, dtype=float)
    except (TypeError, ValueError):
        raise InvalidJointsError([], f"joint values must be numbers, got {short_repr(q)}") from None
    if values.shape != (len(arm.joints),):
        names = ", ".join(j.name for j in arm.joints)
        raise InvalidJointsError(
            values.ravel().tolist(),
            f"expected {len(arm.joints)} values, one per joint ({names}) in model units "
            f"(rad, m), got shape {values.shape}",
        )
    if not np.isfinite(values).all():
        raise InvalidJointsError(values.tolist(), "joint values must be finite")
    frames = [np.eye(4)]
    for v, joint in zip(values.tolist(), arm.joints, strict=True):
        value = v * 100.0 if joint.type == "prismatic" else v
        frames.append(frames[-1] @ joint.dh.transform(value, joint.type))
    return frames


def dh_tcp_frame(arm: ArmDescription, q: npt.ArrayLike) -> np.ndarray:
    """The TCP frame: T(0→n) moved by the tool's ``tcp_cm``, (4, 4), cm."""
    T = dh_frames(arm, q)[-1].copy()
    T[:3, 3] += T[:3, :3] @ np.asarray(arm.tool.tcp_cm, dtype=float)
    return T


def dh_fk(arm: ArmDescription, q: npt.ArrayLike) -> np.ndarray:
    """TCP position [cm], (3,)."""
    return dh_tcp_frame(arm, q)[:3, 3].copy()


def dh_jacobian(arm: ArmDescription, q: npt.ArrayLike) -> np.ndarray:
    r"""Position Jacobian of the TCP over every joint (the paper's eq. 9 and eq. 10).

    .. math:: J_i = Z_{i-1} \times (O_{tcp} - O_{i-1}) \ \text{(revolute)}, \qquad
              J_i = Z_{i-1} \ \text{(prismatic)}

    Returns:
        (3, n) [cm/rad] for revolute columns, [cm/m] for prismatic ones.
    """
    frames = dh_frames(arm, q)
    o_tcp = dh_tcp_frame(arm, q)[:3, 3]
    cols = []
    for T, joint in zip(frames[:-1], arm.joints, strict=True):
        z = T[:3, 2]
        cols.append(z * 100.0 if joint.type == "prismatic" else np.cross(z, o_tcp - T[:3, 3]))
    return np.stack(cols, axis=1)
