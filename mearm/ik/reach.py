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

**With the anchor joint's limits** (:meth:`ReachBound.beyond_limits`). Where the anchor
is the second joint's origin, the third joint's origin :math:`o_{k+1}` turns about the
anchor joint's axis through that joint's limits only, and about the first joint's axis
(any turn: the first joint's limits are ignored). A pose within the limits puts
:math:`o_p` within :math:`L' = L - |o_{k+1} - o_k|` of it, so the same bound holds with
:math:`|w - o_k| - L` replaced by :math:`\min |w - o_{k+1}| - L'`. Turned about the first
axis, :math:`o_{k+1}` is nearest :math:`w` at :math:`w`'s own azimuth: the distance is
that of the points (distance from the axis, height along it) in a half-plane, taken at
:data:`LIMIT_SAMPLES` angles through the limits; between two of them it is at most the
radius of :math:`o_{k+1}`'s turn times half their spacing less, which is taken off. It
refuses what the anchor joint's limits forbid (a 5-DOF's shoulder that may not turn
below the horizontal, far out on the table) as well as what the lengths do; a plan it
refuses can only fail, since a plan ends within the limits, at a pose that meets the
stopping rule.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from mearm.kinematics import ArmModel

#: Room left for rounding in the kinematics [m]: far below any tolerance, far above
#: the error of a few products of metre-sized numbers.
_SLACK_M = 1e-9
#: Angles through the anchor joint's limits :meth:`ReachBound.beyond_limits` takes: the
#: distance it takes off between two is the turn's radius times half their spacing
#: (0.001 mm for a 15 cm upper arm through 150°).
LIMIT_SAMPLES = 2049
#: A pose within the limits is a plan's to this much [rad or m] (the planner's check).
_LIMIT_TOL = 1e-9


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
        # set before any return: an arm without a bound (a rail, a branch) has no
        # profile either, and :meth:`beyond_limits` reads it
        self._profile: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float] | None = None
        self._rest_m = math.inf  # L' (module docstring)
        if last < 1 or not serial or axes[0] is None or any(a is None for a in axes):
            return
        offsets = [np.asarray(pm.jointPlacements[i].translation, float) for i in range(1, last + 1)]
        first = 1
        if last >= 2 and np.linalg.norm(np.cross(axes[0], offsets[1])) <= 1e-12:
            first = 2  # the second origin lies on the first joint's axis: it never moves
        anchor = pm.jointPlacements[1].act(offsets[1]) if first == 2 else offsets[0]
        self.anchor_m = np.asarray(anchor, dtype=float)
        self.reach_m = float(sum(np.linalg.norm(offsets[i]) for i in range(first, last)))
        if first == 2 and last >= 3:
            self._profile = self._limit_profile(model, axes, offsets)

    def _limit_profile(
        self, model: ArmModel, axes: list[np.ndarray | None], offsets: list[np.ndarray]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
        """Where the third joint's origin may be, turned through the second's limits.

        Its (distance from the first joint's axis, height along it) at each of
        :data:`LIMIT_SAMPLES` angles [m], the first axis (a point on it, its direction)
        and what one spacing may hide [m] (module docstring).
        """
        pm, chain = model.model, model.chain
        M1, M2 = pm.jointPlacements[1], pm.jointPlacements[2]
        axis1, axis2 = axes[0], axes[1]
        assert axis1 is not None and axis2 is not None  # (revolute: the caller's test)
        i = chain.names.index(pm.names[2])
        lo, hi = chain.lower[i] - _LIMIT_TOL, chain.upper[i] + _LIMIT_TOL
        thetas = np.linspace(lo, hi, LIMIT_SAMPLES)
        t = offsets[2]
        points = np.array([M1.act(M2.act(pin.exp3(axis2 * th) @ t)) for th in thetas])
        origin = np.asarray(M1.translation, dtype=float)
        up = np.asarray(M1.rotation @ axis1, dtype=float)
        rel = points - origin
        height = rel @ up
        out = np.linalg.norm(rel - np.outer(height, up), axis=1)
        # the origin's speed about the second axis: its distance from that axis
        radius = float(np.linalg.norm(t - (t @ axis2) * axis2))
        hidden = radius * (hi - lo) / (LIMIT_SAMPLES - 1) / 2 + _SLACK_M
        self._rest_m = self.reach_m - float(np.linalg.norm(t))
        return out, height, origin, up, hidden

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

    def beyond_limits(self, target_m: list[float], approach: tuple[float, ...] | None) -> bool:
        """:meth:`beyond`, or beyond every pose the anchor joint's limits allow (module).

        Slower than :meth:`beyond` (some tens of microseconds): for a caller that would
        otherwise plan the target, not for the solver's own test. ``False`` means only
        that neither bound can tell.
        """
        if self.beyond(target_m, approach):
            return True
        if self._profile is None:
            return False
        out, height, origin, up, hidden = self._profile
        x = np.asarray(target_m, dtype=float)
        w = x if approach is None else x - self._along * np.asarray(approach, dtype=float)
        rel = w - origin
        h = float(rel @ up)
        r = float(np.linalg.norm(rel - h * up))
        near = float(np.min(np.hypot(out - r, height - h))) - hidden
        if approach is None:
            return near - self._rest_m - self._tcp > self._tol_m
        short = near - self._rest_m
        return short - self._across - abs(self._along) * self._turn > self._tol_m


__all__ = ["ReachBound"]
