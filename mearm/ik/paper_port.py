"""The paper's PD-PIJ loop as a straightforward NumPy port of a MATLAB script.

Every iteration builds the DH matrices (paper §2, eq. 1), multiplies them (eq. 2), takes
the TCP from the last frame (eq. 3), builds the Jacobian column by column with cross
products (eq. 9; the z axis for a prismatic joint) and inverts it with
:func:`numpy.linalg.pinv` (eq. 13), then applies the paper's limit rule and sets every
passive joint from its coupling (``paper`` mode, paper §3).

It is deliberately plain: it is the baseline ``tools/bench.py`` measures
:class:`~mearm.ik.PdPij` against, and an independent implementation the tests compare
``paper`` mode with, iteration by iteration. Inputs are not validated here.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from mearm.config import ArmDescription, ControllerConfig


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
    q_start: npt.ArrayLike,
    target_cm: npt.ArrayLike,
    arm: ArmDescription,
    config: ControllerConfig,
) -> tuple[str, np.ndarray, np.ndarray]:
    """Run the paper's loop from ``q_start`` to ``target_cm``.

    Args:
        q_start: Start joints, every one, model units (rad, or m for a prismatic joint),
            (n,).
        target_cm: Target (x, y, z) in the base frame [cm], (3,).
        arm: DH rows, joint limits, couplings and the TCP offset.
        config: kp, kd, tolerance and max iterations (mode, safeguard and the rest unused).

    Returns:
        ``(status, q_path, ee_path_cm)``: ``"converged"`` or ``"max_iterations"``, the
        joints (N+1, n) and TCP positions (N+1, 3) of every iteration, start included.
    """
    joints = arm.joints
    prismatic = [j.type == "prismatic" for j in joints]
    scale = np.array([0.01 if p else math.pi / 180.0 for p in prismatic])
    limits = arm.joint_limits()
    lower = np.array([limits[j.name].min for j in joints]) * scale
    upper = np.array([limits[j.name].max for j in joints]) * scale
    names = [j.name for j in joints]
    tcp = np.array([*arm.tool.tcp_cm, 1.0])
    target = np.asarray(target_cm, dtype=float)
    q = np.array(q_start, dtype=float)
    q_path, ee_path = [q.copy()], []
    e_prev = None
    status = "max_iterations"
    for _ in range(config.max_iterations + 1):
        frames = [np.eye(4)]
        for v, j, pr in zip(q, joints, prismatic, strict=True):
            theta = math.radians(j.dh.theta_deg) + (0.0 if pr else v)
            d = j.dh.d_cm + (v * 100.0 if pr else 0.0)
            frames.append(frames[-1] @ _dh(theta, j.dh.a_cm, math.radians(j.dh.alpha_deg), d))
        p = (frames[-1] @ tcp)[:3]
        ee_path.append(p.copy())
        e = target - p
        if e @ e < config.tolerance_cm2:
            status = "converged"
            break
        if len(q_path) > config.max_iterations:
            break
        if e_prev is None:
            e_prev = e
        J = np.column_stack(
            [
                T[:3, 2] * 100.0 if pr else np.cross(T[:3, 2], p - T[:3, 3])
                for T, pr in zip(frames[:-1], prismatic, strict=True)
            ]
        )
        ds = config.kp * e + config.kd * (e - e_prev)
        e_prev = e
        dq = np.linalg.pinv(J, rcond=config.singular_value_cutoff) @ ds
        new = q + dq
        dq[(new < lower) | (new > upper)] = 0.0  # the paper's limit rule
        q = q + dq
        for i, j in enumerate(joints):  # the couplings, in the config's units
            if j.coupling is not None:
                value = j.coupling.offset * scale[i]
                for term, coef in j.coupling.terms.items():
                    k = names.index(term)
                    value += coef * q[k] / scale[k] * scale[i]
                q[i] = value
        q_path.append(q.copy())
    return status, np.array(q_path), np.array(ee_path)
