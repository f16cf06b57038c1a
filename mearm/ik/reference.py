"""The paper's PD-PIJ loop as a straightforward NumPy port of a MATLAB script.

Every iteration builds the four DH matrices (SPEC §2, eq. 1), multiplies them (eq. 2),
takes the EE from the last column (eq. 3), builds the Jacobian column by column with cross
products (eq. 9) and inverts it with :func:`numpy.linalg.pinv` (eq. 13), then applies the
paper's limit rule and re-imposes θ4 = −(θ2 + θ3) (``paper`` mode, SPEC §3).

It is deliberately plain: it is the baseline ``tools/bench.py`` measures
:class:`~mearm.ik.PdPij` against, and an independent implementation the tests compare
``paper`` mode with, iteration by iteration. Inputs are not validated here.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from mearm.config import ControllerConfig, RobotConfig


def _dh(theta: float, a: float, alpha: float, d: float) -> np.ndarray:
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array(
        [
            [ct, -ca * st, sa * st, a * ct],
            [st, ca * ct, -sa * ct, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def numpy_port_solve(
    q_start_rad: npt.ArrayLike,
    target_cm: npt.ArrayLike,
    robot: RobotConfig,
    config: ControllerConfig,
) -> tuple[str, np.ndarray, np.ndarray]:
    """Run the paper's loop from ``q_start_rad`` to ``target_cm``.

    Args:
        q_start_rad: Start joints (θ1..θ4) [rad], (4,).
        target_cm: Target (x, y, z) in the base frame [cm], (3,).
        robot: DH table and joint limits.
        config: kp, kd, tolerance and max iterations (mode, safeguard and the rest unused).

    Returns:
        ``(status, q_path_rad, ee_path_cm)``: ``"converged"`` or ``"max_iterations"``,
        the joints (N+1, 4) and EE positions (N+1, 3) of every iteration, start included.
    """
    dh = [(r.a_cm, math.radians(r.alpha_deg), r.d_cm) for r in robot.dh]
    limits = robot.joint_limits_deg.as_list()
    lower = np.radians([lim.min for lim in limits])
    upper = np.radians([lim.max for lim in limits])
    target = np.asarray(target_cm, dtype=float)
    q = np.array(q_start_rad, dtype=float)
    q_path, ee_path = [q.copy()], []
    e_prev = None
    status = "max_iterations"
    for _ in range(config.max_iterations + 1):
        frames = [np.eye(4)]
        for theta, (a, alpha, d) in zip(q, dh, strict=True):
            frames.append(frames[-1] @ _dh(theta, a, alpha, d))
        p = frames[-1][:3, 3]
        ee_path.append(p.copy())
        e = target - p
        if e @ e < config.tolerance_cm2:
            status = "converged"
            break
        if len(q_path) > config.max_iterations:
            break
        if e_prev is None:
            e_prev = e
        J = np.column_stack([np.cross(T[:3, 2], p - T[:3, 3]) for T in frames[:-1]])
        ds = config.kp * e + config.kd * (e - e_prev)
        e_prev = e
        dq = np.linalg.pinv(J, rcond=config.singular_value_cutoff) @ ds
        new = q + dq
        dq[(new < lower) | (new > upper)] = 0.0  # the paper's limit rule
        q = q + dq
        q[3] = -(q[1] + q[2])
        q_path.append(q.copy())
    return status, np.array(q_path), np.array(ee_path)
