"""Opening the rig a config describes: world (if simulated), camera and servo bus."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from dataclasses import dataclass

from mearm.config import Config, SceneObject
from mearm.hardware import ServoBus, open_bus
from mearm.kinematics import ArmModel
from mearm.vision import Camera, open_camera
from mearm.world import World


@dataclass
class Rig:
    """The parts of one rig, simulated or real.

    Attributes:
        world: The simulated table, or ``None`` on a real rig (camera and servos real).
        camera: The frame source.
        bus: The servo bus (not yet connected).
        model: The arm model.
    """

    world: World | None
    camera: Camera
    bus: ServoBus
    model: ArmModel

    @property
    def simulated(self) -> bool:
        """Whether any part of the rig is simulated."""
        return self.world is not None


def uses_world(config: Config) -> bool:
    """Whether the camera or the servos are simulated, so a world model is needed."""
    return config.camera.kind == "sim" or config.servo.backend == "sim"


def scene_layout(config: Config, scene: list[SceneObject] | None = None) -> list[dict[str, object]]:
    """The simulated table as run-log entries ``{id, color, x, y}``; empty on a real rig.

    Ids are the ones :class:`~mearm.world.World` gives (``red1``, ``red2``, …).
    """
    if not uses_world(config):
        return []
    world = World.from_scene(config.task.scene if scene is None else scene, config.task.bins_cm)
    return [{"id": o.id, "color": o.color, "x": o.x_cm, "y": o.y_cm} for o in world.objects]


@contextlib.contextmanager
def open_rig(config: Config, scene: list[SceneObject] | None = None) -> Iterator[Rig]:
    """Open camera and servo bus (and the world, if simulated); close them on exit.

    Args:
        config: The whole configuration.
        scene: Objects for the simulated table (default: ``config.task.scene``).
    """
    world = None
    if uses_world(config):
        world = World.from_scene(config.task.scene if scene is None else scene, config.task.bins_cm)
    model = ArmModel(config.robot)
    with contextlib.ExitStack() as stack:
        camera = stack.enter_context(open_camera(config, world=world))
        bus = open_bus(config, world=world)
        stack.callback(bus.close)
        yield Rig(world=world, camera=camera, bus=bus, model=model)
