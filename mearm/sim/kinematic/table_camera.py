"""The simulated camera: the world's table as it is at every read (paper §1, §4).

It stands in for a real camera behind the same :class:`~mearm.vision.camera.Camera`
interface; :func:`mearm.backends.open_camera` returns one for ``camera.kind: sim``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mearm.config import Config
from mearm.sim.kinematic.renderer import Disc, Extra, TableRenderer
from mearm.sim.kinematic.world import World
from mearm.vision.calibration import Calibration
from mearm.vision.camera import NumberedCamera
from mearm.vision.errors import CameraError


class SimCamera(NumberedCamera):
    """The simulated camera: renders the objects on the world's table at every read.

    The renderer redraws the table only when the objects on it changed; each read has
    fresh sensor noise (see :class:`~mearm.sim.kinematic.renderer.TableRenderer`). Each object is
    a disc of its class's ``draw_rgb`` and ``diameter_cm`` (``task.classes``).

    Args:
        config: The whole config: ``camera`` (size, noise, light, table, seed),
            ``calibration`` (objects are drawn through its inverse) and ``task.classes``.
        world: The table; its current ``table_objects()`` are drawn (held objects and
            objects in bins are not).
        extras: Distractors drawn in every frame (see :mod:`mearm.sim.kinematic.renderer`).
    """

    def __init__(self, config: Config, world: World, extras: Sequence[Extra] = ()):
        cam = config.camera
        super().__init__("sim", (cam.width_px, cam.height_px))
        self.world = world
        self.classes = {c.name: c for c in config.task.classes}
        calibration = Calibration.from_config(config.calibration)
        self.renderer = TableRenderer.from_config(cam, calibration, extras)
        self.frames_read = 0

    def _read(self) -> np.ndarray:
        discs = []
        for o in self.world.table_objects():
            color_class = self.classes.get(o.color)
            if color_class is None:
                raise CameraError(
                    self.source,
                    f"object {o.id} is of class '{o.color}', which is not in task.classes "
                    f"({', '.join(self.classes)}): the camera cannot draw it",
                )
            discs.append(Disc.of_class(color_class, o.x_cm, o.y_cm, o.yaw_deg))
        frame = self.renderer.render(discs, frame_index=self.frames_read)
        self.frames_read += 1
        return frame
