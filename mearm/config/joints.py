r"""A joint of the chain: its DH row, and either a servo (actuated) or a coupling (passive).

.. math:: T_{i-1,i} = R_z(\theta_i)\,T_z(d_i)\,T_x(a_i)\,R_x(\alpha_i)

whose variable is θ (``revolute``, degrees) or d (``prismatic``, centimetres); a passive
joint's value is :math:`q_p = \sum_j c_{pj}\, q_j + c_p` over the actuated joints.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from mearm.config.base import (
    MAX_ANGLE_DEG,
    Angle,
    Length,
    Name,
    Range,
    Strict,
)
from mearm.config.servo_calibration import Coefficient, JointServo, ServoCalibration

JointType = Literal["revolute", "prismatic"]


class DHRow(Strict):
    r"""One standard DH row, :math:`R_z(\theta)\,T_z(d)\,T_x(a)\,R_x(\alpha)`.

    For a revolute joint the variable is added to ``theta_deg``; for a prismatic joint
    it is added to ``d_cm``.
    """

    a_cm: Length = 0.0
    alpha_deg: Angle = 0.0
    d_cm: Length = 0.0
    theta_deg: Angle = 0.0
    """Constant offset of θ [deg] (the joint variable of a revolute joint adds to it)."""

    def transform(self, value: float, joint_type: JointType = "revolute") -> np.ndarray:
        """The (4, 4) transform of this row at joint value ``value``.

        Args:
            value: θ [rad] for a revolute joint, d [cm] for a prismatic one.
            joint_type: ``revolute`` or ``prismatic``.

        Returns:
            The homogeneous transform, translation in cm.
        """
        theta = math.radians(self.theta_deg)
        d = self.d_cm
        if joint_type == "revolute":
            theta += value
        else:
            d += value
        ct, st = math.cos(theta), math.sin(theta)
        alpha = math.radians(self.alpha_deg)
        ca, sa = math.cos(alpha), math.sin(alpha)
        return np.array(
            [
                [ct, -ca * st, sa * st, self.a_cm * ct],
                [st, ca * ct, -sa * ct, self.a_cm * st],
                [0.0, sa, ca, d],
                [0.0, 0.0, 0.0, 1.0],
            ]
        )


class Coupling(Strict):
    """A passive joint's value as an affine function of actuated joints.

    ``terms`` maps actuated joint names to coefficients [-]; ``offset`` is in the
    joint's unit (deg or cm). The paper arm's parallelogram: ``terms: {shoulder: -1,
    elbow: -1}``.
    """

    terms: dict[Name, Coefficient] = Field(min_length=1, max_length=12)
    offset: Length = 0.0


class Joint(Strict):
    """One joint of the chain: its DH row and either a servo (actuated) or a coupling."""

    name: Name
    type: JointType = "revolute"
    dh: DHRow = DHRow()
    limits: Range | None = None
    """[deg] or [cm]; required for an actuated joint; a passive joint's default is the
    range its coupling gives over the actuated joints' limits."""
    home: Length | None = None
    """Home value of an actuated joint [deg] or [cm]."""
    servo: JointServo | None = None
    coupling: Coupling | None = None

    @field_validator("servo", mode="before")
    @classmethod
    def _joint_servo(cls, value: object) -> object:
        """A plain :class:`ServoCalibration` given in code is a servo that turns its joint."""
        if isinstance(value, ServoCalibration) and not isinstance(value, JointServo):
            return value.model_dump()
        return value

    @model_validator(mode="after")
    def _actuated_or_passive(self) -> Joint:
        if (self.servo is None) == (self.coupling is None):
            raise ValueError(
                f"joint '{self.name}' needs exactly one of 'servo' (actuated) or "
                "'coupling' (passive)"
            )
        if self.type == "revolute" and self.limits is not None:
            for end in ("min", "max"):
                if abs(getattr(self.limits, end)) > MAX_ANGLE_DEG:
                    raise ValueError(
                        f"@limits.{end}: {getattr(self.limits, end):g} deg is more than a "
                        f"turn; a revolute joint's limits lie within ±{MAX_ANGLE_DEG:g} deg"
                    )
        if self.servo is not None:
            if self.limits is None:
                raise ValueError("@limits: required for an actuated joint")
            if self.home is None:
                raise ValueError("@home: required for an actuated joint")
            if not self.limits.contains(self.home):
                raise ValueError(
                    f"@home: {self.home:g} is outside the limits "
                    f"[{self.limits.min:g}, {self.limits.max:g}]"
                )
            self._check_servo(self.servo, self.limits)
        elif self.home is not None:
            raise ValueError("@home: a passive joint takes no home: its coupling gives it")
        elif self.type == "revolute" and self.coupling is not None:
            if abs(self.coupling.offset) > MAX_ANGLE_DEG:
                raise ValueError(
                    f"@coupling.offset: {self.coupling.offset:g} deg is more than a turn; a "
                    f"revolute joint's offset lies within ±{MAX_ANGLE_DEG:g} deg"
                )
        return self

    def _check_servo(self, servo: JointServo, limits: Range) -> None:
        """The servo's own checks: a combination that turns something, limits in range.

        A servo over this joint alone has its pulse range checked at both limits; one over
        several joints is checked where the arm is (:class:`ArmDescription`).
        """
        drives = servo.drives
        if drives is not None:
            if all(c == 0 for c in drives.terms.values()):
                raise ValueError(
                    "@servo.drives.terms: every coefficient is 0: the servo would turn "
                    "nothing; give at least one joint a non-zero coefficient"
                )
            if self.type == "revolute" and abs(drives.offset) > MAX_ANGLE_DEG:
                raise ValueError(
                    f"@servo.drives.offset: {drives.offset:g} deg is more than a turn; a "
                    f"revolute joint's servo offset lies within ±{MAX_ANGLE_DEG:g} deg"
                )
        if not servo.drives_only(self.name):
            return
        own = servo.combination(self.name)
        c = own.terms[self.name]
        for end in ("min", "max"):
            value = getattr(limits, end)
            if drives is None:
                servo.check_value(value, f"limits.{end}")
                continue
            v = c * value + own.offset
            problem = servo.pulse_problem(v)
            if problem is not None:
                raise ValueError(
                    f"@limits.{end}: {value:g} puts its servo's value {own.text()} at {v:g}, "
                    f"which {problem}"
                )

    @property
    def actuated(self) -> bool:
        """Whether a servo drives this joint."""
        return self.servo is not None

    @property
    def unit(self) -> str:
        """``deg`` or ``cm``."""
        return "deg" if self.type == "revolute" else "cm"
