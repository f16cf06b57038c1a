"""Errors of the arm's model: its description, its joints and the targets asked of it.

Raised by the kinematics (the chain, the model's limits, the closed forms) and by the
layers that check a value against them before anything moves (:mod:`mearm.ik`,
:mod:`mearm.hardware`).
"""

from __future__ import annotations

from collections.abc import Sequence

from mearm.errors import MearmError


class ModelError(MearmError):
    """The robot description (URDF / DH table) is missing or inconsistent."""


class JointLimitError(MearmError):
    """A joint angle is outside its limits.

    Attributes:
        joint: Joint name, e.g. ``"shoulder"``.
        value_deg: The offending value [deg, or cm for a prismatic joint].
        lower_deg: Lower limit [same unit].
        upper_deg: Upper limit [same unit].
        unit: ``deg`` or ``cm``.
    """

    def __init__(
        self, joint: str, value_deg: float, lower_deg: float, upper_deg: float, unit: str = "deg"
    ):
        self.joint = joint
        self.value_deg = float(value_deg)
        self.lower_deg = float(lower_deg)
        self.upper_deg = float(upper_deg)
        self.unit = unit
        super().__init__(
            f"{joint} = {self.value_deg:.4g} {unit} is outside its limits "
            f"[{self.lower_deg:.4g}, {self.upper_deg:.4g}] {unit}"
            + past_limit_text(self.value_deg, self.lower_deg, self.upper_deg)
        )


def past_limit_text(value: float, lower: float, upper: float) -> str:
    """Where a value outside [lower, upper] that reads as a limit at 4 digits lies.

    ``160.0000001`` prints as ``160`` beside the limit ``160``, which hides why it was
    refused: then the value and the limit are shown with as many digits as tell them
    apart, ``" (160.0000001 > 160)"``; otherwise nothing.
    """
    if not (value < lower or value > upper):
        return ""  # within (a tolerance let it be refused) or NaN: the 4 digits say it
    bound, sign = (lower, "<") if value < lower else (upper, ">")
    if f"{value:.4g}" != f"{bound:.4g}":
        return ""
    for digits in range(5, 18):
        shown, limit = f"{value:.{digits}g}", f"{bound:.{digits}g}"
        if shown != limit:
            return f" ({shown} {sign} {limit})"
    return f" ({value!r} {sign} {bound!r})"


class InvalidJointsError(MearmError):
    """A joint vector cannot be used as a start: wrong length, not finite, or uncoupled.

    Attributes:
        joints: The values given (as floats where possible).
        reason: What is wrong and what is allowed.
    """

    def __init__(self, joints: Sequence[float], reason: str):
        self.joints = tuple(joints)
        self.reason = reason
        super().__init__(f"joints {list(self.joints)!r}: {reason}")


class InvalidTargetError(MearmError):
    """A target is not three finite numbers."""


class TargetError(MearmError):
    """A Cartesian target cannot be used; raised before anything moves.

    Attributes:
        target_cm: The target (x, y, z) in the base frame [cm].
        reason: Why it was refused.
    """

    def __init__(self, target_cm: Sequence[float], reason: str):
        self.target_cm = tuple(float(v) for v in target_cm)
        self.reason = reason
        x, y, z = self.target_cm
        super().__init__(f"target ({x:.4g}, {y:.4g}, {z:.4g}) cm: {reason}")


class TargetOutsideBoxError(TargetError):
    """The target lies outside the end-effector target box (paper §3, Table 3).

    Attributes:
        axis: The violated axis, ``"x"``, ``"y"`` or ``"z"``.
        bounds_cm: The allowed (min, max) on that axis [cm].
    """

    def __init__(self, target_cm: Sequence[float], axis: str, bounds_cm: tuple[float, float]):
        self.axis = axis
        self.bounds_cm = (float(bounds_cm[0]), float(bounds_cm[1]))
        value = float(target_cm["xyz".index(axis)])
        super().__init__(
            target_cm,
            f"{axis} = {value:.4g} is outside the target box {axis} ∈ "
            f"[{self.bounds_cm[0]:.4g}, {self.bounds_cm[1]:.4g}] cm",
        )


class UnreachableTargetError(TargetError):
    """The target is inside the box but the arm cannot reach it within its joint limits."""


class JointLimitTargetError(UnreachableTargetError):
    """The links reach the target, but only with a joint outside its limits.

    Attributes:
        joint: The joint that would leave its limits.
        value: The value it would need [deg, or cm for a prismatic joint].
        lower: Its lower limit [same unit].
        upper: Its upper limit [same unit].
        unit: ``deg`` or ``cm``.

    ``why``: where the limits come from, when not the joint's own (a passive joint held
    to what a servo over a combination reaches, :meth:`ArmDescription.joint_limits
    <mearm.config.arm.ArmDescription.joint_limits>`).
    """

    def __init__(
        self,
        target_cm: Sequence[float],
        joint: str,
        value: float,
        lower: float,
        upper: float,
        unit: str = "deg",
        why: str | None = None,
    ):
        self.joint = joint
        self.value = float(value)
        self.lower = float(lower)
        self.upper = float(upper)
        self.unit = unit
        super().__init__(
            target_cm,
            f"needs {joint} = {self.value:.2f} {unit}, outside its limits "
            f"[{self.lower:.4g}, {self.upper:.4g}] {unit}"
            + (f" ({why})" if why else "")
            + past_limit_text(self.value, self.lower, self.upper),
        )


class SingularTargetError(UnreachableTargetError):
    """The target sits where the arm is singular (on the base axis: the base is undefined)."""
