"""The sorting task: the loop of SPEC §1 and the simulated scenes it runs on."""

from mearm.task.rig import Rig, open_rig, scene_layout
from mearm.task.scene import SceneError, camera_field_cm, load_scene, random_scene
from mearm.task.sorter import SortAborted, Sorter, SortReport, TrackedObject

__all__ = [
    "Rig",
    "SceneError",
    "SortAborted",
    "SortReport",
    "Sorter",
    "TrackedObject",
    "camera_field_cm",
    "load_scene",
    "open_rig",
    "random_scene",
    "scene_layout",
]
