"""The collision model of a config's table and arm: the one place its parts are gathered.

Below the simulators a :class:`~mearm.kinematics.collision.CollisionModel` takes what it
checks (the table's contents, the arm, the servos' bodies), never the whole config; the
planner, the checks and the kinematic simulator all build theirs here.
"""

from __future__ import annotations

from collections.abc import Iterable

from mearm.config import Config
from mearm.config.servo_models import ServoSpec, servo_named
from mearm.kinematics import ArmModel
from mearm.kinematics.bodies import TableContents
from mearm.kinematics.collision import DEFAULT_CLEARANCE_CM, CollisionModel, joint_servo


def collision_model(
    config: Config,
    model: ArmModel,
    *,
    clearance_cm: float | None = None,
    servo: ServoSpec | None = None,
    bins: Iterable[str] | None = None,
    table: TableContents | None = None,
) -> CollisionModel:
    """The planner's collision model of a config's table, its twin's servos and ``model``.

    Args:
        config: The whole configuration: its classes, scene and belt, and the twin's
            servos (``twin.gripper_servo``, ``twin.joint_servo``).
        model: The arm's kinematic model.
        clearance_cm: What every arm shape keeps from bins and objects [cm] (``None``:
            :data:`~mearm.kinematics.collision.DEFAULT_CLEARANCE_CM`).
        servo: The joints' servo (default: ``twin.joint_servo``'s).
        bins: The classes whose bins stand on the table (default: every class's).
        table: How many objects of each class the table holds, which the bins' walls are
            built for (default: the config's scene and belt).
    """
    return CollisionModel(
        TableContents.of(config.task, config.belt) if table is None else table,
        model,
        gripper_servo=servo_named(config.twin.gripper_servo),
        clearance_cm=DEFAULT_CLEARANCE_CM if clearance_cm is None else clearance_cm,
        servo=servo or joint_servo(config.twin.joint_servo),
        bins=bins,
    )
