"""The twin's camera frame as state: drawn in another process, pixel for pixel the same.

A recording's frame costs the sort's process 6.5–8 ms of CPU to draw (MuJoCo's software
renderer) and a few microseconds to describe: what ``mjv_updateScene`` reads of the
physics' data, the poses of the bodies, geoms, sites, camera and light and the tendons'
paths (:data:`FRAME_FIELDS`, about 10 kB for the 12-object scene). The recorder's encoder
process builds its own renderer from a copy of the model once a scene
(:class:`~mearm.sim.twin.frame_drawer.TwinFrameSource`, pickled: the model travels as
MuJoCo's binary model) and draws each frame from its state
(:meth:`~mearm.sim.twin.frame_drawer.TwinFrameDrawer.draw`; that module imports only NumPy
and MuJoCo, for the encoder's process to start fast).

The poses are sent, not ``qpos``: the twin samples after ``mj_step``, whose poses are
those of the step's start; ``mj_kinematics`` of the new ``qpos`` differs from what the
sort's renderer draws by the last step's motion (82 pixels of a moving arm's edge in a
640×480 frame, measured). Copied poses give the same pixels.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mearm.sim.twin.frame_drawer import (  # noqa: F401  (re-exported: the frame's state)
    FRAME_FIELDS,
    TwinFrameDrawer,
    TwinFrameSource,
    frame_state_size,
    unpack_frame_state,
)


def pack_frame_state(data: mujoco.MjData, out: np.ndarray) -> None:
    """Write ``data``'s frame state into ``out`` (float64, at least the state's size).

    The integer fields (tendon path addresses) are small: float64 holds them exactly.
    """
    at = 0
    for name in FRAME_FIELDS:
        values = getattr(data, name)
        out[at : at + values.size] = values.reshape(-1)
        at += values.size
