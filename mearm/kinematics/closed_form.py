r"""Closed-form inverse kinematics of the arm, and the target check built on it.

The parallelogram keeps link 4 horizontal (θ2 + θ3 + θ4 = 0, SPEC §2), so the EE sits at

.. math::
    \rho = a_1 + a_2\cos\theta_2 + a_3\cos(\theta_2+\theta_3) + a_4, \qquad
    z = d_1 + a_2\sin\theta_2 + a_3\sin(\theta_2+\theta_3)

along the horizontal direction θ1. With θ3 < 0 (every pose within the limits, the
elbow-up branch) the solution is unique, which makes this both an oracle for the
iterative solvers and the instant reachability test used before anything moves.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from mearm.config import ACTUATED_JOINTS, RobotConfig
from mearm.exceptions import InvalidTargetError, TargetOutsideBoxError, UnreachableTargetError

_EPS = 1e-12


def as_target_cm(target_cm: npt.ArrayLike) -> np.ndarray:
    """A target as a (3,) float array [cm]; :class:`InvalidTargetError` if it is not one."""
    try:
        t = np.asarray(target_cm, dtype=float)
    except (TypeError, ValueError):
        raise InvalidTargetError(
            f"a target is three finite numbers (x, y, z) in cm, got {target_cm!r}"
        ) from None
    if t.shape != (3,) or not np.all(np.isfinite(t)):
        raise InvalidTargetError(
            f"a target is three finite numbers (x, y, z) in cm, got {t.tolist()!r}"
        )
    return t


def analytic_ik_deg(target_cm: npt.ArrayLike, robot: RobotConfig) -> np.ndarray:
    """Joint angles (θ1, θ2, θ3, θ4) [deg] that put the EE at ``target_cm``.

    Args:
        target_cm: (x, y, z) in the base frame [cm].
        robot: Geometry and joint limits.

    Returns:
        (4,) joint angles in degrees, θ4 = −(θ2 + θ3), all within the limits.

    Raises:
        UnreachableTargetError: the point is beyond the arm's reach, too close to it, or
            needs a joint outside its limits; the message says which.
    """
    x, y, z = as_target_cm(target_cm)
    r1, r2, r3, r4 = robot.dh
    if (r1.alpha_deg, r2.alpha_deg, r3.alpha_deg, r4.alpha_deg) != (90.0, 0.0, 0.0, 0.0):
        raise UnreachableTargetError(
            (x, y, z), "the closed form needs the MeArm DH structure α = (90, 0, 0, 0) deg"
        )
    a2, a3 = r2.a_cm, r3.a_cm
    rho = math.hypot(x, y)
    if rho < _EPS:
        raise UnreachableTargetError((x, y, z), "on the base axis, where θ1 is undefined")
    theta1 = math.atan2(y, x)
    r = rho - r1.a_cm - r4.a_cm
    h = z - r1.d_cm - r2.d_cm - r3.d_cm - r4.d_cm
    dist = math.hypot(r, h)
    reach_max, reach_min = a2 + a3, abs(a2 - a3)
    if dist > reach_max + _EPS or dist < reach_min - _EPS:
        raise UnreachableTargetError(
            (x, y, z),
            f"out of reach: the wrist point is {dist:.3f} cm from joint 2, "
            f"the arm reaches [{reach_min:.3f}, {reach_max:.3f}] cm",
        )
    cos3 = (dist * dist - a2 * a2 - a3 * a3) / (2.0 * a2 * a3)
    theta3 = -math.acos(min(1.0, max(-1.0, cos3)))
    theta2 = math.atan2(h, r) - math.atan2(a3 * math.sin(theta3), a2 + a3 * math.cos(theta3))
    q_deg = np.degrees([theta1, theta2, theta3])
    jl = robot.joint_limits_deg
    for name, value, lim in zip(
        ACTUATED_JOINTS, q_deg, (jl.joint1, jl.joint2, jl.joint3), strict=True
    ):
        if not lim.contains(value, tol=1e-9):
            raise UnreachableTargetError(
                (x, y, z),
                f"needs {name} = {value:.2f} deg, "
                f"outside its limits [{lim.min:g}, {lim.max:g}] deg",
            )
    return np.array([q_deg[0], q_deg[1], q_deg[2], -(q_deg[1] + q_deg[2])])


def check_in_box(target_cm: npt.ArrayLike, robot: RobotConfig) -> None:
    """Raise :class:`TargetOutsideBoxError` if the target leaves the Table 3 box."""
    t = as_target_cm(target_cm)
    box = robot.target_box
    for axis, value, rng in zip("xyz", t, (box.x_cm, box.y_cm, box.z_cm), strict=True):
        if not rng.contains(float(value)):
            raise TargetOutsideBoxError(tuple(t), axis, (rng.min, rng.max))


def check_target(target_cm: npt.ArrayLike, robot: RobotConfig) -> np.ndarray:
    """Validate a target before any motion: inside the box and reachable within limits.

    Returns:
        The closed-form joint solution (θ1..θ4) [deg], (4,).

    Raises:
        TargetOutsideBoxError: outside SPEC §3 Table 3.
        UnreachableTargetError: inside the box but out of reach.
    """
    check_in_box(target_cm, robot)
    return analytic_ik_deg(target_cm, robot)
