"""The twin's scene around the arm: table, bins, objects, belt, lights and camera.

What each is and why: :mod:`mearm.sim.twin.mjcf`'s docstring (**The scene**, **The
belt**).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from mearm.config import ColorClass, Config
from mearm.kinematics.bodies import (
    TableContents,
    bin_name,
    bin_origin_m,
    bin_shapes,
    object_centre_m,
    object_name,
)
from mearm.kinematics.mjspec import exact, yaw_quat
from mearm.sim.belt import Arrival, Belt, belt_arrivals
from mearm.sim.twin.twin_geoms import (
    _SCENE_CONAFFINITY,
    _SCENE_CONTYPE,
    BELT_FRICTION,
    M_PER_CM,
    OBJECT_FRICTION,
    OBJECT_ROLL_FRICTION,
    OBJECT_SPIN_FRICTION,
    PLA_DENSITY,
    TABLE_FRICTION,
    _rgba,
    _scene_geom,
)
from mearm.sim.twin.twin_optics import CAMERA_HEIGHT_M, camera_pose, homography_view
from mearm.sim.twin.twin_scene_check import _bin_half_outer_m, object_ids, parked_m

#: The table plane's drawn grid spacing, and the margin it is drawn beyond everything on
#: it [m].
TABLE_GRID_M = 0.05
TABLE_MARGIN_M = 0.05


def _object_geom(
    model: mujoco.MjSpec,
    body: mujoco.MjsBody,
    name: str,
    c: ColorClass,
    material: str | None = None,
) -> None:
    """A scene object of class ``c``: solid PLA of its class's shape, size and colour.

    A cylinder, a box (a cube's footprint, its class's height) or a triangular prism (a
    convex mesh, a corner towards the body's +y), standing on its base; its yaw is its
    body's. ``material``: the model's material it is drawn with (the glossy one of its
    class under a lamp), or none.
    """
    size_m, h = c.diameter_cm * M_PER_CM, c.height_cm * M_PER_CM
    footprint = c.object_shape.footprint
    mass = PLA_DENSITY * c.object_shape.area_cm2(c.diameter_cm) * M_PER_CM**2 * h
    attrs: dict[str, object] = {
        "mass": mass,
        # against the table (condim 6, :func:`_table`) sliding and rolling friction, no
        # torsional (it kept one object rocking on the table plane): a contact takes the
        # larger of its two geoms' condim and of each friction; against the bins and other
        # objects sliding friction only; against the pads the pads' (priority) condim 4
        # holds, so a held object does not spin
        "friction": [OBJECT_FRICTION, 0.0, OBJECT_ROLL_FRICTION],
        "condim": 3,
        "rgba": _rgba(c.draw_rgb),
    }
    if material is not None:
        attrs["material"] = material
    if footprint == "disc":
        _scene_geom(body, name, "cylinder", (size_m / 2, h / 2), **attrs)
    elif footprint == "square":
        _scene_geom(body, name, "box", (size_m / 2, size_m / 2, h / 2), **attrs)
    else:
        mesh = f"{name}_prism"
        corners = [
            (size_m / math.sqrt(3) * math.cos(a), size_m / math.sqrt(3) * math.sin(a))
            for a in (math.pi / 2, math.pi / 2 + 2 * math.pi / 3, math.pi / 2 + 4 * math.pi / 3)
        ]
        verts = [v for x, y in corners for z in (-h / 2, h / 2) for v in (x, y, z)]
        model.add_mesh(name=mesh, uservert=verts)
        body.add_geom(
            name=name,
            type=mujoco.mjtGeom.mjGEOM_MESH,
            meshname=mesh,
            contype=_SCENE_CONTYPE,
            conaffinity=_SCENE_CONAFFINITY,
            **attrs,
        )


def _objects(model: mujoco.MjSpec, config: Config) -> list[Arrival]:
    """The scene's objects on the table and the belt's waiting off it: free bodies ``obj_<id>``.

    Returns the belt's arrivals, in the order their bodies were added.
    """
    world, task = model.worldbody, config.task
    for oid, obj in zip(object_ids(config), task.scene, strict=True):
        c = task.class_named(obj.color)
        centre = object_centre_m(c, obj.x, obj.y)
        yaw = math.radians(obj.yaw_deg)
        body = world.add_body(
            name=object_name(oid),
            pos=exact(centre),
            quat=exact(yaw_quat(yaw)),
        )
        body.add_freejoint(name=object_name(oid))
        gloss = None if config.twin.lamp is None else f"object_{c.name}"  # under a lamp
        _object_geom(model, body, object_name(oid), c, material=gloss)
    arrivals = belt_arrivals(config)
    for i, arrival in enumerate(arrivals):
        name = object_name(arrival.id)
        body = world.add_body(name=name, pos=exact(parked_m(config, i, arrival)))
        body.add_freejoint(name=name)
        gloss = None if config.twin.lamp is None else f"object_{arrival.color}"
        _object_geom(model, body, name, task.class_named(arrival.color), material=gloss)
    return arrivals


def _belt(world: mujoco.MjsBody, config: Config) -> None:
    """The belt: a box on the table whose top moves along its length (``surfacevel``)."""
    assert config.belt is not None
    b = config.belt
    belt = Belt(b)
    cx, cy = belt.centre_cm
    yaw = math.radians(b.heading_deg)
    _scene_geom(
        world,
        "belt",
        "box",
        (b.length_cm / 2 * M_PER_CM, b.width_cm / 2 * M_PER_CM, b.surface_cm / 2 * M_PER_CM),
        pos=exact([cx * M_PER_CM, cy * M_PER_CM, b.surface_cm / 2 * M_PER_CM]),
        quat=exact(yaw_quat(yaw)),
        material="belt",
        friction=[BELT_FRICTION, OBJECT_SPIN_FRICTION, OBJECT_ROLL_FRICTION],
        surfacevel=[b.speed_cm_s * M_PER_CM, 0.0, 0.0, 0.0, 0.0, 0.0],
    )


def _field_corners_m(config: Config) -> np.ndarray:
    """The calibrated field's corners and centre on the table, (5, 2) [m]."""
    H = np.asarray(config.calibration.homography, dtype=float)
    w, h = config.camera.width_px, config.camera.height_px
    px = np.array([[0, 0, 1], [w, 0, 1], [w, h, 1], [0, h, 1], [w / 2, h / 2, 1]], dtype=float)
    xyw = px @ H.T
    return xyw[:, :2] / xyw[:, 2:] * M_PER_CM


def _table(world: mujoco.MjsBody, config: Config) -> None:
    pts = [np.zeros(2), *_field_corners_m(config)]
    for c in config.task.classes:
        h = _bin_half_outer_m(config, c.name)
        centre = np.array(c.bin_cm[:2]) * M_PER_CM
        pts += [centre - h, centre + h]
    for obj in config.task.scene:
        pts.append(np.array([obj.x, obj.y]) * M_PER_CM)
    lo = np.min(pts, axis=0) - TABLE_MARGIN_M
    hi = np.max(pts, axis=0) + TABLE_MARGIN_M
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    # a plane: drawn over everything on the table and a margin, it collides everywhere
    # (an object pushed past the drawn edge slides on out of view instead of falling);
    # cylinder-plane contacts are analytic, and cost a third less per step than
    # cylinder-box ones. Rolling friction (condim 6): without it a cylinder a jaw knocked
    # onto its side rolled on at 5 cm/s for 2.5 m (5-DOF perspective twin, seed 998044).
    # OBJECT_ROLL_FRICTION, 0.1 mm, is the rolling resistance's lever arm: handbooks give
    # 0.5 mm for steel on steel and 1-2 mm for wood or plastic on steel, for loaded
    # wheels; a print of a few grams dents a table far less, so the low end. A 1 cm-radius
    # cylinder rolling at 5 cm/s stops within 2 cm (at 20 cm/s, 30 cm). Torsional friction
    # stays off (0 here and on the objects).
    _scene_geom(
        world,
        "table",
        "plane",
        (half[0], half[1], TABLE_GRID_M),
        pos=[centre[0], centre[1], 0.0],
        material="table",
        friction=[TABLE_FRICTION, 0.0, OBJECT_ROLL_FRICTION],
        condim=6,
    )


def _lights(model: mujoco.MjSpec, config: Config) -> None:
    """The twin's light: an even light straight down, or ``twin.lamp``.

    Without a lamp: a directional light ``top`` straight down and MuJoCo's headlight (a
    light on the camera). With one (:class:`~mearm.config.twin_lamp_config.TwinLampConfig`):
    the light ``lamp`` where it stands, pointed at its target, casting shadows if it says
    so; the headlight gives only the room's ``ambient`` light; each class's objects get a
    material ``object_<class>`` of the lamp's ``object_specular`` and ``object_shininess``.
    """
    lamp = config.twin.lamp
    world = model.worldbody
    if lamp is None:
        world.add_light(name="top", pos=[0.0, 0.0, 1.5], dir=[0.0, 0.0, -1.0],
                        type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)  # fmt: skip
        return
    pos = np.array(lamp.position_cm) * M_PER_CM
    if lamp.target_cm is not None:
        target = np.array([*lamp.target_cm, 0.0]) * M_PER_CM
    else:
        target = np.array([*homography_view(config)[0], 0.0])
    direction = target - pos  # never zero: the lamp stands ≥ 1 cm above the table
    distance = float(np.linalg.norm(direction))
    kind = {"spot": mujoco.mjtLightType.mjLIGHT_SPOT,
            "directional": mujoco.mjtLightType.mjLIGHT_DIRECTIONAL}[lamp.kind]  # fmt: skip
    light = world.add_light(name="lamp", pos=exact(pos), dir=exact(direction / distance),
                            type=kind, castshadow=lamp.shadows)  # fmt: skip
    light.diffuse = [lamp.diffuse] * 3
    light.specular = [lamp.specular] * 3
    light.ambient = [0.0] * 3
    light.cutoff = lamp.cutoff_deg
    light.exponent = lamp.exponent
    model.visual.quality.shadowsize = lamp.shadow_map_px
    headlight = model.visual.headlight
    headlight.ambient = [lamp.ambient] * 3
    headlight.diffuse = [0.0] * 3
    headlight.specular = [0.0] * 3
    for c in config.task.classes:
        model.add_material(
            name=f"object_{c.name}",
            rgba=_rgba(c.draw_rgb),
            specular=lamp.object_specular,
            shininess=lamp.object_shininess,
        )


def _camera(world: mujoco.MjsBody, config: Config) -> None:
    """The camera ``camera``: :func:`~mearm.sim.twin.twin_optics.camera_pose` of the config.

    Unconfigured (``twin.camera`` null) it looks straight down over the calibrated field's
    centre and sees that field; configured, it stands, tilts and sees as
    ``twin.camera`` says (its lens distortion is applied to the rendered frames by
    :class:`~mearm.sim.twin.twin_camera.TwinCamera`).
    """
    if config.twin.camera is None:
        centre, yaw, extent = homography_view(config)
        fovy = 2 * math.degrees(math.atan(extent / 2 / CAMERA_HEIGHT_M))
        world.add_camera(
            name="camera",
            pos=[centre[0], centre[1], CAMERA_HEIGHT_M],
            quat=yaw_quat(yaw),
            fovy=fovy,
        )
        return
    pose = camera_pose(config)
    # MuJoCo's camera: x right and y up in the image, looking along its -z
    camera = world.add_camera(name="camera", pos=pose.centre_m, fovy=pose.fovy_deg)
    camera.alt.type = mujoco.mjtOrientation.mjORIENTATION_XYAXES
    camera.alt.xyaxes = exact([*pose.R_base_mj[:, 0], *pose.R_base_mj[:, 1]])


def _bin(world: mujoco.MjsBody, config: Config, color: str) -> None:
    """A bin on the table under ``bin_cm``: a floor and four walls."""
    table = TableContents.of(config.task, config.belt)
    c = table.class_named(color)
    body = world.add_body(name=bin_name(color), pos=exact(bin_origin_m(c)))
    for shape in bin_shapes(c, table.objects(color)):
        _scene_geom(body, shape.name, "box", shape.size, pos=exact(shape.pos), material="bin")
