"""The arm's body and the table's, as primitive shapes: one description for physics and plans.

Both the physical twin's MJCF (:mod:`mearm.sim.twin.mjcf`) and the collision model the planner
checks every route against (:mod:`mearm.kinematics.collision`) are built from the shapes
here, so what the plan avoids is what the physics would touch. Nothing here imports
MuJoCo or Pinocchio: a shape is a box or a cylinder (half-sizes, MuJoCo's convention, in
metres), fixed in one *body* of the MJCF's tree at a pose in that body's frame.

The bodies, by name:

- ``base_link``: the world frame at the arm's base (the table's top is z = 0);
- ``link_<joint>``: the frame of DH joint ``<joint>``, turning (or sliding) with it,
  exactly as the URDF's joint frame (:mod:`mearm.kinematics.urdf`);
- ``tcp``: the tool centre point, fixed in the last joint's frame;
- ``link_<jaw>``: each of the gripper's two jaws, sliding from the TCP across the approach
  axis by half the opening (:attr:`Shape.jaw` gives the direction's sign);
- ``bin_<class>`` and ``obj_<id>``: a class's bin and a scene object, in the world frame.

What the shapes are (the MJCF's module docstring says why): every DH segment a plate
:data:`LINK_THICKNESS_M` thick and :func:`link_width_m` wide; each actuated joint's servo
a box of its datasheet size at the joint, in the body before it; the gripper's servo (and
each tool actuator's) behind the TCP and the jaws' roots; a mount plate bridging the TCP
to the jaws' roots when they start beyond it; each jaw a finger ending in a pad centred on
the grip point; a bin a floor and four walls; an object a cylinder standing on the table.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from mearm.config import ArmDescription, BeltConfig, ClawMarker, ColorClass, Joint, TaskConfig
from mearm.config.arm import base_radius_m, link_width_m
from mearm.config.belt_config import belt_classes
from mearm.config.classes import class_named
from mearm.config.servo_models import ServoSpec
from mearm.kinematics.chain import M_PER_CM
from mearm.kinematics.urdf import jaw_frame, jaw_joint_names, jaw_pad_length_m

#: Laser-cut link plates: 3 mm acrylic, as the MeArm kits are cut from [m].
LINK_THICKNESS_M = 0.003
#: Bin walls' and floor's thickness [m]; walls' height in object heights, and at least.
BIN_WALL_M = 0.003
BIN_WALL_HEIGHT_PER_HEIGHT = 2.0
BIN_MIN_WALL_HEIGHT_M = 0.02

#: What a shape is part of: the planner treats each kind its own way (a jaw's pads may
#: touch the object they close on; a plate of the last row runs between the jaws and is
#: drawn only).
Part = Literal["base", "link", "servo", "mount", "pad", "finger", "bin", "object", "marker"]


@dataclass(frozen=True)
class Shape:
    """One primitive, fixed in one body.

    Attributes:
        name: The MJCF geom's name (unique in a scene).
        body: The body it is fixed in (see the module docstring).
        kind: ``box`` or ``cylinder`` (a cylinder's axis is its frame's z).
        size: MuJoCo's half-sizes [m]: (x, y, z) for a box, (radius, half-height) for a
            cylinder.
        pos: Its centre in the body's frame [m], (3,).
        R: Its frame's axes in the body's frame, (3, 3); ``None`` for the body's own.
        part: What it is part of (:data:`Part`).
        collides: Whether anything touches it (the base plate and the last row's plates,
            which run between the jaws, are drawn only).
        mass_kg: Its mass, for the physics; ``None`` where the MJCF gives a density-free
            default (bins) or its own formula (objects).
        jaw: ``+1`` or ``-1`` for a shape on a jaw (the sign of the jaw's slide along the
            opening axis), else 0.
    """

    name: str
    body: str
    kind: Literal["box", "cylinder"]
    size: tuple[float, ...]
    pos: np.ndarray
    R: np.ndarray | None = None
    part: Part = "link"
    collides: bool = True
    mass_kg: float | None = None
    jaw: int = 0

    @property
    def radius_m(self) -> float:
        """Radius of a sphere about :attr:`pos` that holds the shape [m]."""
        if self.kind == "box":
            return float(np.linalg.norm(self.size))
        return float(math.hypot(self.size[0], self.size[1]))

    @property
    def pose(self) -> np.ndarray:
        """Its pose in the body's frame, (4, 4) [m]."""
        T = np.eye(4)
        if self.R is not None:
            T[:3, :3] = self.R
        T[:3, 3] = self.pos
        return T


@dataclass(frozen=True)
class ArmBodies:
    """The arm's shapes, and the frames the tool's hang from.

    Attributes:
        shapes: Every shape of the arm, base to jaws.
        tcp_in_last: The TCP's pose in the last joint's frame, (4, 4) [m].
        across: The jaws' opening axis in the TCP frame, unit, (3,).
        approach: The tool's approach axis in the TCP frame, unit, (3,).
        grip_m: The grip point's distance from the TCP along :attr:`approach` [m].
    """

    shapes: tuple[Shape, ...]
    tcp_in_last: np.ndarray
    across: np.ndarray
    approach: np.ndarray
    grip_m: float
    jaw_joints: tuple[str, str] = field(default=("", ""))
    marker_in_tcp: np.ndarray | None = None
    """The claw marker's frame in the TCP frame, (4, 4) [m], as OpenCV's marker frame: x
    right, y towards the top edge, z out of its face; ``None``: the tool carries none."""


# --------------------------------------------------------------------------- names

#: What the table's body and geom names start with: a class's bin, a scene object.
BIN_PREFIX = "bin_"
OBJECT_PREFIX = "obj_"


def bin_name(class_name: str, part: str | None = None) -> str:
    """A class's bin body ``bin_<class>``, or its geom ``bin_<class>_<part>`` (``wall_px``)."""
    return f"{BIN_PREFIX}{class_name}" if part is None else f"{BIN_PREFIX}{class_name}_{part}"


def class_of(name: str) -> str | None:
    """The class whose bin a body or geom is part of (:func:`bin_name` read back), else ``None``."""
    if not name.startswith(BIN_PREFIX):
        return None
    return name[len(BIN_PREFIX) :].split("_wall_")[0].removesuffix("_floor")


def object_name(object_id: str) -> str:
    """A scene object's body, joint and geom name: ``obj_<id>``."""
    return f"{OBJECT_PREFIX}{object_id}"


def object_of(name: str) -> str | None:
    """The object a body or geom name is (:func:`object_name` read back), else ``None``."""
    return name[len(OBJECT_PREFIX) :] if name.startswith(OBJECT_PREFIX) else None


# --------------------------------------------------------------------------- helpers


def fixed_part(joint: Joint) -> np.ndarray:
    """The fixed part of a DH row, (4, 4), translation in metres."""
    T = joint.dh.transform(0.0, joint.type)
    T[:3, 3] *= M_PER_CM
    return T


def plate_mass_kg(length_m: float, width_m: float, density: float) -> float:
    """A plate's mass [kg]."""
    return density * length_m * width_m * LINK_THICKNESS_M


def frame_about(a: np.ndarray) -> np.ndarray:
    """A rotation whose z axis is the unit vector ``a``: columns (x, y, a), right-handed."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, a)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(a, x), a])


def _rz(t: float) -> np.ndarray:
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _servo(name: str, body: str, spec: ServoSpec, pos: np.ndarray, R: np.ndarray) -> Shape:
    length, wide, high = spec.size_m
    return Shape(
        name, body, "box", (length / 2, wide / 2, high / 2), np.asarray(pos, float), R,
        part="servo", mass_kg=spec.mass_kg,
    )  # fmt: skip


# --------------------------------------------------------------------------- the arm


def arm_bodies(
    arm: ArmDescription, servo: ServoSpec, gripper_servo: ServoSpec, *, acrylic_kg_m3: float
) -> ArmBodies:
    """The arm's shapes: base plate, each DH row's plates, servos, and the tool.

    Args:
        arm: The arm and its tool.
        servo: The joints' servo (its box sits at each actuated joint but the first).
        gripper_servo: The gripper's servo (and each tool actuator's).
        acrylic_kg_m3: The plates' density, for their masses.
    """
    width = link_width_m(arm)
    shapes: list[Shape] = [
        Shape(
            "base_plate", "base_link", "cylinder", (base_radius_m(arm), width / 2),
            np.array([0.0, 0.0, width / 2]), part="base", collides=False,
        )
    ]  # fmt: skip
    actuated = {j.name for j in arm.actuated_joints()}
    parent, T_prev = "base_link", np.eye(4)
    last = len(arm.joints) - 1
    for i, joint in enumerate(arm.joints):
        if joint.name in actuated and i > 0:
            shapes.append(
                _servo(f"{joint.name}_servo", parent, servo, T_prev[:3, 3], T_prev[:3, :3])
            )
        shapes += _plates(joint, width, collides=i != last, acrylic_kg_m3=acrylic_kg_m3)
        parent, T_prev = f"link_{joint.name}", fixed_part(joint)
    tcp = np.eye(4)
    tcp[:3, :3] = T_prev[:3, :3]
    tcp[:3, 3] = T_prev[:3, 3] + T_prev[:3, :3] @ (np.asarray(arm.tool.tcp_cm) * M_PER_CM)
    R = jaw_frame(arm)
    approach, across, third = R[:, 0], R[:, 1], R[:, 2]
    grip = arm.tool.tcp_above_grip_cm * M_PER_CM
    shapes += _tool(arm, width, gripper_servo, approach, across, third, grip, acrylic_kg_m3)
    marker = marker_in_tcp(arm, gripper_servo)
    if marker is not None and arm.tool.marker is not None:
        shapes.append(_marker_plate(arm.tool.marker, marker, acrylic_kg_m3))
    left, right = jaw_joint_names(arm)
    return ArmBodies(tuple(shapes), tcp, across, approach, grip, (left, right), marker)


#: The claw marker's plate: 2 mm acrylic [m].
MARKER_PLATE_M = 0.002


def marker_in_tcp(arm: ArmDescription, gripper_servo: ServoSpec) -> np.ndarray | None:
    """The claw marker's face in the TCP frame (:attr:`ArmBodies.marker_in_tcp`), (4, 4) [m].

    It looks along ``tool.marker.faces`` (default −approach), its top edge along the jaws'
    third axis, or the approach axis where it looks along the third. Its default centre is
    on a plate resting on the servo stack behind the TCP (the gripper's servo and one per
    tool actuator, as :func:`_tool` stacks them), on the side it looks to.
    """
    tool = arm.tool
    m = tool.marker
    if m is None:
        return None
    J = jaw_frame(arm)
    approach, third = J[:, 0], J[:, 2]
    z = -approach if m.faces is None else np.asarray(m.faces, dtype=float)
    z = z / np.linalg.norm(z)
    up = third if abs(float(third @ z)) < 0.9 else approach
    y = up - (up @ z) * z
    y /= np.linalg.norm(y)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([np.cross(y, z), y, z])
    if m.centre_cm is not None:
        T[:3, 3] = np.asarray(m.centre_cm, dtype=float) * M_PER_CM
        return T
    g = tool.gripper
    root = tool.tcp_above_grip_cm * M_PER_CM + jaw_pad_length_m(g) / 2 - g.jaw_length_cm * M_PER_CM
    n = len(tool.actuators) + 1
    size = np.asarray(gripper_servo.size_m, dtype=float)
    # the stack's centre, and how far its boxes reach along the face's normal
    centre = approach * (min(0.0, root) - size[2] * n / 2)
    R = J[:, [1, 2, 0]]  # a servo case's axes: across, third, approach
    reach = float(np.abs(R.T @ z) @ (size / 2 * np.array([1.0, 1.0, n])))
    T[:3, 3] = centre + z * (reach + MARKER_PLATE_M)
    return T


def _marker_plate(m: ClawMarker, marker_in_tcp: np.ndarray, acrylic_kg_m3: float) -> Shape:
    """The plate the claw marker is printed on: its face is the marker's, its body the TCP's."""
    half = (m.size_cm / 2 + m.border_cm) * M_PER_CM
    z = marker_in_tcp[:3, 2]
    return Shape(
        "claw_marker_plate", "tcp", "box", (half, half, MARKER_PLATE_M / 2),
        marker_in_tcp[:3, 3] - z * MARKER_PLATE_M / 2, marker_in_tcp[:3, :3], part="marker",
        mass_kg=acrylic_kg_m3 * (2 * half) ** 2 * MARKER_PLATE_M,
    )  # fmt: skip


def _plates(joint: Joint, width: float, *, collides: bool, acrylic_kg_m3: float) -> list[Shape]:
    """Row i's plates, in joint i's moving frame: Tz(d) then Rz(θ0)·Tx(a)."""
    a, dd = joint.dh.a_cm * M_PER_CM, joint.dh.d_cm * M_PER_CM
    t0 = math.radians(joint.dh.theta_deg)
    body = f"link_{joint.name}"
    out = []
    if abs(dd) > 1e-9:
        out.append(
            Shape(
                f"{joint.name}_d", body, "box", (width / 2, LINK_THICKNESS_M / 2, abs(dd) / 2),
                np.array([0.0, 0.0, dd / 2]), collides=collides,
                mass_kg=plate_mass_kg(abs(dd), width, acrylic_kg_m3),
            )
        )  # fmt: skip
    if abs(a) > 1e-9:
        out.append(
            Shape(
                f"{joint.name}_a", body, "box", (abs(a) / 2, width / 2, LINK_THICKNESS_M / 2),
                np.array([a / 2 * math.cos(t0), a / 2 * math.sin(t0), dd]), _rz(t0),
                collides=collides, mass_kg=plate_mass_kg(abs(a), width, acrylic_kg_m3),
            )
        )  # fmt: skip
    return out


def _tool(
    arm: ArmDescription,
    width: float,
    gripper_servo: ServoSpec,
    approach: np.ndarray,
    across: np.ndarray,
    third: np.ndarray,
    grip: float,
    acrylic_kg_m3: float,
) -> list[Shape]:
    """The gripper's servo(s) behind the TCP, the mount, and the two jaws.

    Along the approach axis (distances from the TCP): the pad spans ``grip ± pad/2``, the
    finger ``[tip − jaw_length, grip − pad/2]``, the mount ``[0, tip − jaw_length]`` when
    the jaws start beyond the TCP.
    """
    g = arm.tool.gripper
    length, thick = g.jaw_length_cm * M_PER_CM, g.jaw_thickness_cm * M_PER_CM
    pad = jaw_pad_length_m(g)
    tip = grip + pad / 2
    root = tip - length
    # the case: long side along the opening axis, shaft along the approach axis
    R = np.column_stack([across, third, approach])
    behind = approach * (min(0.0, root) - gripper_servo.size_m[2] / 2)
    out = [_servo(f"{g.name}_servo", "tcp", gripper_servo, behind, R)]
    for k, act in enumerate(arm.tool.actuators):
        offset = behind - approach * gripper_servo.size_m[2] * (k + 1)
        out.append(_servo(f"{act.name}_servo", "tcp", gripper_servo, offset, R))
    if root > 1e-9:
        out.append(
            Shape(
                f"{g.name}_mount", "tcp", "box", (root / 2, width / 2, LINK_THICKNESS_M / 2),
                approach * root / 2, np.column_stack([approach, third, -across]), part="mount",
                mass_kg=plate_mass_kg(root, width, acrylic_kg_m3),
            )
        )  # fmt: skip
    R_jaw = np.column_stack([approach, across, third])
    for name, sign in zip(jaw_joint_names(arm), (1, -1), strict=True):
        inner = across * sign * thick / 2  # the inner face on the joint's position
        pieces: list[tuple[Part, float, float]] = [("pad", grip, pad)]
        if length - pad > 1e-9:
            pieces.append(("finger", (root + grip - pad / 2) / 2, length - pad))
        for part, centre, span in pieces:
            out.append(
                Shape(
                    f"{name}_{part}", f"link_{name}", "box", (span / 2, thick / 2, width / 2),
                    approach * centre + inner, R_jaw, part=part,
                    mass_kg=acrylic_kg_m3 * span * thick * width, jaw=sign,
                )
            )  # fmt: skip
    return out


# --------------------------------------------------------------------------- the table


@dataclass(frozen=True)
class TableContents:
    """What stands on the table: the classes, each with its bin, and how many objects.

    Attributes:
        classes: The task's classes, in sort order.
        scene: Objects of each class the scene lays out, by class name.
        belt: Objects of each class the belt brings, by class name.
    """

    classes: tuple[ColorClass, ...]
    scene: Mapping[str, int]
    belt: Mapping[str, int] = field(default_factory=dict)

    @classmethod
    def of(cls, task: TaskConfig, belt: BeltConfig | None = None) -> TableContents:
        """The classes and objects of a task's scene, and those its belt brings."""
        names = [c.name for c in task.classes]
        brought = belt_classes(belt, task.classes)
        return cls(
            tuple(task.classes),
            {n: sum(1 for o in task.scene if o.color == n) for n in names},
            {n: sum(1 for b in brought if b == n) for n in names},
        )

    @property
    def class_names(self) -> list[str]:
        """Class names in sort order."""
        return [c.name for c in self.classes]

    def class_named(self, name: str) -> ColorClass:
        """The class called ``name`` (:func:`~mearm.config.classes.class_named`)."""
        return class_named(self.classes, name)

    def objects(self, name: str) -> int:
        """Objects of class ``name`` the table ever holds: the scene's and the belt's."""
        return self.scene.get(name, 0) + self.belt.get(name, 0)


def wall_height_m(cls: ColorClass, objects: int) -> float:
    """The class's ``bin_height_cm``, else walls that hold ``objects`` of it stacked, and one more.

    ``objects``: the scene's and the belt's (:meth:`TableContents.objects`). The twin
    releases each over the bin's middle, so they stack.
    """
    if cls.bin_height_cm is not None:
        return cls.bin_height_cm * M_PER_CM
    per = max(BIN_WALL_HEIGHT_PER_HEIGHT, max(1, objects) + 1.0)
    return max(BIN_MIN_WALL_HEIGHT_M, per * cls.height_cm * M_PER_CM)


def bin_half_outer_m(cls: ColorClass) -> float:
    """Half a bin's outer width [m]."""
    return cls.bin_inner_width_cm * M_PER_CM / 2 + BIN_WALL_M


def bin_origin_m(cls: ColorClass) -> np.ndarray:
    """Where a class's bin stands: its body's origin in the world frame, (3,) [m]."""
    return np.array([cls.bin_cm[0] * M_PER_CM, cls.bin_cm[1] * M_PER_CM, 0.0])


def bin_shapes(cls: ColorClass, objects: int) -> list[Shape]:
    """A class's bin: a floor and four walls, in its body ``bin_<class>`` (:func:`bin_origin_m`).

    ``objects``: how many the walls must hold (:func:`wall_height_m`).
    """
    color = cls.name
    inner = cls.bin_inner_width_cm * M_PER_CM / 2
    outer = inner + BIN_WALL_M
    body = bin_name(color)
    t, z = BIN_WALL_M / 2, wall_height_m(cls, objects) / 2
    floor = bin_name(color, "floor")
    out = [Shape(floor, body, "box", (outer, outer, t), np.array([0, 0, t]), part="bin")]
    for name, pos, size in (
        ("px", (inner + t, 0, z), (t, outer, z)),
        ("nx", (-inner - t, 0, z), (t, outer, z)),
        ("py", (0, inner + t, z), (inner, t, z)),
        ("ny", (0, -inner - t, z), (inner, t, z)),
    ):
        out.append(
            Shape(
                bin_name(color, f"wall_{name}"), body, "box", size, np.array(pos, float), part="bin"
            )
        )
    return out


def object_shape(cls: ColorClass, oid: str) -> Shape:
    """A scene object as the planner sees it: a cylinder about its body's origin.

    The cylinder around its footprint (a cylinder's own; a cube's or a prism's enclosing
    one, whatever its yaw), its class's height; the origin stands
    :func:`object_centre_m` above the table.
    """
    r, h = cls.footprint_radius_cm * M_PER_CM, cls.height_cm * M_PER_CM
    name = object_name(oid)
    return Shape(name, name, "cylinder", (r, h / 2), np.zeros(3), part="object")


def object_centre_m(cls: ColorClass, x_cm: float, y_cm: float) -> np.ndarray:
    """An object's centre, standing on the table at (x, y), (3,) [m]."""
    h = cls.height_cm * M_PER_CM
    return np.array([x_cm * M_PER_CM, y_cm * M_PER_CM, h / 2])


__all__ = [
    "BIN_PREFIX",
    "BIN_WALL_M",
    "LINK_THICKNESS_M",
    "OBJECT_PREFIX",
    "ArmBodies",
    "Shape",
    "TableContents",
    "arm_bodies",
    "base_radius_m",
    "bin_half_outer_m",
    "bin_name",
    "bin_origin_m",
    "bin_shapes",
    "class_of",
    "fixed_part",
    "frame_about",
    "link_width_m",
    "object_centre_m",
    "object_name",
    "object_of",
    "object_shape",
    "plate_mass_kg",
    "wall_height_m",
]
