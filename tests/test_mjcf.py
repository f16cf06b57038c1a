"""The twin's MJCF: loads, reproduces the DH chain, holds home, rests the objects."""

from __future__ import annotations

import copy
import math

import mujoco
import numpy as np
import pytest
from badinput import check_bad_input
from conftest import ROOT

from mearm.config import Config, SceneObject, load_config
from mearm.exceptions import ModelError
from mearm.kinematics import ArmModel
from mearm.kinematics.chain import Chain
from mearm.kinematics.urdf import jaw_joint_names
from mearm.sim import World
from mearm.sim.twin.mjcf import (
    COUPLING_PLAY,
    COUPLING_SOLREF,
    GRIPPER_SERVO,
    GRIPPER_SERVO_TEXT,
    JOINT_SERVO_TEXT,
    M_PER_CM,
    SG90,
    generate_mjcf,
    object_ids,
    pad_length_m,
    recorded_servo,
    save_mjcf,
    servo_named,
    servo_tendon,
    twin_model,
)
from mearm.task.plan import Planner

CONFIGS = ("sim.yaml", "sim_mujoco.yaml", "sim_mearm_v1.yaml", "sim_5dof.yaml")
HOLD_S = 2.0


@pytest.fixture(scope="module", params=CONFIGS)
def twin(request: pytest.FixtureRequest) -> tuple[Config, str, mujoco.MjModel]:
    config = load_config(ROOT / "configs" / request.param)
    return config, generate_mjcf(config), twin_model(config)


@pytest.fixture(scope="module")
def held(twin: tuple[Config, str, mujoco.MjModel]) -> mujoco.MjData:
    """The twin after HOLD_S of sim time at home, ctrl at home, under gravity."""
    _, _, m = twin
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_step(m, d, nstep=round(HOLD_S / m.opt.timestep))
    return d


def test_the_twin_and_mink_solve_on_one_chain(twin: tuple[Config, str, mujoco.MjModel]) -> None:
    """One builder: the twin's chain and the mink cross-check's put the TCP at one place."""
    from mearm.ik.mink_solver import mujoco_model  # here: mink costs each worker 0.3 s

    config, _, m = twin
    arm = ArmModel(config.arm)
    bare = mujoco_model(arm)
    d, e = mujoco.MjData(m), mujoco.MjData(bare)
    chain = arm.chain
    rng = np.random.default_rng(7)
    for _ in range(20):
        q = chain.C @ rng.uniform(chain.actuated_lower, chain.actuated_upper) + chain.c
        _set_arm(m, d, config, q)
        e.qpos[:] = q
        mujoco.mj_kinematics(bare, e)
        np.testing.assert_allclose(d.site("tcp").xpos, e.site("tcp").xpos, atol=1e-12)
        np.testing.assert_allclose(d.site("tcp").xpos * 100, arm.fk_cm(q), atol=1e-9)


def test_the_mjcf_text_is_the_compiled_twin(twin: tuple[Config, str, mujoco.MjModel]) -> None:
    """generate_mjcf writes the model twin_model compiles (to MuJoCo's six digits)."""
    _, xml, m = twin
    read = mujoco.MjModel.from_xml_string(xml)
    for field in ("body_pos", "body_mass", "jnt_range", "geom_size", "actuator_gainprm",
                  "actuator_biasprm", "eq_data", "key_qpos", "key_ctrl"):  # fmt: skip
        np.testing.assert_allclose(getattr(read, field), getattr(m, field), rtol=1e-5,
                                   atol=1e-9, err_msg=field)  # fmt: skip


def _set_arm(m: mujoco.MjModel, d: mujoco.MjData, config: Config, q: np.ndarray) -> None:
    for name, value in zip((j.name for j in config.arm.joints), q, strict=True):
        d.qpos[m.joint(name).qposadr[0]] = value
    mujoco.mj_forward(m, d)


def _arm_q(m: mujoco.MjModel, d: mujoco.MjData, config: Config) -> np.ndarray:
    return np.array([d.qpos[m.joint(j.name).qposadr[0]] for j in config.arm.joints])


def test_loads_from_string_and_from_path(twin, tmp_path):
    """The MJCF loads from a string and, written by save_mjcf, from a file."""
    config, xml, m = twin
    path = save_mjcf(config, tmp_path / "twin.xml")
    assert path.read_text(encoding="utf-8") == xml
    from_path = mujoco.MjModel.from_xml_path(str(path))
    assert (from_path.nbody, from_path.njnt, from_path.nu) == (m.nbody, m.njnt, m.nu)
    assert "<mesh" not in xml and "file=" not in xml


def test_tcp_at_home_matches_pinocchio(twin):
    """The tcp site at the home keyframe is Pinocchio's FK of home within 0.01 cm."""
    config, _, m = twin
    model = ArmModel(config.arm)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(_arm_q(m, d, config), model.home, atol=1e-12)
    np.testing.assert_allclose(d.site("tcp").xpos * 100, model.fk_cm(model.home), atol=1e-2)


def test_tcp_at_random_poses_matches_pinocchio(twin):
    """Position and orientation of the tcp site equal Pinocchio's at seeded in-limit poses."""
    config, _, m = twin
    model = ArmModel(config.arm)
    ch = model.chain
    d = mujoco.MjData(m)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q = ch.C @ rng.uniform(ch.actuated_lower, ch.actuated_upper) + ch.c
        _set_arm(m, d, config, q)
        p_cm, R = model.tcp_pose(q)
        np.testing.assert_allclose(d.site("tcp").xpos * 100, p_cm, atol=1e-9)
        np.testing.assert_allclose(d.site("tcp").xmat.reshape(3, 3), R, atol=1e-12)


def test_holds_home_under_gravity(twin, held):
    """With ctrl at home the TCP stays within 0.2 cm and each coupling within 1e-3 rad."""
    config, _, m = twin
    model = ArmModel(config.arm)
    ch = model.chain
    q = _arm_q(m, held, config)
    assert np.linalg.norm(held.site("tcp").xpos * 100 - model.fk_cm(model.home)) < 0.2
    coupled = ch.C @ q[ch.actuated_index] + ch.c
    assert np.max(np.abs(q - coupled)) < 1e-3
    assert np.max(np.abs(held.qvel[: ch.n])) < 1e-3  # settled, not oscillating


def test_coupling_is_a_tendon_held_at_its_offset(twin):
    """Each passive joint has a fixed tendon q_p − Σ c q_a held at its offset by its limits.

    Not a tendon equality: MuJoCo cannot put bodies to sleep in a model that has one.
    """
    config, _, m = twin
    chain = Chain.from_description(config.arm)
    for i, joint in enumerate(config.arm.joints):
        if joint.coupling is None:
            continue
        t = m.tendon(f"{joint.name}_coupling").id
        assert m.tendon_limited[t]
        half = COUPLING_PLAY / 2
        np.testing.assert_allclose(m.tendon_range[t], chain.c[i] + np.array([-half, half]))
        assert m.tendon_solref_lim[t].tolist() == list(COUPLING_SOLREF)


def test_objects_rest_on_the_table(twin, held):
    """After settling every object stands upright at z ≈ height/2, still, where placed."""
    config, _, m = twin
    for oid, obj in zip(object_ids(config), config.task.scene, strict=True):
        c = config.task.class_named(obj.color)
        body = held.body(f"obj_{oid}")
        assert body.xpos[2] * 100 == pytest.approx(c.height_cm / 2, abs=0.02)
        np.testing.assert_allclose(body.xpos[:2] * 100, (obj.x, obj.y), atol=0.01)
        assert body.xmat[8] > 1 - 1e-6  # upright
        assert np.linalg.norm(body.cvel) < 1e-3
        assert m.body(f"obj_{oid}").mass[0] > 0


def test_objects_at_rest_sleep_and_wake_when_touched(twin, held):
    """Settled objects sleep (MuJoCo does not simulate them), and so does the arm holding
    still; a push wakes an object and moves it, and leaves the arm asleep."""
    config, _, m = twin
    ids = object_ids(config)
    bodies = [m.body(f"obj_{oid}").id for oid in ids]
    assert all(held.body_awake[b] == mujoco.mjtSleepState.mjS_ASLEEP for b in bodies)
    assert held.nv_awake == 0
    d = copy.copy(held)
    b = bodies[0]
    d.xfrc_applied[b, 0] = 0.5  # a sideways push [N]: it wakes the object
    x0 = d.xpos[b].copy()
    mujoco.mj_step(m, d, nstep=50)
    assert d.body_awake[b] == mujoco.mjtSleepState.mjS_AWAKE
    assert np.linalg.norm(d.xpos[b] - x0) > 1e-4
    arm = m.body(f"link_{config.arm.joints[0].name}").id
    assert d.body_awake[arm] == mujoco.mjtSleepState.mjS_ASLEEP


def test_object_names_are_the_worlds_ids(twin):
    config, _, m = twin
    world = World.from_config(config)
    for o in world.objects:
        assert m.body(f"obj_{o.id}").id > 0


def test_objects_in_view_where_the_calibration_sees_them(twin):
    """The camera projects each object's foot to the pixel the calibration maps it from."""
    config, _, m = twin
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    cam = d.camera("camera")
    w, h = config.camera.width_px, config.camera.height_px
    f_px = h / 2 / math.tan(math.radians(m.camera("camera").fovy[0]) / 2)
    H_inv = np.linalg.inv(np.asarray(config.calibration.homography, dtype=float))
    for obj in config.task.scene:
        p = cam.xmat.reshape(3, 3).T @ (np.array([obj.x, obj.y, 0.0]) / 100 - cam.xpos)
        assert p[2] < 0  # in front of the camera
        u, v = w / 2 + f_px * p[0] / -p[2], h / 2 - f_px * p[1] / -p[2]
        assert 0 <= u <= w and 0 <= v <= h
        expected = H_inv @ np.array([obj.x, obj.y, 1.0])
        np.testing.assert_allclose((u, v), expected[:2] / expected[2], atol=0.5)
    assert cam.xpos[2] == pytest.approx(0.52)


def test_bins_have_a_floor_and_four_walls(twin):
    config, _, m = twin
    for c in config.task.classes:
        body = m.body(f"bin_{c.name}").id
        geoms = {m.geom(i).name for i in range(m.ngeom) if m.geom(i).bodyid[0] == body}
        walls = {f"bin_{c.name}_wall_{s}" for s in ("px", "nx", "py", "ny")}
        assert {f"bin_{c.name}_floor", *walls} <= geoms
        np.testing.assert_allclose(m.body(f"bin_{c.name}").pos[:2] * 100, c.bin_cm[:2])
        inner = m.geom(f"bin_{c.name}_wall_px").pos[0] - m.geom(f"bin_{c.name}_wall_px").size[0]
        assert inner * 200 == pytest.approx(3 * c.diameter_cm)


def test_table_top_is_z0(twin):
    _, _, m = twin
    table = m.geom("table")
    assert table.type == mujoco.mjtGeom.mjGEOM_PLANE and table.pos[2] == pytest.approx(0.0)


def test_gripper_closes_both_jaws(twin):
    """Commanding the closed opening moves the jaws, the second mirroring the first."""
    config, _, m = twin
    g = config.arm.tool.gripper
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    d.ctrl[m.actuator(g.name).id] = g.closed_cm / 100
    mujoco.mj_step(m, d, nstep=500)
    left, right = (d.joint(f"{g.name}_jaw_{s}").qpos[0] for s in ("left", "right"))
    assert (left + right) * 100 == pytest.approx(g.closed_cm, abs=0.01)
    assert left == pytest.approx(right, abs=1e-4)


def _grip_point_cm(config: Config, model: ArmModel, q: np.ndarray) -> np.ndarray:
    """The description's grip point: TCP + tcp_above_grip_cm along the approach axis, (3,)."""
    p_cm, R = model.tcp_pose(q)
    tool = config.arm.tool
    approach = R @ np.asarray(tool.approach_axis, dtype=float)
    return p_cm + approach / np.linalg.norm(approach) * tool.tcp_above_grip_cm


def _jaw_geoms(m: mujoco.MjModel, config: Config, part: str) -> list[str]:
    names = [f"{j}_{part}" for j in jaw_joint_names(config.arm)]
    return [n for n in names if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n) >= 0]


def test_jaw_pads_centre_on_the_grip_point(twin):
    """Open or closed, at seeded poses the pads' centre is the grip point (0.01 mm); the
    jaws reach no further than half a pad beyond it."""
    config, _, m = twin
    model = ArmModel(config.arm)
    ch = model.chain
    g = config.arm.tool.gripper
    d = mujoco.MjData(m)
    rng = np.random.default_rng(3)
    pad = pad_length_m(config) / M_PER_CM
    for opening_cm in (g.open_cm, g.closed_cm):
        for _ in range(3):
            q = ch.C @ rng.uniform(ch.actuated_lower, ch.actuated_upper) + ch.c
            for jaw in jaw_joint_names(config.arm):
                d.qpos[m.joint(jaw).qposadr[0]] = opening_cm * M_PER_CM / 2
            _set_arm(m, d, config, q)
            grip = _grip_point_cm(config, model, q)
            pads = [d.geom(n).xpos / M_PER_CM for n in _jaw_geoms(m, config, "pad")]
            np.testing.assert_allclose(np.mean(pads, axis=0), grip, atol=1e-3)
            np.testing.assert_allclose(d.site("grip").xpos / M_PER_CM, grip, atol=1e-3)
            gap = float(np.linalg.norm(pads[0] - pads[1]))
            assert gap == pytest.approx(opening_cm + g.jaw_thickness_cm, abs=1e-6)
            approach = d.site("tcp").xmat.reshape(3, 3) @ np.asarray(config.arm.tool.approach_axis)
            approach /= np.linalg.norm(approach)
            for n in _jaw_geoms(m, config, "pad") + _jaw_geoms(m, config, "finger"):
                R = d.geom(n).xmat.reshape(3, 3)
                half = m.geom(n).size
                reach = float(d.geom(n).xpos @ approach + np.abs(R.T @ approach) @ half)
                tip = float(grip @ approach * M_PER_CM) + pad / 2 * M_PER_CM
                assert reach <= tip + 1e-9, (n, reach, tip)


def _home_tool(m: mujoco.MjModel, config: Config) -> tuple[mujoco.MjData, np.ndarray]:
    """The twin at its home keyframe and the approach axis there, unit, (3,)."""
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)
    approach = d.site("tcp").xmat.reshape(3, 3) @ np.asarray(config.arm.tool.approach_axis)
    return d, approach / np.linalg.norm(approach)


def test_jaws_open_level_at_home(twin):
    """The jaws open across the approach axis along a level line with the arm at home: they
    close on objects standing on the table, so a claw pointing forward (sim.yaml's axis,
    the MeArm's) opens sideways, not up and down."""
    config, _, m = twin
    d, approach = _home_tool(m, config)
    left, right = (d.xaxis[m.joint(j).id] for j in jaw_joint_names(config.arm))
    for axis in (left, right):
        assert abs(axis[2]) < 1e-9 and abs(axis @ approach) < 1e-9
    np.testing.assert_allclose(right, -left, atol=1e-12)


def test_gripper_servo_lies_behind_the_jaws_shaft_along_the_approach(twin):
    """The gripper's servo case: shaft (its height) along the approach axis, its long side
    along the jaws' opening axis, wholly behind the TCP and the jaws' roots."""
    config, _, m = twin
    g = config.arm.tool.gripper
    d, approach = _home_tool(m, config)
    name = f"{g.name}_servo"
    R = d.geom(name).xmat.reshape(3, 3)
    length, _, high = (2 * s for s in m.geom(name).size)
    assert (length, high) == pytest.approx((SG90.size_m[0], SG90.size_m[2]))
    np.testing.assert_allclose(R[:, 2], approach, atol=1e-9)
    opening = d.xaxis[m.joint(jaw_joint_names(config.arm)[0]).id]
    assert abs(R[:, 0] @ opening) == pytest.approx(1.0, abs=1e-9)
    pad = pad_length_m(config)
    root = config.arm.tool.tcp_above_grip_cm * M_PER_CM + pad / 2 - g.jaw_length_cm * M_PER_CM
    front = float((d.geom(name).xpos - d.site("tcp").xpos) @ approach) + high / 2
    assert front == pytest.approx(min(0.0, root), abs=1e-9)


def test_a_planned_pick_puts_the_grip_point_at_the_grip_height(twin):
    """Where the planner sends the TCP to pick, the twin's grip point is at the class's
    grip height over the object (an arm whose jaws point down when it picks: along
    pick_approach, or held down by the arm's structure, as the paper arm's levelled wrist
    holds its jaws, on sim.yaml as on sim_mujoco.yaml since its arm file says so)."""
    config, _, m = twin
    model = ArmModel(config.arm)
    planner = Planner(config, model)
    obj = config.task.scene[0]
    cls = config.task.class_named(obj.color)
    result = planner.solver.solve(planner.pick_target(cls, obj.x, obj.y), model.home)
    assert result.converged
    if model.approach(result.q) @ np.array([0.0, 0.0, -1.0]) < np.cos(np.radians(1)):
        pytest.skip("the jaws do not point down at the pick (the MeArm v1's claw points ahead)")
    d = mujoco.MjData(m)
    _set_arm(m, d, config, result.q)
    grip = d.site("grip").xpos / M_PER_CM
    np.testing.assert_allclose(grip, (obj.x, obj.y, cls.grip_z_cm), atol=0.05)


def test_model_records_its_servos(twin):
    """The servos the model was built with are named in its <custom> texts."""
    config, xml, m = twin
    joint_servo = xml.split("Joint servos: ")[1].split(" ")[0]
    assert recorded_servo(m, JOINT_SERVO_TEXT) == joint_servo
    assert recorded_servo(m, GRIPPER_SERVO_TEXT) == GRIPPER_SERVO.name
    assert recorded_servo(m, "no_such_text") is None


def test_actuators_are_limited_servos(twin):
    """Each actuated joint: a position servo, ctrl range = limits, force range = stall.

    A servo that turns a combination of joints (the MeArm's elbow servo: shoulder +
    elbow) drives a fixed tendon with those coefficients; its ctrl range is what its
    pulse range allows within the joints' limits, and the motor's inertia is the tendon's.
    """
    config, _, m = twin
    model = ArmModel(config.arm)
    ch = model.chain
    for k, name in enumerate(ch.actuated):
        a = m.actuator(name)
        i = ch.actuated_index[k]
        servo = config.arm.joints[i].servo
        assert a.forcerange[1] > 0 and a.forcerange[0] == -a.forcerange[1]
        assert a.gainprm[0] > 0
        if servo.drives is None:
            np.testing.assert_allclose(a.ctrlrange, (ch.lower[i], ch.upper[i]))
            assert a.trntype == mujoco.mjtTrn.mjTRN_JOINT and m.joint(name).armature[0] > 0
            continue
        tendon = m.tendon(servo_tendon(name))
        assert a.trntype == mujoco.mjtTrn.mjTRN_TENDON and a.trnid[0] == tendon.id
        assert m.tendon_armature[tendon.id] > 0 and m.joint(name).armature[0] == 0
        wraps = range(m.tendon_adr[tendon.id], m.tendon_adr[tendon.id] + m.tendon_num[tendon.id])
        coef = {m.joint(int(m.wrap_objid[w])).name: float(m.wrap_prm[w]) for w in wraps}
        assert coef == pytest.approx(dict(servo.drives.terms))  # revolute joints: same units
        lo, hi = (math.radians(v - servo.drives.offset) for v in servo.value_range())
        assert lo - 1e-9 <= a.ctrlrange[0] < a.ctrlrange[1] <= hi + 1e-9


def test_explicit_servo_is_used(config):
    xml = generate_mjcf(config, servo=SG90)
    assert "Joint servos: SG90" in xml
    assert recorded_servo(mujoco.MjModel.from_xml_string(xml), JOINT_SERVO_TEXT) == "SG90"


@pytest.mark.parametrize(
    ("name", "joint", "gripper"),
    [("sim_mearm_v1_mujoco", "SG90", "SG90"), ("sim_mujoco", "RDS3135", "SG90")],
)
def test_the_config_names_the_servos(name, joint, gripper):
    """``twin.joint_servo`` / ``twin.gripper_servo`` pick the catalogue models, whose
    datasheet figures (stall torque) become the actuators' force limits."""
    config = load_config(ROOT / "configs" / f"{name}.yaml")
    m = twin_model(config)
    assert recorded_servo(m, JOINT_SERVO_TEXT) == joint
    assert recorded_servo(m, GRIPPER_SERVO_TEXT) == gripper
    stall = servo_named(joint).stall_torque_nm
    base = config.arm.actuated_joints()[0].name
    assert m.actuator(base).forcerange[1] == pytest.approx(stall)
    other = load_config(ROOT / "configs" / f"{name}.yaml", ["twin.joint_servo=MG996R"])
    m2 = twin_model(other)
    assert recorded_servo(m2, JOINT_SERVO_TEXT) == "MG996R"


@pytest.mark.bad_input
def test_an_unknown_servo_model_is_refused():
    out = check_bad_input(["sort", "--set", "twin.joint_servo=SG9O"])
    assert "twin.joint_servo" in out.line and "SG90, MG90S, MG996R, RDS3135" in out.line


# --------------------------------------------------------------------------- errors


def _with_scene(config: Config, scene: list[SceneObject]) -> Config:
    return config.model_copy(update={"task": config.task.model_copy(update={"scene": scene})})


def test_overlapping_objects_are_refused(config):
    scene = [SceneObject(color="red", x=0.0, y=40.0), SceneObject(color="red", x=1.0, y=40.0)]
    with pytest.raises(ModelError, match="red1 and red2 overlap"):
        generate_mjcf(_with_scene(config, scene))


def test_object_on_a_bin_is_refused(config):
    bx, by, _ = config.task.classes[1].bin_cm
    scene = [SceneObject(color="red", x=bx + 1.0, y=by)]
    with pytest.raises(ModelError, match="red1 .* lies on the bin of class green"):
        generate_mjcf(_with_scene(config, scene))


def test_object_on_the_base_is_refused(config):
    with pytest.raises(ModelError, match="stands on the arm's base"):
        generate_mjcf(_with_scene(config, [SceneObject(color="blue", x=1.0, y=1.0)]))


def test_bin_below_its_walls_is_refused(config):
    classes = [
        c.model_copy(update={"bin_cm": (c.bin_cm[0], c.bin_cm[1], 12.0)})
        for c in config.task.classes
    ]
    task = config.task.model_copy(update={"classes": classes})
    with pytest.raises(ModelError, match="class red: .* below the bin's .* raise bin_cm z"):
        generate_mjcf(config.model_copy(update={"task": task}))


def test_mirrored_calibration_is_refused(config):
    mirrored = ((0.0625, 0.0, -20.5), (0.0, 0.0625, 29.0), (0.0, 0.0, 1.0))
    calibration = config.calibration.model_copy(update={"homography": mirrored})
    with pytest.raises(ModelError, match="mirrored"):
        generate_mjcf(config.model_copy(update={"calibration": calibration}))


def test_sort_saves_the_scene_it_will_see_as_mjcf(tmp_path, capsys):
    """``mearm sort --save-mjcf PATH``: one self-contained file for MuJoCo's own viewer,
    holding the table the sort runs on (here a random one of 5 objects)."""
    from mearm.sort import main

    path = tmp_path / "scene.xml"
    assert main(["--quiet", "--random", "5", "--seed", "3", "--save-mjcf", str(path)]) == 0
    assert f"wrote {path}" in capsys.readouterr().out.splitlines()
    m = mujoco.MjModel.from_xml_path(str(path))
    bodies = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, i) for i in range(m.nbody)]
    assert sum(1 for b in bodies if b and b.startswith("obj_")) == 5


def test_the_twins_objects_start_at_their_scenes_yaw() -> None:
    """The keyframe every twin run starts from puts each object where and at the yaw its
    scene gives (it used to leave every object at yaw 0: cubes the scene turned 20°, 45°
    and 70° were sorted square to the jaws)."""
    config = load_config(ROOT / "configs" / "sim_shapes_mujoco.yaml")
    model = twin_model(config)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    yaws = [o.yaw_deg for o in config.task.scene]
    assert any(yaws)
    for obj, oid in zip(config.task.scene, object_ids(config), strict=True):
        body = data.body(f"obj_{oid}")
        yaw = math.degrees(2 * math.atan2(body.xquat[3], body.xquat[0]))
        assert abs((yaw - obj.yaw_deg + 180.0) % 360.0 - 180.0) < 1e-6, (oid, yaw, obj.yaw_deg)
        np.testing.assert_allclose(body.xpos[:2] * 100, (obj.x, obj.y), atol=1e-9)
