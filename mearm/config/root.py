"""The whole configuration: the arm, the rig around it and the task."""

from __future__ import annotations

from pydantic import Field, model_validator

from mearm.config.arm import ArmDescription
from mearm.config.base import Strict
from mearm.config.defaults import paper_arm
from mearm.config.rig import (
    CalibrationConfig,
    CameraConfig,
    ControllerConfig,
    ServoConfig,
    TaskConfig,
    VisionConfig,
)


class Config(Strict):
    """The whole configuration. Its defaults are the simulated rig with the paper's arm."""

    arm: ArmDescription = Field(default_factory=paper_arm)
    camera: CameraConfig = CameraConfig()
    calibration: CalibrationConfig = CalibrationConfig()
    vision: VisionConfig = VisionConfig()
    controller: ControllerConfig = ControllerConfig()
    servo: ServoConfig = ServoConfig()
    task: TaskConfig = TaskConfig()

    @model_validator(mode="after")
    def _names_known(self) -> Config:
        actuated = [j.name for j in self.arm.actuated_joints()]
        for name in self.servo.error_model.offset_deg:
            if name not in actuated:
                raise ValueError(
                    f"@servo.error_model.offset_deg.{name}: not an actuated joint "
                    f"(actuated: {', '.join(actuated)})"
                )
        return self
