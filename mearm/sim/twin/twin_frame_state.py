"""The twin's camera frame as state: drawn in another process, pixel for pixel the same.

A recording's frame costs the sort's process 6.5–8 ms of CPU to draw (MuJoCo's software
renderer) and a few microseconds to describe: what ``mjv_updateScene`` reads of the
physics' data, the poses of the bodies, geoms, sites, camera and light and the tendons'
paths (:data:`FRAME_FIELDS`, about 10 kB for the 12-object scene). The recorder's encoder
process builds its own renderer from a copy of the model once a scene
(:class:`TwinFrameSource`, pickled: the model travels as MuJoCo's binary model) and draws
each frame from its state (:meth:`TwinFrameDrawer.draw`).

The poses are sent, not ``qpos``: the twin samples after ``mj_step``, whose poses are
those of the step's start; ``mj_kinematics`` of the new ``qpos`` differs from what the
sort's renderer draws by the last step's motion (82 pixels of a moving arm's edge in a
640×480 frame, measured). Copied poses give the same pixels.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import mujoco
import numpy as np

from mearm.config import Config

#: What ``mjv_updateScene`` reads of ``MjData`` for the sorter's frame (no contacts,
#: joints or inertia drawn): each one's values, in this order, are a frame's state.
FRAME_FIELDS = (
    "xpos",
    "xmat",
    "geom_xpos",
    "geom_xmat",
    "site_xpos",
    "site_xmat",
    "cam_xpos",
    "cam_xmat",
    "light_xpos",
    "light_xdir",
    "ten_wrapadr",
    "ten_wrapnum",
    "ten_length",
    "wrap_obj",
    "wrap_xpos",
)


def frame_state_size(model: mujoco.MjModel) -> int:
    """The number of float64 values in a frame's state of ``model``."""
    data = mujoco.MjData(model)
    return sum(getattr(data, name).size for name in FRAME_FIELDS)


def pack_frame_state(data: mujoco.MjData, out: np.ndarray) -> None:
    """Write ``data``'s frame state into ``out`` (float64, at least the state's size).

    The integer fields (tendon path addresses) are small: float64 holds them exactly.
    """
    at = 0
    for name in FRAME_FIELDS:
        values = getattr(data, name)
        out[at : at + values.size] = values.reshape(-1)
        at += values.size


def unpack_frame_state(state: np.ndarray, data: mujoco.MjData) -> None:
    """Set ``data``'s frame fields from ``state`` (:func:`pack_frame_state`'s layout)."""
    at = 0
    for name in FRAME_FIELDS:
        values = getattr(data, name)
        values.reshape(-1)[:] = state[at : at + values.size]
        at += values.size


class RendersRGB(Protocol):
    """A renderer of the twin's camera (:class:`~mearm.sim.twin.twin_camera.LensRenderer`)."""

    def render_rgb(self, data: mujoco.MjData, out: np.ndarray) -> bool:
        """Draw ``data``'s frame into ``out``, (h, w, 3) uint8 RGB; whether it could."""

    def close(self) -> None:
        """Free its GL context."""


@dataclass
class TwinFrameSource:
    """What another process needs to draw the twin's camera frames: sent once a scene.

    Attributes:
        model: The twin's model (pickled as MuJoCo's binary model, about 80 kB).
        config: The whole config (the frame's size, the camera's lens).
        msaa_samples: Multisamples per pixel, as the sort's renderer.
        shadows: Whether shadows are drawn, as the sort's renderer.
        renderer: The sort's renderer's class, called as it is with ``model`` and
            ``config`` (pickled by name).
    """

    model: mujoco.MjModel
    config: Config
    msaa_samples: int
    shadows: bool
    renderer: Callable[..., RendersRGB]

    @property
    def state_size(self) -> int:
        """The number of float64 values in a frame's state."""
        return frame_state_size(self.model)

    def open(self) -> TwinFrameDrawer:
        """A renderer of this scene's frames, in the calling process.

        Raises:
            CameraError: no offscreen OpenGL context could be made.
        """
        return TwinFrameDrawer(self)


class TwinFrameDrawer:
    """Draws the twin's camera frames from their states (module docstring).

    Args:
        source: The scene's model and the renderer's settings.

    Raises:
        CameraError: no offscreen OpenGL context could be made.
    """

    def __init__(self, source: TwinFrameSource):
        self._data = mujoco.MjData(source.model)
        self._renderer = source.renderer(
            source.model,
            source.config,
            msaa_samples=source.msaa_samples,
            shadows=source.shadows,
        )

    def draw(self, state: np.ndarray, out: np.ndarray) -> None:
        """Draw the frame of ``state`` into ``out``, (h, w, 3) uint8 RGB."""
        unpack_frame_state(state, self._data)
        if not self._renderer.render_rgb(self._data, out):
            raise ValueError("a lens's frames are drawn where the twin runs, not from a state")

    def close(self) -> None:
        """Free the renderer's GL context."""
        self._renderer.close()
