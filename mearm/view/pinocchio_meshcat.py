"""Pinocchio's meshcat visualiser, imported without the viser visualiser's trimesh.

``pinocchio.visualize`` imports every visualiser it has when any one of them is imported.
Its viser visualiser imports trimesh (and, through it, SciPy and networkx) before it finds
out that viser is not installed, and then goes without: 0.8–1.0 s of CPU (measured here)
that the 3-D view paid at every start, for a visualiser it never uses. Where viser is not
installed, trimesh is held out of that import (a ``None`` in :data:`sys.modules`, which
makes ``import trimesh`` fail as a missing module does), so Pinocchio ends the same way,
without a viser visualiser, without the cost. Where viser is installed, or trimesh is
already imported, nothing is held out.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from types import ModuleType

#: Pinocchio's meshcat visualiser (``MeshcatVisualizer``, ``loadPrimitive``).
MESHCAT_VISUALIZER = "pinocchio.visualize.meshcat_visualizer"
#: What Pinocchio's viser visualiser imports before it looks for viser.
HELD_OUT = "trimesh"


def meshcat_visualizer() -> ModuleType:
    """``pinocchio.visualize.meshcat_visualizer``, imported without trimesh where viser is absent.

    ``trimesh`` is importable again afterwards, as before.
    """
    loaded = sys.modules.get(MESHCAT_VISUALIZER)
    if loaded is not None:
        return loaded
    hold = HELD_OUT not in sys.modules and importlib.util.find_spec("viser") is None
    if hold:
        sys.modules[HELD_OUT] = None  # type: ignore[assignment]
    try:
        return importlib.import_module(MESHCAT_VISUALIZER)
    finally:
        if hold and HELD_OUT in sys.modules and sys.modules[HELD_OUT] is None:
            del sys.modules[HELD_OUT]
