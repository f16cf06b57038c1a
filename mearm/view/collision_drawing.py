"""The planner's collision model in the view: its shapes, translucent, under ``collision/``.

:class:`CollisionDrawing` draws a :class:`~mearm.kinematics.collision.CollisionModel`
into a meshcat scene: every shape that is in its world now — the arm's plates, servos,
hand and jaws, a held object, each bin's floor and walls, each object on the table —
posed by Pinocchio (``pin.updateGeometryPlacements``) for the arm's joints, as
:class:`~mearm.view.ArmView` draws them. The table, a half-space, is not drawn (the view's
own table marks it). Pinocchio's meshcat helpers (``loadPrimitive``) turn each coal shape
into meshcat geometry; only what changed is sent again.

Scene tree (below the view's ``/meshcat``)::

    collision/arm/<shape>      what moves with the arm (and the arm's mount on the table),
                               translucent magenta (:data:`COLLISION_ARM_RGB`)
    collision/world/<shape>    the bins' walls and floors and the objects, translucent
                               cyan (:data:`COLLISION_WORLD_RGB`)

Shape names are the model's (the twin's MJCF geoms: ``gripper_jaw_left_pad``,
``bin_red_wall_px``, ``obj_red1``, …; a ``/`` in a name becomes ``_``).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import coal
import meshcat
import meshcat.geometry as mg
import numpy as np
import pinocchio as pin

from mearm.kinematics.collision import CollisionModel
from mearm.view.pinocchio_meshcat import meshcat_visualizer

#: The arm's shapes (and a held object): translucent magenta.
COLLISION_ARM_RGB = 0xE0108C
#: The bins' and objects' shapes: translucent cyan.
COLLISION_WORLD_RGB = 0x00A0D8
#: The shapes' opacity [-]: the arm and the scene stay visible through them.
COLLISION_OPACITY = 0.35
#: The scene-tree folder the shapes are drawn under.
COLLISION_ROOT = "collision"

#: The coal shapes' sizes that tell one shape from another [m].
_SIZES = ("halfSide", "radius", "halfLength", "radii")


@dataclass(frozen=True)
class DrawnShape:
    """One shape of the model as drawn.

    Attributes:
        index: Its geometry object's index in ``collision.geometry``.
        group: ``arm`` (it moves with the arm, or is the arm's mount) or ``world``.
        key: Its kind and sizes: the shape is drawn again when they change.
    """

    index: int
    group: str
    key: tuple[Any, ...]


def shape_key(geometry: Any) -> tuple[Any, ...]:
    """A coal shape's kind and sizes [m], e.g. ``("Box", (0.01, 0.02, 0.005))``."""
    sizes = []
    for name in _SIZES:
        if hasattr(geometry, name):
            value = np.atleast_1d(np.asarray(getattr(geometry, name), dtype=float))
            sizes.append((name, tuple(np.round(value, 12).tolist())))
    return (type(geometry).__name__, tuple(sizes))


def shapes_in_world(collision: CollisionModel) -> dict[str, DrawnShape]:
    """The shapes of the model's world now, by their scene path (below ``/meshcat``).

    The arm's own shapes (``collision.arm_shapes``) are always there; any other geometry
    object (a held object, a bin, an object) is there while one of its collision pairs is
    active (a model may keep inactive places for objects). The table's half-space is not
    drawn.
    """
    g = collision.geometry
    arm_names = {s.name for s in collision.arm_shapes}
    active = list(collision.gdata.activeCollisionPairs)
    involved: set[int] = set()
    for pair, on in zip(g.collisionPairs, active, strict=True):
        if on:
            involved.update((int(pair.first), int(pair.second)))
    out: dict[str, DrawnShape] = {}
    for k, obj in enumerate(g.geometryObjects):
        if isinstance(obj.geometry, (coal.Halfspace, coal.Plane)):
            continue
        own = obj.name in arm_names
        if not own and k not in involved:
            continue
        group = "arm" if own or obj.parentJoint != 0 else "world"
        path = f"{COLLISION_ROOT}/{group}/{obj.name.replace('/', '_')}"
        out[path] = DrawnShape(k, group, shape_key(obj.geometry))
    return out


def meshcat_geometry(obj: pin.GeometryObject) -> mg.Geometry | None:
    """A coal primitive as meshcat geometry (Pinocchio's ``loadPrimitive``), or ``None``.

    Boxes, spheres, cylinders, cones and capsules are drawn; other shapes are not.
    """
    # imported here, and without what Pinocchio's other visualisers import
    load_primitive = meshcat_visualizer().loadPrimitive
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "unsupported geometry type"
        return load_primitive(obj)


def _material(rgb: int) -> mg.MeshLambertMaterial:
    return mg.MeshLambertMaterial(
        color=rgb, transparent=True, opacity=COLLISION_OPACITY, depthWrite=False
    )


class CollisionDrawing:
    """A collision model drawn in a meshcat scene, kept in step with the arm's joints.

    Args:
        viewer: The scene's ``/meshcat`` node (base frame, metres).
        collision: The model to draw.
        track_world: Whether the view puts its own objects and jaw opening into the
            model (:meth:`set_world`) before each drawing.

    Attributes:
        collision: The model drawn.
        track_world: As given.
        drawn: The shapes drawn now, by scene path.
    """

    def __init__(self, viewer: meshcat.Visualizer, collision: CollisionModel, *, track_world: bool):
        self.viewer = viewer
        self.collision = collision
        self.track_world = track_world
        self.drawn: dict[str, DrawnShape] = {}
        self._sent: dict[str, np.ndarray] = {}  # the last transform sent, by path
        self._geometry: Any = None
        self._data = collision.model.model.createData()
        self._gdata: Any = None
        self._set: tuple[Any, ...] | None = None  # the world last set (set_world)
        self._world: tuple[int, bytes] | None = None  # the model and active pairs of _wanted
        self._wanted: dict[str, DrawnShape] = {}
        self._undrawable: set[tuple[str, tuple[Any, ...]]] = set()
        self._materials = {
            "arm": _material(COLLISION_ARM_RGB),
            "world": _material(COLLISION_WORLD_RGB),
        }

    def set_world(self, objects: list[tuple[str, str, float, float]], opening_cm: float) -> None:
        """Put objects ``(id, class, x_cm, y_cm)`` on the table and open the jaws [cm].

        Nothing is held. Passed on to ``collision.set_world`` only when they changed.
        """
        world = (tuple(objects), float(opening_cm))
        if world != self._set:
            self.collision.set_world(objects, opening_cm=opening_cm, held=None)
            self._set = world

    def update(self, q: np.ndarray) -> None:
        """Draw the model's world at the chain's joints ``q`` (model units, (n,)).

        Shapes that left the world are deleted, new or resized ones drawn, and only the
        transforms that changed are sent.
        """
        cm = self.collision
        g = cm.geometry
        if g is not self._geometry:  # the model was built anew
            self._geometry = g
            self._gdata = pin.GeometryData(g)
        pin.updateGeometryPlacements(cm.model.model, self._data, g, self._gdata, q)
        world = (id(g), np.asarray(cm.gdata.activeCollisionPairs, dtype=bool).tobytes())
        if world != self._world:  # other shapes in the world (or none drawn yet)
            self._world, self._wanted = world, shapes_in_world(cm)
        wanted = self._wanted
        for path in [p for p in self.drawn if p not in wanted]:
            self.viewer[path].delete()
            del self.drawn[path]
            self._sent.pop(path, None)
        objects = g.geometryObjects
        for path, shape in wanted.items():
            node = self.viewer[path]
            old = self.drawn.get(path)
            if old is None or old.key != shape.key or old.group != shape.group:
                if (path, shape.key) in self._undrawable:
                    continue
                geometry = meshcat_geometry(objects[shape.index])
                if geometry is None:  # a shape meshcat has no primitive for
                    self._undrawable.add((path, shape.key))
                    continue
                node.set_object(geometry, self._materials[shape.group])
                self._sent.pop(path, None)
            self.drawn[path] = shape
            T = self._gdata.oMg[shape.index].homogeneous
            sent = self._sent.get(path)
            if sent is None or not np.array_equal(sent, T):
                node.set_transform(T)
                self._sent[path] = T.copy()

    def delete(self) -> None:
        """Remove every shape from the scene."""
        self.viewer[COLLISION_ROOT].delete()
        self.drawn.clear()
        self._sent.clear()


__all__ = [
    "COLLISION_ARM_RGB",
    "COLLISION_OPACITY",
    "COLLISION_ROOT",
    "COLLISION_WORLD_RGB",
    "CollisionDrawing",
    "DrawnShape",
    "meshcat_geometry",
    "shape_key",
    "shapes_in_world",
]
