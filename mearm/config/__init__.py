"""Typed configuration: one pydantic model tree, loaded from YAML.

The defaults of :class:`Config` *are* the simulated rig with the paper's arm
(``configs/sim.yaml`` writes them out with comments). The arm (:class:`ArmDescription`)
and the colour classes (:class:`ColorClass`) are data: any hobby arm and any set of
classes is a config file, not code. Each reference arm is one file (``configs/arms/``)
that configs name (``arm: {use: mearm_v1}``), and a config may build on another
(``extends``), giving only what differs (:mod:`mearm.config.compose`).

Loading is strict: unknown keys are rejected and each bad field is reported with its
dotted path, the value given and what is allowed (:class:`~mearm.errors.ConfigError`).
Files are read through :mod:`mearm.yamlio` (no special files, duplicate keys, tags, alias
bombs or deep nesting), and every number is bounded by physical sense, so a config that
loads cannot overflow, hang or exhaust memory later.
"""

from mearm.config.arm import (
    ArmDescription,
    ClawMarker,
    Coupling,
    DHRow,
    Gripper,
    Joint,
    JointServo,
    JointType,
    ServoCalibration,
    ServoDrives,
    TargetBox,
    Tool,
    ToolActuator,
)
from mearm.config.base import (
    Angle,
    Finite,
    Length,
    Name,
    NonNegative,
    NonNegativeLength,
    Positive,
    PositiveLength,
    Range,
    Seed,
    Strict,
    short_repr,
)
from mearm.config.belt_config import BeltArrivals, BeltConfig
from mearm.config.classes import ColorClass, HueBand, LearnedColour
from mearm.config.defaults import default_classes, paper_arm, paper_classes
from mearm.config.files import load_config, read_yaml
from mearm.config.loader import apply_overrides, config_from_dict
from mearm.config.root import Config, ServoKitConfig, TwinConfig
from mearm.config.sections import (
    CalibrationConfig,
    CameraConfig,
    ControllerConfig,
    SceneObject,
    ServoConfig,
    SimErrorModel,
    TaskConfig,
    VisionConfig,
)

__all__ = [
    "Angle",
    "ArmDescription",
    "BeltArrivals",
    "BeltConfig",
    "CalibrationConfig",
    "CameraConfig",
    "ColorClass",
    "Config",
    "ControllerConfig",
    "Coupling",
    "DHRow",
    "Finite",
    "Gripper",
    "HueBand",
    "LearnedColour",
    "Joint",
    "JointServo",
    "JointType",
    "Length",
    "Name",
    "NonNegative",
    "NonNegativeLength",
    "Positive",
    "PositiveLength",
    "Range",
    "SceneObject",
    "Seed",
    "ServoCalibration",
    "ServoConfig",
    "ServoDrives",
    "SimErrorModel",
    "Strict",
    "TargetBox",
    "TaskConfig",
    "ServoKitConfig",
    "TwinConfig",
    "ClawMarker",
    "Tool",
    "ToolActuator",
    "VisionConfig",
    "apply_overrides",
    "config_from_dict",
    "default_classes",
    "load_config",
    "paper_arm",
    "paper_classes",
    "read_yaml",
    "short_repr",
]
