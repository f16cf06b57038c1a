"""mearm: a vision-guided colour-sorting robot arm (the MeArm of Agustian et al.).

config → kinematics → (vision, ik) → hardware → task. See README.md.
"""

from mearm.config import Config, config_from_dict, load_config
from mearm.exceptions import (
    ConfigError,
    InvalidTargetError,
    JointLimitError,
    MearmError,
    ModelError,
    TargetError,
    TargetOutsideBoxError,
    UnreachableTargetError,
)
from mearm.kinematics import ArmModel, analytic_ik_deg, check_target, dh_fk, dh_to_urdf
from mearm.world import World, WorldObject

__version__ = "0.1.0"

__all__ = [
    "ArmModel",
    "Config",
    "ConfigError",
    "InvalidTargetError",
    "JointLimitError",
    "MearmError",
    "ModelError",
    "TargetError",
    "TargetOutsideBoxError",
    "UnreachableTargetError",
    "World",
    "WorldObject",
    "__version__",
    "analytic_ik_deg",
    "check_target",
    "config_from_dict",
    "dh_fk",
    "dh_to_urdf",
    "load_config",
]
