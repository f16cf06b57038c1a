"""The simulator: everything that stands in for the real rig behind the same interfaces.

- :class:`World`: the table's objects and the bins, shared by the parts below;
- :class:`TableRenderer`: the camera's picture of the table, and :class:`SimCamera`, a
  :class:`~mearm.vision.camera.Camera` that renders the world at every read;
- :class:`SimArm`: the servo bus over the world (``mearm.sim.servo_bus``).

The simulator sits above vision and hardware: it may import them, they never import it
(:mod:`mearm.backends`, above all three, opens the simulated kinds).
"""

from __future__ import annotations

from mearm._lazy import lazy_exports
from mearm.sim.renderer import (
    Disc,
    Extra,
    Highlight,
    Paper,
    Shadow,
    TableRenderer,
    class_bgr,
    class_discs,
)
from mearm.sim.table_camera import SimCamera
from mearm.sim.world import World, WorldObject

# ---------------------------------------------------------------- simulated servo bus
# ``mearm.sim.servo_bus`` (SimArm and its records) is imported on first access, so this
# package imports without it and without loading the hardware layer.
_SERVO_BUS = "mearm.sim.servo_bus"
_LAZY: dict[str, str] = {
    "GripResult": _SERVO_BUS,
    "ReleaseResult": _SERVO_BUS,
    "SimArm": _SERVO_BUS,
    "quantize_deg": _SERVO_BUS,
}
# ----------------------------------------------------------------------------------

__all__ = [
    "Disc",
    "Extra",
    "GripResult",
    "Highlight",
    "Paper",
    "ReleaseResult",
    "Shadow",
    "SimArm",
    "SimCamera",
    "TableRenderer",
    "World",
    "WorldObject",
    "class_bgr",
    "class_discs",
    "quantize_deg",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals(), __all__)
