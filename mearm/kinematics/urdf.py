r"""Generate an arm's URDF from its description.

Each DH row i becomes joint i (revolute or prismatic) moving along its own z axis; the
fixed part of row i, :math:`R_z(\theta_{0,i})\,T_z(d_i)\,T_x(a_i)\,R_x(\alpha_i)`, is the
origin of the next joint, and of the fixed ``tcp`` joint (moved by the tool's
``tcp_cm``) after the last row. The FK of the URDF is therefore the DH product, exactly.

A passive joint is written as an ordinary joint: URDF's ``mimic`` follows one joint only,
so the coupling (an affine function of several) is recorded in a comment beside it, in a
form a reader can parse (``mearm:coupling``); the solvers impose it. The gripper's two
jaws are real prismatic joints on the ``tcp`` link, the second a ``mimic`` of the first.
Lengths are written in metres and angles in radians, as URDF requires.

The jaws are drawn where the physical twin (:mod:`mearm.sim.twin.mjcf`) has them, where the
grasp happens: along the tool's approach axis the grip point is ``tcp_above_grip_cm``
beyond the TCP; a jaw, ``jaw_length_cm`` long from root to tip, ends in a pad
(:func:`jaw_pad_length_m` long) centred on the grip point, so its tip is half a pad
beyond the grip point and its root ``jaw_length_cm`` before the tip
(:func:`jaw_span_m`). Its inner face is on the jaw joint's position, so the faces are the
opening apart. A plate on the ``tcp`` link bridges the TCP to the roots when they start
beyond it.
"""

from __future__ import annotations

import math

import numpy as np

from mearm.config import ArmDescription, Gripper, Joint, Tool
from mearm.kinematics.chain import Chain
from mearm.kinematics.dh import dh_tcp_frame
from mearm.kinematics.errors import ModelError
from mearm.kinematics.per_arm import PerArm

CM = 0.01  # metres per centimetre

# Joint torque/speed written into the URDF: informative only (the solvers do not use
# them). A hobby servo: a few N·m, about 0.15 s per 60° (≈ 7 rad/s).
_EFFORT = 3.4
_VELOCITY = 7.0

_COLORS = {
    "base": "0.25 0.25 0.28 1",
    "link": "0.95 0.55 0.10 1",
    "joint": "0.15 0.15 0.15 1",
    "gripper": "0.70 0.70 0.75 1",
}

#: Name of the tool-centre-point frame every model has.
TCP_FRAME = "tcp"

#: A jaw pad's length along the approach axis, at most the jaw's (estimate: the rubber
#: pads of hobby grippers are about 1 cm; 8 mm keeps the tips of pads closing on a 1 cm
#: object at half its height 1 mm off the table) [m]. The URDF and the twin's MJCF both
#: place the jaws by it.
JAW_PAD_LENGTH_M = 0.008


def _f(x: float) -> str:
    # repr round-trips a float exactly; drop float noise below 1e-15 and -0.0.
    x = float(x)
    if abs(x) < 1e-15:
        x = 0.0
    return repr(x + 0.0)


def _xyz(v: np.ndarray | tuple[float, ...]) -> str:
    return " ".join(_f(x) for x in v)


def _visual(geometry: str, xyz: str, rpy: str, material: str) -> str:
    return (
        f'    <visual>\n      <origin xyz="{xyz}" rpy="{rpy}"/>\n'
        f"      <geometry>{geometry}</geometry>\n"
        f'      <material name="{material}"/>\n    </visual>\n'
        f'    <collision>\n      <origin xyz="{xyz}" rpy="{rpy}"/>\n'
        f"      <geometry>{geometry}</geometry>\n    </collision>\n"
    )


def _inertial(mass_kg: float, xyz: str) -> str:
    # A small box-like inertia: MuJoCo refuses massless moving bodies.
    i = mass_kg * 1e-3
    return (
        f'    <inertial>\n      <origin xyz="{xyz}" rpy="0 0 0"/>\n'
        f'      <mass value="{_f(mass_kg)}"/>\n'
        f'      <inertia ixx="{_f(i)}" ixy="0" ixz="0" iyy="{_f(i)}" iyz="0" izz="{_f(i)}"/>\n'
        "    </inertial>\n"
    )


def _fixed_part(joint: Joint) -> tuple[np.ndarray, np.ndarray]:
    """Translation [m] and rotation of Rz(θ0)·Tz(d)·Tx(a)·Rx(α), (3,) and (3, 3)."""
    t0, al = math.radians(joint.dh.theta_deg), math.radians(joint.dh.alpha_deg)
    a, d = joint.dh.a_cm * CM, joint.dh.d_cm * CM
    ct, st, ca, sa = math.cos(t0), math.sin(t0), math.cos(al), math.sin(al)
    R = np.array([[ct, -st * ca, st * sa], [st, ct * ca, -ct * sa], [0.0, sa, ca]])
    return np.array([a * ct, a * st, d]), R


def _rpy(joint: Joint) -> str:
    # Rz(θ0)·Rx(α) is roll α, pitch 0, yaw θ0 in URDF's fixed-axis convention: exact.
    return _xyz((math.radians(joint.dh.alpha_deg), 0.0, math.radians(joint.dh.theta_deg)))


def _link_body(joint: Joint, width_m: float, material: str) -> str:
    """Visuals of row i's segment Tz(d)·Rz(θ0)·Tx(a) in joint i's (moving) frame."""
    out = ""
    a, d = joint.dh.a_cm * CM, joint.dh.d_cm * CM
    t0 = math.radians(joint.dh.theta_deg)
    if abs(d) > 1e-9:
        cyl = f'<cylinder radius="{_f(width_m)}" length="{_f(abs(d))}"/>'
        out += _visual(cyl, _xyz((0, 0, d / 2)), "0 0 0", material)
    if abs(a) > 1e-9:
        box = f'<box size="{_xyz((abs(a), width_m, width_m))}"/>'
        centre = (a / 2 * math.cos(t0), a / 2 * math.sin(t0), d)
        out += _visual(box, _xyz(centre), _xyz((0, 0, t0)), material)
    shape = "cylinder" if joint.type == "revolute" else "box"
    if shape == "cylinder":
        hub = f'<cylinder radius="{_f(width_m * 0.9)}" length="{_f(width_m * 1.6)}"/>'
    else:
        hub = f'<box size="{_xyz((width_m * 1.8, width_m * 1.8, width_m * 1.2))}"/>'
    out += _visual(hub, "0 0 0", "0 0 0", "joint")
    return out


def _coupling_text(joint: Joint) -> str:
    assert joint.coupling is not None
    terms = " + ".join(f"{c!r}*{name}" for name, c in joint.coupling.terms.items())
    return f"{joint.name} = {terms} + {joint.coupling.offset!r}"


def jaw_frame(arm: ArmDescription) -> np.ndarray:
    """The jaws' axes in the TCP frame, unit columns (3, 3) (:func:`_jaw_frame`, a copy).

    Worked out once per description (:class:`~mearm.kinematics.per_arm.PerArm`): a run
    asks some 14 times.
    """
    return _jaw_frame_of(arm).copy()


def _jaw_frame(arm: ArmDescription) -> np.ndarray:
    """The jaws' axes in the TCP frame, unit columns (3, 3).

    The columns are the approach axis, the axis across it the left jaw opens along, and
    their cross product. The jaws close on objects standing on the table, so they open
    along a line that is level with the arm at home (a claw pointing forward and level
    opens sideways, not up and down); with the approach axis vertical at home every axis
    across it is level, and the first of the TCP frame's y and x made perpendicular to
    the approach axis is taken. The physical twin (:mod:`mearm.sim.twin.mjcf`) uses the same.
    """
    approach = np.asarray(arm.tool.approach_axis, dtype=float)
    approach = approach / np.linalg.norm(approach)
    for trial in (np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0])):
        v = np.cross(approach, trial)
        if np.linalg.norm(v) > 1e-6:
            across = np.cross(v, approach)
            across /= np.linalg.norm(across)
            break
    else:  # pragma: no cover - two trial axes cannot both be parallel
        raise AssertionError("unreachable: two trial axes cannot both be parallel")
    R = dh_tcp_frame(arm, Chain.from_description(arm).home)[:3, :3]
    up = R.T @ np.array([0.0, 0.0, 1.0])  # the vertical in the TCP frame at home
    level = np.cross(approach, up)
    if abs(float(across @ up)) > 1e-6 and np.linalg.norm(level) > 1e-6:
        across = level / np.linalg.norm(level)
    return np.column_stack([approach, across, np.cross(approach, across)])


_jaw_frame_of = PerArm(_jaw_frame)


def jaw_pad_length_m(gripper: Gripper) -> float:
    """A jaw pad's length along the approach axis: :data:`JAW_PAD_LENGTH_M` or the jaw's [m]."""
    return min(JAW_PAD_LENGTH_M, gripper.jaw_length_cm * CM)


def jaw_span_m(tool: Tool) -> tuple[float, float]:
    """Where a jaw's root and tip are along the approach axis, from the TCP [m].

    The pad is centred on the grip point (``tcp_above_grip_cm`` beyond the TCP), so the
    tip is half a pad beyond it and the root ``jaw_length_cm`` before the tip.
    """
    tip = tool.tcp_above_grip_cm * CM + jaw_pad_length_m(tool.gripper) / 2
    return tip - tool.gripper.jaw_length_cm * CM, tip


def _rpy_of(R: np.ndarray) -> str:
    """URDF's fixed-axis roll, pitch, yaw of rotation ``R`` (= Rz(y)·Ry(p)·Rx(r))."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[0, 0], R[1, 0]) > 1e-9:
        roll, yaw = math.atan2(R[2, 1], R[2, 2]), math.atan2(R[1, 0], R[0, 0])
    else:  # pitch ±90°: only yaw ∓ roll is defined; take roll 0
        roll, yaw = 0.0, math.atan2(-R[0, 1], R[1, 1])
    return _xyz((roll, pitch, yaw))


def jaw_joint_names(arm: ArmDescription) -> tuple[str, str]:
    """The URDF names of the gripper's two jaw joints (the second mimics the first)."""
    g = arm.tool.gripper.name
    return (f"{g}_jaw_left", f"{g}_jaw_right")


def _check_frame_names(arm: ArmDescription) -> None:
    """Raise :class:`ModelError` when a name the maker gave is one the URDF also writes.

    Pinocchio names its frames after the URDF's joints and links alike, and the model
    finds the TCP by the name ``tcp``: a joint named ``tcp`` or ``base_link`` (a ROS
    habit), or ``link_elbow`` beside a joint ``elbow``, would leave two frames of one name
    (an unexpected error with a traceback) or two links of one name (URDF refuses the
    file, with C++ lines on stderr). Named here instead: the config's field and the clash.
    """
    seen: dict[str, tuple[str, str | None]] = {}

    def add(name: str, what: str, field: str | None) -> None:
        if name in seen:
            first, first_field = seen[name]
            # the joint named last is the likelier slip (a joint "link_elbow" beside "elbow")
            named = field if field is not None and field.startswith("arm.joints") else None
            raise ModelError(
                f"{named or first_field or field}: {name!r} is both {first} and {what} in "
                "this arm's URDF (its joints and links are named base_link, tcp, tcp_fixed, "
                "link_<joint> and <gripper>_jaw_left/right): give it another name"
            )
        seen[name] = (what, field)

    add("base_link", "the base link", None)
    for joint in arm.joints:
        field = f"arm.joints.{joint.name}.name"
        add(joint.name, f"the joint {joint.name!r}", field)
        add(f"link_{joint.name}", f"the link of the joint {joint.name!r}", field)
    add(f"{TCP_FRAME}_fixed", "the TCP's fixed joint", None)
    add(TCP_FRAME, "the TCP frame", None)
    for jaw in jaw_joint_names(arm):
        add(jaw, f"the gripper's jaw joint {jaw!r}", "arm.tool.gripper.name")
        add(f"link_{jaw}", f"the link of the jaw joint {jaw!r}", "arm.tool.gripper.name")


def generate_urdf(arm: ArmDescription) -> str:
    """Build the URDF text of ``arm``.

    Returns:
        URDF XML, metres and radians; joints named as in the description, then the
        fixed ``tcp`` joint, then the gripper's jaw joints.

    Raises:
        ModelError: a joint or the gripper has a name the URDF also gives another of its
            joints or links (:func:`_check_frame_names`).
    """
    _check_frame_names(arm)
    parts = [
        '<?xml version="1.0"?>\n',
        "<!-- Generated by `mearm urdf` (tools/dh_to_urdf.py) from the arm description.\n",
        "     Do not edit: change the config and regenerate.\n",
        "     Joint i moves along its own z axis; its origin is the fixed part\n",
        "     Rz(theta0)·Tz(d)·Tx(a)·Rx(alpha) of DH row i-1, so FK equals the DH product.\n",
        "     Lengths in metres, angles in radians. -->\n",
        f'<robot name="{arm.name}">\n',
    ]
    parts += [
        f'  <material name="{k}"><color rgba="{v}"/></material>\n' for k, v in _COLORS.items()
    ]
    reach = sum(abs(j.dh.a_cm) + abs(j.dh.d_cm) for j in arm.joints) * CM
    width = max(0.006, min(0.02, reach / 60))
    parts.append('  <link name="base_link">\n')
    base = f'<cylinder radius="{_f(width * 3.3)}" length="{_f(width)}"/>'
    parts.append(_visual(base, _xyz((0, 0, width / 2)), "0 0 0", "base"))
    parts.append(_inertial(0.5, _xyz((0, 0, width / 2))))
    parts.append("  </link>\n")

    parent = "base_link"
    origin_xyz, origin_rpy = "0 0 0", "0 0 0"
    limits = arm.joint_limits()
    last = len(arm.joints) - 1
    for i, joint in enumerate(arm.joints):
        lname = f"link_{joint.name}"
        lim = limits[joint.name]
        scale = CM if joint.type == "prismatic" else math.pi / 180.0
        if joint.coupling is not None:
            parts.append(
                "  <!-- passive joint, no servo; URDF mimic follows one joint only, so the\n"
                f"       solvers impose its coupling. mearm:coupling {_coupling_text(joint)}\n"
                "       (values in degrees, or cm for a prismatic joint) -->\n"
            )
        parts.append(
            f'  <joint name="{joint.name}" type="{joint.type}">\n'
            f'    <parent link="{parent}"/>\n    <child link="{lname}"/>\n'
            f'    <origin xyz="{origin_xyz}" rpy="{origin_rpy}"/>\n'
            '    <axis xyz="0 0 1"/>\n'
            f'    <limit lower="{_f(lim.min * scale)}" upper="{_f(lim.max * scale)}" '
            f'effort="{_f(_EFFORT)}" velocity="{_f(_VELOCITY)}"/>\n'
            "  </joint>\n"
        )
        material = "gripper" if i == last else "link"
        parts.append(f'  <link name="{lname}">\n')
        parts.append(_link_body(joint, width if i else width * 1.5, material))
        t, _ = _fixed_part(joint)
        parts.append(_inertial(0.1, _xyz(t / 2)))
        parts.append("  </link>\n")
        t, _R = _fixed_part(joint)
        origin_xyz, origin_rpy = _xyz(t), _rpy(joint)
        parent = lname

    # the tcp frame: the DH end moved by tcp_cm (given in that frame)
    last_joint = arm.joints[-1]
    t, R = _fixed_part(last_joint)
    tcp = t + R @ (np.asarray(arm.tool.tcp_cm, dtype=float) * CM)
    parts.append(
        f'  <joint name="{TCP_FRAME}_fixed" type="fixed">\n'
        f'    <parent link="{parent}"/>\n    <child link="{TCP_FRAME}"/>\n'
        f'    <origin xyz="{_xyz(tcp)}" rpy="{_rpy(last_joint)}"/>\n'
        "  </joint>\n"
    )
    parts.append(f'  <link name="{TCP_FRAME}">\n')
    parts.append(_mount(arm, width))
    parts.append(_inertial(0.02, "0 0 0"))
    parts.append("  </link>\n")
    parts.append(_jaws(arm, width))
    parts.append("</robot>\n")
    return "".join(parts)


def _jaws(arm: ArmDescription, width_m: float) -> str:
    """The gripper's two jaws: prismatic joints on the tcp link, the right one a mimic.

    Each jaw is a plate ``jaw_thickness_cm`` thick and ``width_m`` wide spanning
    :func:`jaw_span_m` along the approach axis, its inner face on the joint's position
    (the twin's pad and finger together); the joints, axes and limits do not depend on
    where the plates are.
    """
    g = arm.tool.gripper
    R = jaw_frame(arm)
    approach, across = R[:, 0], R[:, 1]
    half_open = g.servo.value_range()[1] / 2 * CM
    thick = g.jaw_thickness_cm * CM
    root, tip = jaw_span_m(arm.tool)
    size = _xyz((tip - root, thick, width_m))
    out = ""
    left, right = jaw_joint_names(arm)
    for name, sign in ((left, 1.0), (right, -1.0)):
        mimic = f'    <mimic joint="{left}" multiplier="1" offset="0"/>\n' if sign < 0 else ""
        centre = _xyz(approach * (root + tip) / 2 + across * sign * thick / 2)
        out += (
            f'  <joint name="{name}" type="prismatic">\n'
            f'    <parent link="{TCP_FRAME}"/>\n    <child link="link_{name}"/>\n'
            '    <origin xyz="0 0 0" rpy="0 0 0"/>\n'
            f'    <axis xyz="{_xyz(across * sign)}"/>\n'
            f'    <limit lower="0" upper="{_f(half_open)}" effort="{_f(_EFFORT)}" '
            f'velocity="{_f(0.1)}"/>\n'
            f"{mimic}  </joint>\n"
            f'  <link name="link_{name}">\n'
            + _visual(f'<box size="{size}"/>', centre, _rpy_of(R), "gripper")
            + _inertial(0.01, centre)
            + "  </link>\n"
        )
    return out


def _mount(arm: ArmDescription, width_m: float) -> str:
    """The tcp link's plate from the TCP to the jaws' roots.

    Empty when the roots start at or before the TCP.
    """
    R = jaw_frame(arm)
    root, _ = jaw_span_m(arm.tool)
    if root <= 1e-9:
        return ""
    box = f'<box size="{_xyz((root, arm.tool.gripper.jaw_thickness_cm * CM, width_m))}"/>'
    return _visual(box, _xyz(R[:, 0] * root / 2), _rpy_of(R), "gripper")
