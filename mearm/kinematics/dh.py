"""The paper's own kinematics: the DH product and the eq. 9 Jacobian (SPEC §2).

This is the independent reference the Pinocchio model is checked against, written the
way the paper writes it, in centimetres.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from mearm.config import DHRow


def dh_transform(theta_rad: float, row: DHRow) -> np.ndarray:
    r"""One DH link transform (SPEC §2, eq. 1).

    .. math:: T_{i-1,i} = R_z(\theta_i)\,T_z(d_i)\,T_x(a_i)\,R_x(\alpha_i)

    Args:
        theta_rad: Joint angle θi [rad].
        row: The link's a [cm], α [deg] and d [cm].

    Returns:
        The (4, 4) homogeneous transform, translation in cm.
    """
    ct, st = np.cos(theta_rad), np.sin(theta_rad)
    alpha = np.radians(row.alpha_deg)
    ca, sa = np.cos(alpha), np.sin(alpha)
    return np.array(
        [
            [ct, -ca * st, sa * st, row.a_cm * ct],
            [st, ca * ct, -sa * ct, row.a_cm * st],
            [0.0, sa, ca, row.d_cm],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def dh_frames(joints_rad: npt.ArrayLike, rows: Sequence[DHRow]) -> list[np.ndarray]:
    """Frames T(0→0), T(0→1), …, T(0→n) (SPEC §2, eq. 2), each (4, 4), cm."""
    q = np.asarray(joints_rad, dtype=float)
    if q.shape != (len(rows),):
        raise ValueError(f"expected {len(rows)} joint angles, got shape {q.shape}")
    frames = [np.eye(4)]
    for theta, row in zip(q, rows, strict=True):
        frames.append(frames[-1] @ dh_transform(float(theta), row))
    return frames


def dh_fk(joints_rad: npt.ArrayLike, rows: Sequence[DHRow]) -> np.ndarray:
    """EE position, the last column of T(0→n) (SPEC §2, eq. 3). Returns (3,) [cm]."""
    return dh_frames(joints_rad, rows)[-1][:3, 3].copy()


def dh_jacobian(joints_rad: npt.ArrayLike, rows: Sequence[DHRow]) -> np.ndarray:
    r"""Position Jacobian of the EE for revolute joints (SPEC §2, eq. 9).

    .. math:: J_i = Z_{i-1} \times (O_n - O_{i-1})

    Returns:
        (3, n) array [cm/rad].
    """
    frames = dh_frames(joints_rad, rows)
    o_n = frames[-1][:3, 3]
    cols = [np.cross(T[:3, 2], o_n - T[:3, 3]) for T in frames[:-1]]
    return np.stack(cols, axis=1)
