"""The twin's camera frames drawn from their state in the encoder's process: light to import.

A recording's twin frame travels as its state, what ``mjv_updateScene`` reads of the
physics (:data:`FRAME_FIELDS`, written by
:func:`mearm.sim.twin.twin_frame_state.pack_frame_state`); the encoder's process
(:mod:`mearm.dataset.encoder_server`) unpickles a :class:`TwinFrameSource` once a scene
and draws each frame from its state (:meth:`TwinFrameDrawer.draw`) as the sort's renderer
(:class:`~mearm.sim.twin.twin_camera.LensRenderer` without a lens) draws it, pixel for
pixel. Only NumPy and MuJoCo are imported here (and :mod:`mearm.interrupts`, the
standard library's): that process's start-up, which the sort's first frames wait for,
is its imports, and the twin's camera module with the config and the kinematics cost
0.2–0.3 s of CPU more.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from mearm.interrupts import signals_deferred

#: A render's scene has room for this many geoms per geom and tendon of the model …
SCENE_GEOMS_PER_GEOM = 4
#: … and for this many at least.
SCENE_GEOMS_MIN = 1000
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


def unpack_frame_state(state: np.ndarray, data: mujoco.MjData) -> None:
    """Set ``data``'s frame fields from ``state`` (``pack_frame_state``'s layout)."""
    at = 0
    for name in FRAME_FIELDS:
        values = getattr(data, name)
        values.reshape(-1)[:] = state[at : at + values.size]
        at += values.size


def offscreen_renderer(
    model: mujoco.MjModel, size_px: tuple[int, int], *, msaa_samples: int | None, shadows: bool
) -> mujoco.Renderer:
    """MuJoCo's offscreen renderer of ``model``, (w, h) ``size_px``, as the twin's camera's.

    The GL context takes the samples (``None``: the model's) and the shadow map's size
    from the model when it is made; ``model`` is put back as it was at once (it is the
    twin's own: its renders follow the live model). Its scene holds
    :func:`scene_geoms` geoms, not MuJoCo's default 10,000 (which cost 20–35 ms of CPU to
    make, for the twin's 74), and its font is the smallest (no text is drawn).

    Raises:
        Exception: MuJoCo's own, when no offscreen OpenGL context can be made.
    """
    quality = model.vis.quality
    kept = (quality.offsamples, quality.shadowsize)
    if msaa_samples is not None:
        quality.offsamples = msaa_samples
    if not shadows:
        quality.shadowsize = 0
    try:
        renderer = mujoco.Renderer(
            model,
            size_px[1],
            size_px[0],
            max_geom=scene_geoms(model),
            font_scale=mujoco.mjtFontScale.mjFONTSCALE_50,
        )
    finally:
        quality.offsamples, quality.shadowsize = kept
    renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows
    return renderer


def scene_geoms(model: mujoco.MjModel) -> int:
    """Room for geoms in a render's scene: :data:`SCENE_GEOMS_PER_GEOM` per geom and tendon.

    At least :data:`SCENE_GEOMS_MIN`. A scene that runs out of room drops geoms from the
    picture with neither an error nor a warning (MuJoCo 4), so the room is generous: each
    model geom draws one, and the twin's tendon and decorations a few more.
    """
    return max(SCENE_GEOMS_MIN, SCENE_GEOMS_PER_GEOM * (model.ngeom + model.ntendon))


def close_renderer(renderer: mujoco.Renderer) -> None:
    """Free ``renderer``'s GL context, a Ctrl-C or a stop signal taken after, not inside.

    MuJoCo forgets the context only once it has been destroyed: a Ctrl-C in between
    left it named, and the renderer's ``__del__`` destroyed it again at exit, which
    printed an "Exception ignored ... EGL_BAD_CONTEXT" block after the command's
    "interrupted" (:func:`~mearm.interrupts.signals_deferred`).
    """
    with signals_deferred():
        renderer.close()


@dataclass
class TwinFrameSource:
    """What another process needs to draw the twin's camera frames: sent once a scene.

    Attributes:
        model: The twin's model (pickled as MuJoCo's binary model, about 80 kB).
        size_px: The frame's (width, height) [px].
        camera: The camera's name in ``model``.
        msaa_samples: Multisamples per pixel, as the sort's renderer.
        shadows: Whether shadows are drawn, as the sort's renderer.
    """

    model: mujoco.MjModel
    size_px: tuple[int, int]
    camera: str
    msaa_samples: int
    shadows: bool

    @property
    def state_size(self) -> int:
        """The number of float64 values in a frame's state."""
        return frame_state_size(self.model)

    def open(self) -> TwinFrameDrawer:
        """A renderer of this scene's frames, in the calling process.

        Raises:
            Exception: MuJoCo's own, when no offscreen OpenGL context can be made.
        """
        return TwinFrameDrawer(self)


class TwinFrameDrawer:
    """Draws the twin's camera frames from their states (module docstring).

    Args:
        source: The scene's model and the renderer's settings.

    Raises:
        Exception: MuJoCo's own, when no offscreen OpenGL context can be made.
    """

    def __init__(self, source: TwinFrameSource):
        self._data = mujoco.MjData(source.model)
        self._camera = source.camera
        self._renderer = offscreen_renderer(
            source.model,
            source.size_px,
            msaa_samples=source.msaa_samples,
            shadows=source.shadows,
        )

    def draw(self, state: np.ndarray, out: np.ndarray) -> None:
        """Draw the frame of ``state`` into ``out``, (h, w, 3) uint8 RGB."""
        unpack_frame_state(state, self._data)
        self._renderer.update_scene(self._data, camera=self._camera)
        self._renderer.render(out=out)

    def close(self) -> None:
        """Free the renderer's GL context (:func:`close_renderer`)."""
        close_renderer(self._renderer)
