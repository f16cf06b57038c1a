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
"""

from __future__ import annotations

import math

import numpy as np

from mearm.config import ArmDescription, Joint

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


def _opening_axis(approach: np.ndarray) -> np.ndarray:
    """A unit axis across the approach axis, along which the jaws open."""
    for trial in (np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0])):
        v = np.cross(approach, trial)
        if np.linalg.norm(v) > 1e-6:
            axis = np.cross(v, approach)
            return axis / np.linalg.norm(axis)
    raise AssertionError("unreachable: two trial axes cannot both be parallel")


def jaw_joint_names(arm: ArmDescription) -> tuple[str, str]:
    """The URDF names of the gripper's two jaw joints (the second mimics the first)."""
    g = arm.tool.gripper.name
    return (f"{g}_jaw_left", f"{g}_jaw_right")


def generate_urdf(arm: ArmDescription) -> str:
    """Build the URDF text of ``arm``.

    Returns:
        URDF XML, metres and radians; joints named as in the description, then the
        fixed ``tcp`` joint, then the gripper's jaw joints.
    """
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
    parts.append(_inertial(0.02, "0 0 0"))
    parts.append("  </link>\n")
    parts.append(_jaws(arm, width))
    parts.append("</robot>\n")
    return "".join(parts)


def _jaws(arm: ArmDescription, width_m: float) -> str:
    """The gripper's two jaws: prismatic joints on the tcp link, the right one a mimic."""
    g = arm.tool.gripper
    approach = np.asarray(arm.tool.approach_axis, dtype=float)
    approach /= np.linalg.norm(approach)
    across = _opening_axis(approach)
    half_open = g.servo.value_range()[1] / 2 * CM
    length, thick = g.jaw_length_cm * CM, g.jaw_thickness_cm * CM
    # a jaw: a plate reaching `length` along the approach axis from the tcp origin
    centre = approach * length / 2
    size = np.abs(approach) * length + np.abs(across) * thick
    size += (1 - np.abs(approach) - np.abs(across)).clip(0) * width_m
    size = np.maximum(size, thick)
    out = ""
    left, right = jaw_joint_names(arm)
    for name, sign in ((left, 1.0), (right, -1.0)):
        mimic = f'    <mimic joint="{left}" multiplier="1" offset="0"/>\n' if sign < 0 else ""
        out += (
            f'  <joint name="{name}" type="prismatic">\n'
            f'    <parent link="{TCP_FRAME}"/>\n    <child link="link_{name}"/>\n'
            '    <origin xyz="0 0 0" rpy="0 0 0"/>\n'
            f'    <axis xyz="{_xyz(across * sign)}"/>\n'
            f'    <limit lower="0" upper="{_f(half_open)}" effort="{_f(_EFFORT)}" '
            f'velocity="{_f(0.1)}"/>\n'
            f"{mimic}  </joint>\n"
            f'  <link name="link_{name}">\n'
            + _visual(f'<box size="{_xyz(size)}"/>', _xyz(centre), "0 0 0", "gripper")
            + _inertial(0.01, _xyz(centre))
            + "  </link>\n"
        )
    return out
