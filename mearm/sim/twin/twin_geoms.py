"""What the twin's parts are made of: materials, friction, contact classes, primitive geoms.

Densities and friction coefficients are estimates from typical datasheets; the arm's
geoms touch the scene but never each other (their contact type and affinity).
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco

from mearm.kinematics.bodies import Shape
from mearm.kinematics.chain import M_PER_CM as M_PER_CM  # re-exported: the twin's unit
from mearm.kinematics.mjspec import exact, quat

G = 9.81  # m/s²

#: Cast/extruded PMMA (acrylic) sheet: 1.19 g/cm³ (typical sheet datasheets) [kg/m³].
ACRYLIC_DENSITY = 1190.0
#: PLA filament: 1.24 g/cm³ (typical filament datasheets); objects printed solid [kg/m³].
PLA_DENSITY = 1240.0
#: Coulomb friction [-] (estimates: PLA on wood or acrylic 0.3–0.5; rubber jaw pads ~1).
OBJECT_FRICTION = 0.4
TABLE_FRICTION = 0.4
#: A rubber belt's grip on PLA [-] (rubber on plastics: 0.5–0.8).
BELT_FRICTION = 0.6
JAW_FRICTION = 1.0
#: Torsional and rolling friction of the objects [m] (small: they stand flat).
OBJECT_SPIN_FRICTION = 0.005
OBJECT_ROLL_FRICTION = 0.0001

_ARM_CONTYPE, _ARM_CONAFFINITY = 2, 1  # arm geoms: touch the scene, never each other
_SCENE_CONTYPE, _SCENE_CONAFFINITY = 1, 3


def _rgba(rgb: Sequence[int] | tuple[float, float, float], alpha: float = 1.0) -> list[float]:
    return [*(float(c) / 255 for c in rgb), alpha]


_GEOM_KIND = {
    "box": mujoco.mjtGeom.mjGEOM_BOX,
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
    "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
    "plane": mujoco.mjtGeom.mjGEOM_PLANE,
}


def _geom(
    body: mujoco.MjsBody, name: str, kind: str, size: Sequence[float], **attrs: object
) -> mujoco.MjsGeom:
    geom = body.add_geom(name=name, type=_GEOM_KIND[kind], **attrs)
    geom.size[: len(size)] = size
    return geom


def _scene_geom(
    body: mujoco.MjsBody, name: str, kind: str, size: Sequence[float], **attrs: object
) -> None:
    _geom(body, name, kind, size, contype=_SCENE_CONTYPE, conaffinity=_SCENE_CONAFFINITY, **attrs)


def _shape_geom(body: mujoco.MjsBody, shape: Shape, material: str, **attrs: object) -> None:
    """A geom of :mod:`mearm.kinematics.bodies`' ``shape`` in ``body``."""
    place: dict[str, object] = {"pos": exact(shape.pos)}
    if shape.R is not None:
        place["quat"] = quat(shape.R)
    if shape.mass_kg is not None:
        place["mass"] = shape.mass_kg
    collide = (_ARM_CONTYPE, _ARM_CONAFFINITY) if shape.collides else (0, 0)
    _geom(body, shape.name, shape.kind, shape.size, material=material, contype=collide[0],
          conaffinity=collide[1], **place, **attrs)  # fmt: skip
