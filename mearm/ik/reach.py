r"""Targets no pose within the solver's tolerance reaches: a bound from the links' lengths.

A revolute joint keeps the distance from its origin to the next joint's fixed, so the
last joint's origin :math:`o_p` (the TCP frame's parent) is never farther from an
anchor :math:`o_k` than the sum of those distances, :math:`L = \sum_{i=k}^{p-1}
|o_{i+1} - o_i|`. The anchor is the first joint's origin, or the second's where that
lies on the first joint's axis (a base yaw with the shoulder above it: the shoulder
never moves). With the TCP at :math:`t` in the last joint's frame and the approach axis
:math:`\hat a` there, split :math:`t = c\,\hat a + t_\perp`; a pose whose approach
:math:`a'` is within the solver's tolerance of the target's :math:`a` puts the TCP at

.. math::
    |p - x| \ge |w - o_k| - L - |t_\perp| - |c|\,|a' - a|, \qquad w = x - c\,a,
    \quad |a' - a|^2 \le 2 - 2\cos\delta

for a target :math:`x` (position only: :math:`|p - x| \ge |x - o_k| - L - |t|`). When
that exceeds the position tolerance, no pose meets the solver's stopping rule, so a
multi-start could only fail, every seed to its cap: :class:`ReachBound` says so at once.
The bound ignores the limits (it never calls a target out of reach that the limits
alone forbid) and gives no answer for an arm with a prismatic joint or a branching tree.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from mearm.kinematics import ArmModel

#: Room left for rounding in the kinematics [m]: far below any tolerance, far above
#: the error of a few products of metre-sized numbers.
_SLACK_M = 1e-9


def _revolute_axis(joint: pin.JointModel) -> np.ndarray | None:
    """A revolute joint's axis in its own frame, (3,); ``None`` for any other joint."""
    short = joint.shortname()
    axes = {"JointModelRX": (1.0, 0.0, 0.0), "JointModelRY": (0.0, 1.0, 0.0),
            "JointModelRZ": (0.0, 0.0, 1.0)}  # fmt: skip
    if short in axes:
        return np.array(axes[short])
    if short == "JointModelRevoluteUnaligned":
        return np.asarray(joint.extract().axis, dtype=float)
    return None


class ReachBound:
    """Whether a target lies beyond every pose's reach, by the links' lengths (module).

    Args:
        model: The arm model.
        tolerance_cm2: The solver's stopping rule on |e|² [cm²].
        approach_tolerance_deg: The stopping rule on the approach's angle [deg].

    Attributes:
        anchor_m: The fixed origin the lengths are summed from [m], (3,); ``None`` when
            the arm has no bound (a prismatic joint, a branch).
        reach_m: The sum of the links' lengths from the anchor to the TCP's joint [m].
    """

    def __init__(self, model: ArmModel, tolerance_cm2: float, approach_tolerance_deg: float):
        pm = model.model
        frame = pm.frames[model.tcp_frame_id]
        last = int(frame.parentJoint)
        serial = all(int(pm.parents[i]) == i - 1 for i in range(1, pm.njoints))
        axes = [_revolute_axis(pm.joints[i]) for i in range(1, last + 1)]
        self.anchor_m: np.ndarray | None = None
        self.reach_m = math.inf
        self._tol_m = math.sqrt(tolerance_cm2) / 100.0 + _SLACK_M
        # |a' − a| at the approach tolerance's edge
        self._turn = math.sqrt(max(0.0, 2.0 - 2.0 * math.cos(math.radians(approach_tolerance_deg))))
        T = frame.placement
        self._axis_in_last = T.rotation @ model.approach_axis
        t = np.asarray(T.translation, dtype=float)
        self._along = float(t @ self._axis_in_last)
        self._across = float(np.linalg.norm(t - self._along * self._axis_in_last))
        self._tcp = float(np.linalg.norm(t))
        if last < 1 or not serial or axes[0] is None or any(a is None for a in axes):
            return
        offsets = [np.asarray(pm.jointPlacements[i].translation, float) for i in range(1, last + 1)]
        first = 1
        if last >= 2 and np.linalg.norm(np.cross(axes[0], offsets[1])) <= 1e-12:
            first = 2  # the second origin lies on the first joint's axis: it never moves
        anchor = pm.jointPlacements[1].act(offsets[1]) if first == 2 else offsets[0]
        self.anchor_m = np.asarray(anchor, dtype=float)
        self.reach_m = float(sum(np.linalg.norm(offsets[i]) for i in range(first, last)))

    def beyond(self, target_m: list[float], approach: tuple[float, ...] | None) -> bool:
        """Whether no pose meets the stopping rule for ``target_m`` (3 floats) [m].

        ``approach``: the target's unit approach (base frame), or ``None`` (position only).
        ``False`` means only that the bound cannot tell.
        """
        if self.anchor_m is None:
            return False
        x = np.asarray(target_m, dtype=float)
        if approach is None:
            return float(np.linalg.norm(x - self.anchor_m)) - self.reach_m - self._tcp > self._tol_m
        w = x - self._along * np.asarray(approach, dtype=float)
        short = float(np.linalg.norm(w - self.anchor_m)) - self.reach_m
        return short - self._across - abs(self._along) * self._turn > self._tol_m


__all__ = ["ReachBound"]
