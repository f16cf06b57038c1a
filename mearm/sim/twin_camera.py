"""The physical twin's camera: MuJoCo renders what the camera above the table sees.

It stands behind the same :class:`~mearm.vision.camera.Camera` interface as a real
camera, so the detector sees perspective, light and shadow as the twin's physics left
them: an object dropped or knocked over is seen where it lies. Rendering is offscreen on
the CPU; on Linux without a display ``MUJOCO_GL`` defaults to ``egl`` (Mesa), set before
MuJoCo is first imported (:mod:`mearm`).
"""

from __future__ import annotations

import mujoco
import numpy as np

from mearm.config import Config
from mearm.exceptions import CameraError
from mearm.sim.twin_bus import TwinArm
from mearm.vision.camera import Camera

#: The camera's name in the twin's MJCF (:mod:`mearm.sim.mjcf`).
CAMERA_NAME = "camera"


class TwinCamera(Camera):
    """Frames rendered from the twin's camera, at ``camera.width_px × height_px``.

    Args:
        config: The whole config (``camera`` gives the frame size).
        twin: The twin whose state is rendered (its ``model`` and ``data``).

    Raises:
        CameraError: no offscreen OpenGL context could be made (install Mesa's EGL or
            OSMesa, and set ``MUJOCO_GL=egl`` or ``osmesa``).
    """

    def __init__(self, config: Config, twin: TwinArm):
        cam = config.camera
        super().__init__("twin", (cam.width_px, cam.height_px))
        self.twin = twin
        try:
            self._renderer = mujoco.Renderer(twin.model, cam.height_px, cam.width_px)
        except Exception as exc:  # MuJoCo raises plain errors for a missing GL
            raise CameraError(
                self.source,
                f"cannot render offscreen ({type(exc).__name__}: {exc}); install Mesa's EGL "
                "or OSMesa and set MUJOCO_GL=egl or MUJOCO_GL=osmesa",
            ) from None
        self.frames_read = 0

    def _read(self) -> np.ndarray:
        self._renderer.update_scene(self.twin.data, camera=CAMERA_NAME)
        rgb = self._renderer.render()
        self.frames_read += 1
        return np.ascontiguousarray(rgb[:, :, ::-1])

    def close(self) -> None:  # noqa: D102
        if not self._closed:
            self._renderer.close()
        super().close()
