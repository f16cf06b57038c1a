"""The tool on the chain's last frame: TCP, approach axis, gripper, tool actuators, marker."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, model_validator

from mearm.config.base import (
    MAX_ANGLE_DEG,
    MAX_LENGTH_CM,
    Angle,
    Name,
    NonNegativeLength,
    PositiveLength,
    Range,
    Strict,
    Vector3,
)
from mearm.config.servo_calibration import ServoCalibration

#: Jaws thinner or shorter than this cannot be drawn or gripped with [cm].
MIN_JAW_CM = 0.01


class ToolActuator(Strict):
    """A tool servo that does not move the TCP, set per phase of a pick.

    The paper's gripper arm (θ5) is one: 60° at home, 30° while travelling, −60° to grip.
    """

    name: Name
    servo: ServoCalibration
    limits: Range
    home: Angle
    travel: Angle
    grip: Angle

    @model_validator(mode="after")
    def _settings(self) -> ToolActuator:
        for end in ("min", "max"):
            if abs(getattr(self.limits, end)) > MAX_ANGLE_DEG:
                raise ValueError(
                    f"@limits.{end}: {getattr(self.limits, end):g} deg is more than a turn; "
                    f"a tool actuator's limits lie within ±{MAX_ANGLE_DEG:g} deg"
                )
        for end in ("min", "max"):
            self.servo.check_value(getattr(self.limits, end), f"limits.{end}")
        for key in ("home", "travel", "grip"):
            value = getattr(self, key)
            if not self.limits.contains(value):
                raise ValueError(
                    f"@{key}: {value:g} is outside the limits "
                    f"[{self.limits.min:g}, {self.limits.max:g}]"
                )
        return self

    def setting(self, phase: Literal["home", "travel", "grip"]) -> float:
        """The value for a phase of the pick [deg]."""
        return float(getattr(self, phase))


class Gripper(Strict):
    """The gripper: a named actuator that sets the opening between two parallel jaws.

    Its calibration maps the opening [cm] to a pulse. The URDF draws the jaws as two
    prismatic joints, the second a ``mimic`` of the first.
    """

    name: Name = "gripper"
    servo: ServoCalibration
    open_cm: PositiveLength
    """Opening between the jaws when open [cm]."""
    closed_cm: NonNegativeLength
    """Opening when closed on nothing [cm]."""
    jaw_length_cm: float = Field(default=3.0, ge=MIN_JAW_CM, le=MAX_LENGTH_CM, allow_inf_nan=False)
    """A jaw's length along the approach axis, measured from its root to its tip [cm]. The
    jaws sit where they grip: each ends in a pad centred on the grip point
    (``tcp_above_grip_cm`` beyond the TCP), so the tip is half a pad beyond it and the
    root this much before the tip; a mount bridges the TCP to the roots when they start
    beyond it."""
    jaw_thickness_cm: float = Field(
        default=0.5, ge=MIN_JAW_CM, le=MAX_LENGTH_CM, allow_inf_nan=False
    )
    """A jaw's thickness along the opening axis; its inner face is at half the opening [cm]."""

    @model_validator(mode="after")
    def _settings(self) -> Gripper:
        if not self.closed_cm < self.open_cm:
            raise ValueError(
                f"@closed_cm: {self.closed_cm:g} must be below open_cm ({self.open_cm:g})"
            )
        self.servo.check_value(self.open_cm, "open_cm")
        self.servo.check_value(self.closed_cm, "closed_cm")
        return self

    def opening_cm(self, *, closed: bool) -> float:
        """The opening for closed or open [cm]."""
        return self.closed_cm if closed else self.open_cm


class ClawMarker(Strict):
    """An ArUco marker fixed on the tool, so that the camera sees where the claw is.

    The marker is printed on a stiff plate (``mearm aruco-sheet`` prints it) whose face
    looks along :attr:`faces` (by default away from the jaws along the tool's approach
    axis: up, when the jaws hang down to pick). Its top edge points along the jaws' third
    axis (across the approach and the opening axes) or, where the face looks along that,
    along the approach axis.
    ``calibrate-servos --camera`` and the sort's picks that look
    (:mod:`mearm.task.claw_loop`) measure it with the calibrated camera.
    """

    id: int = Field(ge=0, le=999)
    """The marker's id in :attr:`dictionary`."""
    size_cm: PositiveLength
    """The printed side of the marker's black square [cm]."""
    dictionary: str = "DICT_4X4_50"
    """The ArUco dictionary it is printed from (OpenCV's name)."""
    faces: Vector3 | None = None
    """Where the marker's face looks, in the TCP frame; ``null``: against the approach axis."""
    centre_cm: Vector3 | None = None
    """The marker's centre in the TCP frame [cm]; ``null``: on the plate resting on the
    gripper's servo (and each tool actuator's) on the side :attr:`faces` names."""
    border_cm: NonNegativeLength = 0.5
    """The white plate's margin around the black square [cm]."""

    @model_validator(mode="after")
    def _face(self) -> ClawMarker:
        if self.faces is not None and math.hypot(*self.faces) < 1e-9:
            raise ValueError(f"@faces: must be a non-zero vector, got {list(self.faces)}")
        return self


class Tool(Strict):
    """What sits on the last frame of the chain."""

    tcp_cm: Vector3 = (0.0, 0.0, 0.0)
    """The tool centre point in the last DH frame [cm]: what IK targets move."""
    approach_axis: Vector3 = (0.0, 0.0, 1.0)
    """The tool's approach axis in the last DH frame (normalised when used): the way the
    jaws point from the TCP. The collision checks hang the jaws along it, so it must be
    the way they really point (down, on an arm whose wrist keeps the jaws hanging)."""
    pick_approach: Vector3 | None = None
    """Direction (base frame) the approach axis must point in when picking and placing,
    e.g. ``[0, 0, -1]`` for a wrist that picks from above; ``null``: position only."""
    tcp_above_grip_cm: NonNegativeLength = 0.0
    """How far above the point where the jaws close the TCP is when picking [cm]."""
    settle_s: float = Field(default=0.1, ge=0, le=10, allow_inf_nan=False)
    """How long a tool setting (the gripper opening or closing, a tool actuator moving)
    is held after its servos' travel at their speed limit, before the arm moves on [s].
    The default, 0.1 s, is four times a micro servo motor's time constant (about 25 ms,
    :data:`mearm.config.servo_models.MOTOR_TIME_CONSTANT_S`): room for the jaws to stop
    and the grip to take hold."""
    gripper: Gripper
    # copied for each model (why a default: SimErrorModel.offset_deg)
    actuators: list[ToolActuator] = Field(default=[], max_length=12)
    marker: ClawMarker | None = None
    """An ArUco marker on the claw, for the camera to measure the arm (``null``: none)."""

    @model_validator(mode="after")
    def _axes(self) -> Tool:
        for key in ("approach_axis", "pick_approach"):
            v = getattr(self, key)
            if v is not None and math.hypot(*v) < 1e-9:
                raise ValueError(f"@{key}: must be a non-zero vector, got {list(v)}")
        return self
