"""The sorting task: plan → execute → report around one route record.

Also the loop that drives them, the rig it runs on, and simulated scenes.
"""

from mearm.task.execute import Executor
from mearm.task.plan import RETRY_LIFT_CM, Planner
from mearm.task.report import Reporter, Skip, SortReport
from mearm.task.rig import Rig, open_rig, run_sort, scene_layout
from mearm.task.route import Route
from mearm.task.scene import (
    SceneError,
    camera_field_cm,
    check_scene,
    load_scene,
    random_scene,
)
from mearm.task.sorter import SortAborted, Sorter, TrackedObject

__all__ = [
    "RETRY_LIFT_CM",
    "Executor",
    "Planner",
    "Reporter",
    "Rig",
    "Route",
    "SceneError",
    "Skip",
    "SortAborted",
    "SortReport",
    "Sorter",
    "TrackedObject",
    "camera_field_cm",
    "check_scene",
    "load_scene",
    "open_rig",
    "random_scene",
    "run_sort",
    "scene_layout",
]
