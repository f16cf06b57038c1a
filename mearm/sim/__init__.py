"""The simulators: everything that stands in for the real rig behind the same interfaces.

One subpackage or module per kind, each opened by :mod:`mearm.backends`:

- :mod:`mearm.sim.kinematic`: the kinematic simulator (``simulator: kinematic``): a
  :class:`World` of objects and bins, its picture (:class:`TableRenderer`,
  :class:`SimCamera`) and the servo bus over it (:class:`SimArm`), re-exported here;
- :mod:`mearm.sim.twin`: the physical twin in MuJoCo (``simulator: mujoco``);
- :mod:`mearm.sim.virtual_uno`: the project's firmware in simavr driving the kinematic
  arm (``servo.backend: virtual_uno``).

The simulator sits above vision and hardware: it may import them, they never import it
(:mod:`mearm.backends`, above all three, opens the simulated kinds).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mearm._lazy import lazy_exports

if TYPE_CHECKING:  # the names' types, for the type checker; at run time each is lazy
    from mearm.sim.kinematic.renderer import (
        Disc,
        Extra,
        Highlight,
        Paper,
        Shadow,
        TableRenderer,
        class_bgr,
        class_discs,
    )
    from mearm.sim.kinematic.servo_bus import GripResult, ReleaseResult, SimArm, quantize_deg
    from mearm.sim.kinematic.table_camera import SimCamera
    from mearm.sim.kinematic.world import World, WorldObject

# ------------------------------------------------------------ the kinematic simulator
# Imported on first access, so that a module of another simulator (the twin's frame
# drawer, which the recorder's encoder process imports) loads without the kinematic
# renderer, the config and the kinematics.
_RENDERER = "mearm.sim.kinematic.renderer"
_KINEMATIC: dict[str, str] = {
    **dict.fromkeys(
        (
            "Disc",
            "Extra",
            "Highlight",
            "Paper",
            "Shadow",
            "TableRenderer",
            "class_bgr",
            "class_discs",
        ),
        _RENDERER,
    ),
    "SimCamera": "mearm.sim.kinematic.table_camera",
    "World": "mearm.sim.kinematic.world",
    "WorldObject": "mearm.sim.kinematic.world",
}

# ---------------------------------------------------------------- simulated servo bus
# ``mearm.sim.kinematic.servo_bus`` (SimArm and its records) is imported on first access, so this
# package imports without it and without loading the hardware layer.
_SERVO_BUS = "mearm.sim.kinematic.servo_bus"
_LAZY: dict[str, str] = {
    **_KINEMATIC,
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
