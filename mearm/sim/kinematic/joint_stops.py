r"""Where the joint servos leave the kinematic arm when a joint meets its stop.

A joint stops at its limits (the arm description's, where the MuJoCo twin's joints stop
too) however far its servo sends it: by the error model's offset and noise
(:class:`~mearm.sim.kinematic.servo_bus.SimArm`) or by a pulse the virtual Uno measured.
A hobby servo drives in proportion to its error in pulse (its amplifier compares the
pulse with its potentiometer's), so the servos come to rest where their errors in µs are
least with every joint within its stops:

.. math:: q = \arg\min_{l \le q \le u} \lVert K (A q + a - v) \rVert^2,
    \qquad K = \mathrm{diag}(k)

with :math:`v = A q + a` the servos' values (:attr:`~mearm.hardware.ServoMap.combination`)
and :math:`k` their µs per unit. Inside the stops this is :math:`A^{-1}(v - a)`; with each
servo turning its own joint, each joint's value clipped to its stops. A servo that turns a
combination keeps turning it when another joint of it is stopped: the MeArm's shoulder
held at its stop, the elbow servo still sets the forearm's angle to the table.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mearm.config import Range
from mearm.hardware import ServoMap

#: The solution moves less than this in a sweep: it has converged [deg or cm].
_TOLERANCE = 1e-9
#: Sweeps at most (the MeArm v1's converges within 2 over servo values in ±200°).
_MAX_SWEEPS = 10_000


def joints_at_stops(
    smap: ServoMap, servo_values: Mapping[str, float], stops: Mapping[str, Range]
) -> dict[str, float]:
    """The actuated joints the joint servos' values put the arm at, none past its stops.

    Args:
        smap: The joint servos: what each turns and its µs per unit.
        servo_values: Every joint servo (by its joint's name) → its value [deg or cm].
        stops: Every actuated joint → the range it cannot leave [deg or cm].

    Returns:
        Actuated joint name → deg or cm, in chain order.
    """
    names = smap.joint_names
    free = smap.joints_of(servo_values)
    lower = np.array([stops[n].min for n in names])
    upper = np.array([stops[n].max for n in names])
    q = np.clip([free[n] for n in names], lower, upper)
    combination = smap.combination
    if combination is not None and not np.array_equal(q, [free[n] for n in names]):
        # projected Gauss–Seidel on the box-constrained least squares (strictly convex:
        # A is invertible), from the clipped free solution
        A, a = combination
        k = np.array([j.us_per_unit for j in smap.joints])
        M = k[:, None] * A
        H = M.T @ M
        g = M.T @ (k * (np.array([servo_values[n] for n in names]) - a))
        for _ in range(_MAX_SWEEPS):
            moved = 0.0
            for i in range(len(names)):
                qi = min(upper[i], max(lower[i], q[i] + (g[i] - H[i] @ q) / H[i, i]))
                moved, q[i] = max(moved, abs(qi - q[i])), qi
            if moved < _TOLERANCE:
                break
    return dict(zip(names, q.tolist(), strict=True))
