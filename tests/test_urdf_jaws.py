"""The URDF draws the jaws where the physical twin (MJCF) has them: the same tips, roots,
faces and mount, so the view shows a carried object between the drawn jaws."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pinocchio as pin
import pytest
from conftest import ROOT

from mearm.config import Config, load_config
from mearm.kinematics import ArmModel, generate_urdf, jaw_joint_names
from mearm.kinematics.urdf import JAW_PAD_LENGTH_M, jaw_pad_length_m, jaw_span_m
from mearm.sim.twin import mjcf
from mearm.sim.twin.mjcf import twin_model

CONFIGS = (
    "sim.yaml",
    "sim_mujoco.yaml",
    "sim_5dof.yaml",
    "sim_mearm_v1.yaml",
    "sim_4colours.yaml",
)
M_PER_CM = 0.01
TOL = 1e-6  # [m]


@pytest.fixture(scope="module", params=CONFIGS)
def both(request: pytest.FixtureRequest) -> tuple[Config, mujoco.MjModel, mujoco.MjData]:
    """A reference config and its twin at the home keyframe (jaws open)."""
    config = load_config(ROOT / "configs" / request.param)
    m = twin_model(config)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)
    return config, m, d


class Drawn:
    """The URDF placed by Pinocchio at the twin's joints and jaw positions: its visuals
    and, in the world, its TCP and jaw joint axes."""

    def __init__(self, config: Config, d: mujoco.MjData) -> None:
        urdf = generate_urdf(config.arm)
        full = pin.buildModelFromXML(urdf)
        self.geom = pin.buildGeomFromUrdfString(full, urdf, pin.GeometryType.VISUAL)
        q = pin.neutral(full)
        for name in [*ArmModel(config.arm).chain.names, *jaw_joint_names(config.arm)]:
            q[full.joints[full.getJointId(name)].idx_q] = float(d.joint(name).qpos[0])
        data = full.createData()
        self.gdata = self.geom.createData()
        pin.framesForwardKinematics(full, data, q)
        pin.updateGeometryPlacements(full, data, self.geom, self.gdata)
        self.tcp = data.oMf[full.getFrameId("tcp")]
        joints = {j.get("name"): j for j in ET.fromstring(urdf).iter("joint")}
        self.axis = {}
        for name in jaw_joint_names(config.arm):
            xyz = [float(x) for x in joints[name].find("axis").get("xyz").split()]
            self.axis[name] = self.tcp.rotation @ np.array(xyz)

    def box(self, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        i = self.geom.getGeometryId(name)
        assert i < len(self.geom.geometryObjects), f"no URDF visual {name}"
        M = self.gdata.oMg[i]
        return M.translation, M.rotation, np.asarray(self.geom.geometryObjects[i].geometry.halfSide)

    def has(self, name: str) -> bool:
        return self.geom.getGeometryId(name) < len(self.geom.geometryObjects)


def _extent(centre, R, half, origin, axis) -> tuple[float, float]:
    """A box's extent along a world unit axis from ``origin``: (min, max) [m]."""
    c, r = float((centre - origin) @ axis), float(np.abs(R.T @ axis) @ half)
    return c - r, c + r


def _approach(config: Config, tcp_rotation: np.ndarray) -> np.ndarray:
    a = tcp_rotation @ np.asarray(config.arm.tool.approach_axis, dtype=float)
    return a / np.linalg.norm(a)


def _axes(approach: np.ndarray, jaw_axis: np.ndarray) -> list[np.ndarray]:
    """Approach, the jaw's own opening direction and the third: a jaw's own frame."""
    return [approach, jaw_axis, np.cross(approach, jaw_axis)]


@pytest.mark.parametrize("jaw_cm", [4.0, 0.5])
def test_the_twin_uses_the_urdfs_pad_length(jaw_cm):
    """One pad length for both models: the MJCF's is the URDF's, for a jaw longer than
    :data:`JAW_PAD_LENGTH_M` and one shorter (the pad is then the whole jaw)."""
    base = load_config(ROOT / "configs" / "sim_mujoco.yaml")
    tool = base.arm.tool
    gripper = tool.gripper.model_copy(update={"jaw_length_cm": jaw_cm})
    arm = base.arm.model_copy(update={"tool": tool.model_copy(update={"gripper": gripper})})
    config = base.model_copy(update={"arm": arm})
    want = min(JAW_PAD_LENGTH_M, jaw_cm * M_PER_CM)
    assert jaw_pad_length_m(config.arm.tool.gripper) == want
    assert mjcf.pad_length_m(config) == want


def test_urdf_tcp_is_the_twin_tcp(both):
    config, _, d = both
    drawn = Drawn(config, d)
    np.testing.assert_allclose(drawn.tcp.translation, d.site("tcp").xpos, atol=TOL)
    np.testing.assert_allclose(drawn.tcp.rotation, d.site("tcp").xmat.reshape(3, 3), atol=TOL)


def test_urdf_jaws_span_the_twins_pad_and_finger(both):
    """At the twin's home (jaws open), each URDF jaw visual covers exactly the twin's pad
    and finger, from the TCP: along the approach axis (root to tip), along the jaw's own
    opening axis (inner face on the joint's position) and sideways, within 1e-6 m; the
    tip is half a pad beyond the grip point, the root a jaw length before the tip."""
    config, m, d = both
    drawn = Drawn(config, d)
    tcp = d.site("tcp").xpos
    approach = _approach(config, d.site("tcp").xmat.reshape(3, 3))
    root, tip = jaw_span_m(config.arm.tool)
    pad = jaw_pad_length_m(config.arm.tool.gripper)
    assert tip == pytest.approx(float((d.site("grip").xpos - tcp) @ approach) + pad / 2, abs=TOL)
    assert tip - root == pytest.approx(config.arm.tool.gripper.jaw_length_cm * M_PER_CM)
    for jaw in jaw_joint_names(config.arm):
        assert d.joint(jaw).qpos[0] == pytest.approx(config.arm.tool.gripper.open_cm / 200)
        parts = [f"{jaw}_pad"]
        if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, f"{jaw}_finger") >= 0:
            parts.append(f"{jaw}_finger")
        twin = [(d.geom(n).xpos, d.geom(n).xmat.reshape(3, 3), m.geom(n).size) for n in parts]
        twin_axes = _axes(approach, d.xaxis[m.joint(jaw).id])
        box = drawn.box(f"link_{jaw}_0")
        drawn_axes = _axes(_approach(config, drawn.tcp.rotation), drawn.axis[jaw])
        for k in range(3):
            spans = [_extent(*b, tcp, twin_axes[k]) for b in twin]
            want = (min(s[0] for s in spans), max(s[1] for s in spans))
            got = _extent(*box, drawn.tcp.translation, drawn_axes[k])
            np.testing.assert_allclose(got, want, atol=TOL, err_msg=f"{jaw}, axis {k}")
        lo, hi = _extent(*box, drawn.tcp.translation, drawn_axes[0])
        assert (lo, hi) == pytest.approx((root, tip), abs=TOL)


def test_urdf_mount_is_the_twins(both):
    """The tcp link's plate runs from the TCP to the roots exactly when the twin's mount
    does (same span along the approach axis); none when the roots are not beyond it."""
    config, m, d = both
    drawn = Drawn(config, d)
    name = f"{config.arm.tool.gripper.name}_mount"
    has_twin = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name) >= 0
    assert has_twin == drawn.has("tcp_0") == (jaw_span_m(config.arm.tool)[0] > 1e-9)
    if not has_twin:
        return
    approach = _approach(config, d.site("tcp").xmat.reshape(3, 3))
    twin = (d.geom(name).xpos, d.geom(name).xmat.reshape(3, 3), m.geom(name).size)
    got = _extent(*drawn.box("tcp_0"), drawn.tcp.translation, approach)
    want = _extent(*twin, d.site("tcp").xpos, approach)
    np.testing.assert_allclose(got, want, atol=TOL)
    assert got == pytest.approx((0.0, jaw_span_m(config.arm.tool)[0]), abs=TOL)


def test_jaw_joints_are_unchanged(both):
    """Only the plates moved: the jaw joints sit at the TCP, open across the approach
    axis from 0 to half the servo's largest opening, the right one mimicking the left."""
    config, _, _ = both
    root = ET.fromstring(generate_urdf(config.arm))
    joints = {j.get("name"): j for j in root.iter("joint")}
    left, right = jaw_joint_names(config.arm)
    approach = np.asarray(config.arm.tool.approach_axis, dtype=float)
    hi = config.arm.tool.gripper.servo.value_range()[1] * M_PER_CM / 2
    axes = []
    for name in (left, right):
        j = joints[name]
        assert j.get("type") == "prismatic" and j.find("parent").get("link") == "tcp"
        assert j.find("origin").get("xyz") == "0 0 0"
        axes.append(np.array([float(x) for x in j.find("axis").get("xyz").split()]))
        assert float(j.find("limit").get("lower")) == 0.0
        assert float(j.find("limit").get("upper")) == pytest.approx(hi)
    assert axes[0] @ approach == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(axes[1], -axes[0])
    assert joints[right].find("mimic").get("joint") == left


def test_the_urdf_jaws_open_along_the_twins_line(both):
    """The drawn jaws open along the line the twin's do (level with the arm at home), so
    the view shows the jaws where they close on an object."""
    config, m, d = both
    drawn = Drawn(config, d)
    for name in jaw_joint_names(config.arm):
        j = m.joint(name)
        body = d.body(m.jnt_bodyid[j.id])
        twin_axis = body.xmat.reshape(3, 3) @ m.jnt_axis[j.id]
        assert drawn.axis[name] == pytest.approx(twin_axis, abs=1e-9), name
        assert abs(float(twin_axis[2])) < 1e-9, f"{name} does not open level at home"
