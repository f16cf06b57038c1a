"""The twin's servo bus: pulses in, servo-limited physics out, the bus's contract kept."""

from __future__ import annotations

import math
import re
import time

import mujoco
import numpy as np
import pytest
from conftest import ROOT

from mearm.config import Config, load_config
from mearm.exceptions import (
    ModelError,
    ServoError,
    ServoFaultedError,
    ServoStallError,
    WorldError,
)
from mearm.hardware.bus import ArmCommand
from mearm.ik import IKTarget
from mearm.kinematics import ArmModel
from mearm.kinematics.bodies import object_name
from mearm.sim.kinematic.servo_bus import SimArm
from mearm.sim.kinematic.world import World
from mearm.sim.twin.mjcf import (
    JOINT_SERVO_TEXT,
    M_PER_CM,
    MG90S,
    MG996R,
    ServoSpec,
    generate_mjcf,
    twin_model,
)
from mearm.sim.twin.twin_bus import ARRIVED_SHAFT_DEG, BACKLASH_DEG, TwinArm
from mearm.task.plan import RETRY_LIFT_CM, Planner

#: Settling time after the last command of a route [s].
SETTLE_S = 0.5


@pytest.fixture(scope="module")
def paper() -> tuple[Config, mujoco.MjModel]:
    config = load_config(ROOT / "configs" / "sim.yaml")
    return config, twin_model(config)


@pytest.fixture(scope="module")
def desk() -> tuple[Config, mujoco.MjModel]:
    config = load_config(ROOT / "configs" / "sim_5dof.yaml")
    return config, twin_model(config)


def _twin(setup: tuple[Config, mujoco.MjModel]) -> TwinArm:
    config, m = setup
    arm = TwinArm(config, m)
    arm.connect()
    return arm


def _command(config: Config, joints: dict[str, float], closed: bool = False) -> ArmCommand:
    return ArmCommand(joints, {a.name: a.home for a in config.arm.tool.actuators}, closed)


def _stream(arm: TwinArm, q_path: np.ndarray, closed: bool = False) -> None:
    chain = ArmModel(arm.config.arm).chain
    for q in q_path[1:]:
        arm.move(_command(arm.config, chain.named_actuated(q), closed))


def _go(arm: TwinArm, planner: Planner, q: np.ndarray, target: IKTarget, closed: bool):
    """Plan from q to target, stream the route; returns the route's last pose."""
    result = planner.solver.solve(target, q)
    assert result.converged
    _stream(arm, result.q_path, closed)
    return result.q


def test_planned_route_ends_within_the_servo_budget(paper):
    """A PD-PIJ route ends within dead band + backlash + quantisation, the TCP at the FK."""
    config, _ = paper
    arm = _twin(paper)
    model = ArmModel(config.arm)
    planner = Planner(config, model)
    obj = config.task.scene[0]
    result = planner.solver.solve(
        planner.pick_target(config.task.class_named(obj.color), obj.x, obj.y), model.home
    )
    assert result.converged
    t0, sim0 = time.perf_counter(), arm.time_s
    _stream(arm, result.q_path)
    wall, sim = time.perf_counter() - t0, arm.time_s - sim0
    arm.settle(SETTLE_S)
    commanded = model.chain.named_actuated(result.q)
    errors = {n: arm.actual_joints[n] - v for n, v in commanded.items()}
    tcp_error_cm = float(np.linalg.norm(arm.ee_cm - model.fk_cm(result.q)))
    print(
        f"\nroute of {len(result.q_path) - 1} commands, {sim:.2f} s simulated in {wall:.3f} s "
        f"({sim / wall:.1f}x real time); joint errors [deg] "
        + " ".join(f"{n}={e:+.3f}" for n, e in errors.items())
        + f"; TCP {tcp_error_cm:.3f} cm from the FK of the command"
    )
    for s in arm.servos[:-1]:
        budget = (s.deadband + s.backlash) / s.scale + 0.5 / s.amap.us_per_unit
        assert abs(errors[s.name]) <= budget, (s.name, errors[s.name], budget)
    assert tcp_error_cm <= 0.3


def _step_of_first_servo(paper, degrees: float = 60.0):
    """A fresh twin, its first servo, and home with that servo's joint ``degrees`` lower."""
    config, _ = paper
    arm = _twin(paper)
    s = arm.servos[0]
    joints = config.arm.home()
    joints[s.name] -= degrees
    return config, arm, s, joints


def test_speed_limit_holds_on_a_big_step(paper):
    """A 60° step takes at least the datasheet's seconds per 60°."""
    config, arm, s, joints = _step_of_first_servo(paper)
    start = arm.time_s
    for _ in range(200):
        arm.move(_command(config, joints))
        if abs(arm.actual_joints[s.name] - joints[s.name]) < 0.5:
            break
    took = arm.time_s - start
    datasheet = math.radians(60.0) / s.speed
    print(f"\n60° on {s.name} in {took:.3f} s (datasheet {datasheet:.3f} s/60°)")
    assert abs(arm.actual_joints[s.name] - joints[s.name]) < 0.5
    assert took >= datasheet


def test_await_arrival_runs_on_until_a_lagging_joint_is_there(paper):
    """One 60° command: the servo needs its datasheet time; the wait runs on until it is there."""
    config, arm, s, joints = _step_of_first_servo(paper)
    arm.move(_command(config, joints))  # one period: the servo has barely started
    assert abs(arm.actual_joints[s.name] - joints[s.name]) > 30.0
    waited = arm.await_arrival(2.0)
    datasheet = math.radians(60.0) / s.speed
    assert waited >= datasheet - 2 * arm.period_s
    assert abs(arm.actual_joints[s.name] - joints[s.name]) <= ARRIVED_SHAFT_DEG
    assert arm.await_arrival(2.0) == 0.0  # there already: no wait


def test_await_arrival_times_out_and_faults_the_bus(paper):
    """Not there within the timeout: a named stall error, and the bus sends nothing more."""
    config, arm, s, joints = _step_of_first_servo(paper)
    name = s.name
    arm.move(_command(config, joints))
    with pytest.raises(ServoStallError, match=f"joint {name} did not arrive within") as info:
        arm.await_arrival(0.04)
    assert info.value.reason == "timeout" and info.value.joint == name
    assert arm.fault is info.value
    with pytest.raises(ServoFaultedError):
        arm.move(ArmCommand.home(config.arm))


def test_a_joint_too_weak_for_its_load_stalls(paper):
    """A shoulder servo with a hundredth of its torque comes to rest short: a stall fault."""
    config, m = paper
    weak = twin_model(config)
    weak.actuator("shoulder").forcerange[:] = m.actuator("shoulder").forcerange / 100
    arm = TwinArm(config, weak)
    arm.connect()
    arm.settle(1.0)  # it sags under its own weight
    joints = config.arm.home()
    joints["shoulder"] += 20.0  # lift: against gravity
    arm.move(_command(config, joints))
    with pytest.raises(ServoStallError, match="joint shoulder stalled") as info:
        arm.await_arrival(5.0)
    assert info.value.reason == "stalled"
    assert abs(info.value.measured - info.value.commanded) > 5.0


def test_a_bus_without_feedback_does_not_wait():
    """The kinematic sim (like a serial board) cannot measure its joints: no wait."""
    config = load_config(ROOT / "configs" / "sim.yaml")
    with SimArm(config, World.from_config(config)) as arm:
        arm.move(ArmCommand.home(config.arm))
        assert arm.await_arrival(2.0) == 0.0


def test_a_command_inside_the_dead_band_moves_nothing(paper):
    """A target within the dead band of the pot is ignored; one beyond it is followed."""
    config, _ = paper
    arm = _twin(paper)
    arm.move(ArmCommand.home(config.arm))
    arm.settle(SETTLE_S)
    s = arm.servos[0]
    inside = 1.0 / s.amap.us_per_unit  # one µs [deg]
    assert inside * s.scale < s.deadband
    before, setpoint = arm.actual_joints[s.name], arm.setpoint
    joints = config.arm.home()
    joints[s.name] += inside
    arm.move(_command(config, joints))
    arm.settle(SETTLE_S)
    assert arm.setpoint[0] == setpoint[0]
    assert abs(arm.actual_joints[s.name] - before) < 1e-6
    joints[s.name] += 2 * s.deadband / s.scale
    arm.move(_command(config, joints))
    arm.settle(SETTLE_S)
    assert arm.actual_joints[s.name] - before > s.deadband / s.scale


def test_backlash_lags_after_a_reversal(paper):
    """Approached from either side, a joint without gravity load ends half the play apart."""
    config, _ = paper
    s_name = config.arm.actuated_joints()[0].name
    ends = []
    for sign in (1.0, -1.0):
        arm = _twin(paper)
        joints = config.arm.home()
        joints[s_name] += 10.0 * sign
        arm.move(_command(config, joints))
        arm.settle(SETTLE_S)
        arm.move(ArmCommand.home(config.arm))
        arm.settle(SETTLE_S)
        ends.append(arm.actual_joints[s_name])
    np.testing.assert_allclose(ends[0] - ends[1], BACKLASH_DEG, atol=0.02)


def _stepwise(arm: TwinArm, n: int) -> np.ndarray:
    """The servo model's setpoints one step at a time (what ``TwinArm._ramp`` does at once)."""
    step = arm._speed * arm.model.opt.timestep
    motor, setpoint, rows = arm._motor.copy(), arm._setpoint.copy(), []
    for _ in range(n):
        gap = arm._target - motor
        motor = np.where(np.abs(gap) <= step, arm._target, motor + np.sign(gap) * step)
        setpoint = np.clip(setpoint, motor - arm._half_play, motor + arm._half_play)
        rows.append(setpoint)
    return np.array(rows)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_setpoint_ramp_is_the_step_by_step_servo_model(paper, seed):
    """The ramp computed for many steps at once equals the per-step recurrence bit for bit.

    Targets, motors and setpoints are drawn so that servos rise, fall, stand still, arrive
    mid-ramp and start inside their play after a reversal.
    """
    rng = np.random.default_rng(seed)
    arm = _twin(paper)
    nu = len(arm.servos)
    for _ in range(20):
        arm._motor = rng.uniform(-1.0, 1.0, nu)
        arm._target = np.where(rng.random(nu) < 0.2, arm._motor, rng.uniform(-1.0, 1.0, nu))
        arm._setpoint = arm._motor + rng.uniform(-0.5, 0.5, nu) * 2 * arm._half_play
        expected = _stepwise(arm, 400)
        ramp = arm._ramp(400)
        assert 1 <= len(ramp) <= 400
        np.testing.assert_array_equal(ramp, expected[: len(ramp)])
        if len(ramp) < 400:  # the motors are all there: the rest holds the last setpoint
            assert np.array_equal(arm._motor, arm._target)
            np.testing.assert_array_equal(expected[len(ramp) :], expected[len(ramp) - 1 :][:-1])


def test_a_still_arm_sleeps_skips_its_steps_and_wakes_on_a_command(paper):
    """Held still, the whole scene sleeps and a hold only advances the time (the state is
    the same to the bit); the next command wakes the arm and it moves."""
    config, _ = paper
    arm = _twin(paper)
    arm.settle(1.0)
    d = arm.data
    assert d.nv_awake == 0
    qpos, t0 = d.qpos.copy(), arm.time_s
    steps = d.timer[mujoco.mjtTimer.mjTIMER_STEP].number
    arm.settle(2.0)
    assert arm.time_s == pytest.approx(t0 + 2.0)
    assert d.timer[mujoco.mjtTimer.mjTIMER_STEP].number == steps  # no step was taken
    np.testing.assert_array_equal(d.qpos, qpos)
    name = config.arm.actuated_joints()[0].name
    joints = config.arm.home()
    joints[name] += 10.0
    arm.move(_command(config, joints))
    assert d.nv_awake > 0
    for _ in range(20):
        arm.move(_command(config, joints))
    assert arm.actual_joints[name] == pytest.approx(joints[name], abs=1.0)


def test_each_move_runs_one_command_period(paper):
    """100 moves run 100 command periods of physics (the speed is `mearm bench`'s)."""
    config, _ = paper
    arm = _twin(paper)
    name = config.arm.actuated_joints()[0].name
    t0, sim0 = time.perf_counter(), arm.time_s
    for k in range(100):
        joints = config.arm.home()
        joints[name] += 20.0 * math.sin(k / 10)
        arm.move(_command(config, joints))
    ratio = (arm.time_s - sim0) / (time.perf_counter() - t0)
    print(f"\ntwin: {arm.time_s - sim0:.2f} s of moves at {ratio:.1f}x real time")
    assert arm.time_s - sim0 == pytest.approx(100 * arm.period_s, rel=1e-6)


def test_stop_holds_the_current_setpoint(paper):
    """stop() mid-move holds the setpoint where the speed limit had brought it."""
    config, _ = paper
    arm = _twin(paper)
    joints = config.arm.home()
    name = config.arm.actuated_joints()[0].name
    joints[name] -= 60.0
    arm.move(_command(config, joints))
    arm.stop()
    held = arm.setpoint
    arm.settle(SETTLE_S)
    np.testing.assert_array_equal(arm.setpoint, held)
    assert abs(arm.actual_joints[name] - joints[name]) > 30.0
    assert arm.state is not None and arm.state.joints[name] == joints[name]


def test_stop_after_a_fault_sends_nothing(paper, tmp_path, monkeypatch):
    """A diverged twin faults the bus; stop() then moves nothing, move() refuses."""
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warning to MUJOCO_LOG.TXT here
    config, _ = paper
    arm = _twin(paper)
    arm.data.qvel[:] = np.nan
    with pytest.raises(ServoError, match="diverged"):
        arm.move(ArmCommand.home(config.arm))
    t, ctrl = arm.time_s, arm.data.ctrl.copy()
    arm.stop()
    assert arm.time_s == t
    np.testing.assert_array_equal(arm.data.ctrl, ctrl)
    with pytest.raises(ServoFaultedError):
        arm.move(ArmCommand.home(config.arm))


def test_objects_start_on_the_table(paper):
    """At the keyframe no object is in a bin and each rests where the scene puts it."""
    config, _ = paper
    arm = _twin(paper)
    arm.settle(0.2)
    assert arm.objects_in_bin() == {}
    pose = arm.object_pose("red1")
    obj = config.task.scene[0]
    np.testing.assert_allclose(pose.position_cm[:2], (obj.x, obj.y), atol=1e-3)
    assert pose.speed_cm_s < 0.01


def test_where_says_on_the_table_or_past_its_edge(paper):
    """An object where the scene put it is on the table; moved past the table's drawn edge
    (the plane goes on there, as no real table does) it is said to be past the edge."""
    config, _ = paper
    arm = _twin(paper)
    arm.settle(0.2)
    obj = config.task.scene[0]
    assert arm.where("red1") == f"is on the table at ({obj.x:.1f}, {obj.y:.1f}) cm"
    m, d = arm.model, arm.data
    table = m.geom("table")
    edge_x_cm = (m.geom_pos[table.id][0] + table.size[0]) / M_PER_CM
    qpos = m.jnt_qposadr[m.body(object_name("red1")).jntadr[0]]
    d.qpos[qpos] = (edge_x_cm + 10.0) * M_PER_CM
    mujoco.mj_forward(m, d)
    assert arm.where("red1") == (
        f"is past the table's edge, at ({edge_x_cm + 10.0:.1f}, {obj.y:.1f}) cm"
    )


def test_unknown_object_is_refused(paper):
    """object_pose of an unknown id names the twin's objects."""
    arm = _twin(paper)
    with pytest.raises(WorldError, match="its objects: red1"):
        arm.object_pose("purple9")


def test_model_of_another_arm_is_refused(paper, desk):
    """A model without this arm's actuators is refused, naming the fix."""
    config, _ = paper
    _, m = desk
    with pytest.raises(ModelError, match="twin_model"):
        TwinArm(config, m)


def test_unknown_servo_needs_to_be_named(paper):
    """A model whose servos are not in the catalogue needs servo=; with it, it builds."""
    config, _ = paper
    odd = ServoSpec("odd", 0.06, 3.0, 0.2, 4.0, (0.04, 0.02, 0.04), "test")
    m = twin_model(config, odd)
    with pytest.raises(ModelError, match="pass servo="):
        TwinArm(config, m)
    arm = TwinArm(config, m, servo=odd)
    assert arm.servos[0].deadband == pytest.approx(math.radians(0.4))


def test_a_model_records_its_servos_and_the_twin_reads_them(desk):
    """TwinArm takes the servos the model records, not a guess from torque and speed."""
    config, _ = desk
    m = twin_model(config, MG996R, gripper_servo=MG90S)
    arm = TwinArm(config, m)
    s, g = arm.servos[0], arm.servos[-1]
    assert s.speed == pytest.approx(MG996R.speed_rad_s)
    assert s.deadband == pytest.approx(MG996R.deadband_us / s.amap.us_per_unit * s.scale)
    assert g.deadband == pytest.approx(MG90S.deadband_us / g.amap.us_per_unit * g.scale)


def test_a_model_without_the_record_falls_back_to_matching(desk):
    """A model without the servo record (a foreign one) gets the catalogue servo it matches."""
    config, _ = desk
    xml = generate_mjcf(config, MG996R)
    foreign = re.sub(r"<custom>.*?</custom>", "", xml, flags=re.DOTALL)
    assert JOINT_SERVO_TEXT not in foreign
    arm = TwinArm(config, mujoco.MjModel.from_xml_string(foreign))
    assert arm.servos[0].speed == pytest.approx(MG996R.speed_rad_s)


def test_a_recorded_servo_outside_the_catalogue_is_refused(desk):
    """A record naming no catalogue servo is refused, naming the argument to pass."""
    config, _ = desk
    xml = generate_mjcf(config).replace('data="SG90"', 'data="XY123"')
    with pytest.raises(ModelError, match="gripper servo 'XY123' .* pass gripper_servo="):
        TwinArm(config, mujoco.MjModel.from_xml_string(xml))


@pytest.mark.heavy
def test_grasp_lifts_the_object_and_drops_it_in_its_bin(desk):
    """Pick at the planner's target, close, lift: the jaws stop on the object's diameter
    (within 0.3 mm), the object rises with them, then lands in its bin."""
    config, _ = desk
    arm = _twin(desk)
    model = ArmModel(config.arm)
    planner = Planner(config, model)
    obj = config.task.scene[0]
    cls = config.task.class_named(obj.color)
    pick = planner.pick_target(cls, obj.x, obj.y)
    q = _go(arm, planner, model.home, planner.lift_target(pick), closed=False)
    q = _go(arm, planner, q, pick, closed=False)
    arm.settle(0.2)
    grip_z_cm = float(arm.data.site("grip").xpos[2] / M_PER_CM)
    z0 = arm.object_pose("red1").position_cm[2]
    _stream(arm, np.array([q] * 26), closed=True)
    arm.settle(0.2)
    opening_cm = arm.opening_cm
    lift = planner.lift_target(pick)
    q = _go(arm, planner, q, lift, closed=True)
    rise_cm = arm.object_pose("red1").position_cm[2] - z0
    print(
        f"\ngrip point at z = {grip_z_cm:.3f} cm (class grip height {cls.grip_z_cm:g}); "
        f"closed on the {cls.diameter_cm:g} cm object at {opening_cm:.4f} cm; "
        f"lifted {rise_cm:.3f} of {RETRY_LIFT_CM:g} cm"
    )
    assert abs(grip_z_cm - cls.grip_z_cm) < 0.1  # within the servos' budget
    assert abs(opening_cm - cls.diameter_cm) <= 0.03
    assert rise_cm > 0.8 * RETRY_LIFT_CM
    q = _go(arm, planner, q, planner.place_target(cls), closed=True)
    arm.settle(0.2)
    _stream(arm, np.array([q] * 26), closed=False)
    arm.settle(1.0)
    assert arm.objects_in_bin() == {"red1": "red"}


# --------------------------------------------------------------------------- a servo over joints


@pytest.fixture(scope="module")
def mearm() -> tuple[Config, mujoco.MjModel]:
    config = load_config(ROOT / "configs" / "sim_mearm_v1_mujoco.yaml")
    return config, twin_model(config)


#: How far from its planned angle the forearm may settle [deg].
FOREARM_TOL_DEG = 0.5


@pytest.mark.parametrize("shoulder", [45.0, 135.0])
def test_the_mearm_elbow_servo_drives_the_forearm_whatever_the_shoulder(mearm, shoulder):
    """The MeArm v1 twin: the elbow servo turns shoulder + elbow through a tendon. With
    the shoulder at 45° and at 135° (far from the 90° where a per-joint map of the elbow
    would be right), the pulses sent for a planned pose — a joint-space path home → pose,
    timed as the sort times it — put the DH elbow joint, as MuJoCo measures it once
    settled, within 0.5° of the plan. The pose: the forearm at -45° or +45° to the table,
    the library's two calibration points (servo degrees 36 and 144)."""
    from mearm.task.execute import Executor

    config, m = mearm
    arm = _twin(mearm)
    model = ArmModel(config.arm)
    forearm = -45.0 if shoulder < 90 else 45.0
    planned = {"base": 90.0, "shoulder": shoulder, "elbow": forearm - shoulder}
    executor = Executor(config, arm, model)
    executor.home_pose()
    executor.move_joints(model.chain.from_named(planned), "home", closed=False)
    pulses = arm.servo_map.pulses_us(arm.state.to_command())
    elbow_servo = arm.servo_map["elbow"]
    assert pulses[elbow_servo.channel] == (915 if forearm < 0 else 2029)  # 36 / 144 servo °
    arm.settle(SETTLE_S)
    measured = arm.actual_joints
    elbow_error = measured["elbow"] - planned["elbow"]
    forearm_error = measured["shoulder"] + measured["elbow"] - forearm
    print(
        f"\nshoulder {shoulder:g}°: elbow {planned['elbow']:g}° planned, "
        f"{measured['elbow']:.3f}° measured ({elbow_error:+.3f}°); forearm to the table "
        f"{forearm_error:+.3f}°, shoulder {measured['shoulder'] - shoulder:+.3f}°"
    )
    assert abs(elbow_error) <= FOREARM_TOL_DEG
    # the forearm's angle to the table sums the shoulder's and the elbow's: each servo
    # settles within its own dead band under load (the shoulder +0.49° at 45° with the
    # joints' acceleration limit)
    assert abs(forearm_error) <= 2 * FOREARM_TOL_DEG
    # the servo's potentiometer reads the combination, where its actuator's tendon is
    k = [s.name for s in arm.servos].index("elbow")
    assert arm.servos[k].value_of(arm.pot[k]) == pytest.approx(
        measured["shoulder"] + measured["elbow"], abs=1e-9
    )


def test_a_bin_holds_an_object_too_slow_to_climb_its_walls(paper):
    """In a bin: inside its walls, below their top, and too slow to rise over them
    (v² < 2·g·(top − z)); a creeping object counts, one flying through does not."""
    config, m = paper
    arm = _twin(paper)
    bin_xy = np.array(config.task.class_named("red").bin_cm[:2]) * M_PER_CM
    joint = m.body("obj_red1").jntadr[0]
    qpos, qvel = m.jnt_qposadr[joint], m.jnt_dofadr[joint]
    arm.data.qpos[qpos : qpos + 3] = (*bin_xy, 0.01)  # on the bin's floor, not yet at rest
    for speed_m_s, held in ((0.02, True), (2.0, False)):
        arm.data.qvel[qvel : qvel + 3] = (0.0, 0.0, speed_m_s)
        mujoco.mj_forward(m, arm.data)
        assert ("red1" in arm.objects_in_bin()) is held, speed_m_s


def test_play_compensation_ends_a_reversal_where_commanded(paper):
    """With the servo's play in its calibration, both approaches end at the same angle.

    Without it they end the play apart (the test above); the bus sends each pulse half
    the play further the way it moved, so the lag on either side is taken up.
    """
    config, m = paper
    joint = config.arm.actuated_joints()[0]
    s_name = joint.name
    assert joint.servo is not None
    play_us = BACKLASH_DEG * joint.servo.us_per_unit
    compensated = load_config(
        ROOT / "configs" / "sim.yaml", overrides=[f"arm.joints.{s_name}.servo.play_us={play_us}"]
    )
    ends = []
    for sign in (1.0, -1.0):
        arm = TwinArm(compensated, m)
        arm.connect()
        joints = config.arm.home()
        joints[s_name] += 10.0 * sign
        arm.move(_command(config, joints))
        arm.settle(SETTLE_S)
        arm.move(ArmCommand.home(config.arm))
        arm.settle(SETTLE_S)
        ends.append(arm.actual_joints[s_name])
    # within the pulse's whole µs either way
    assert abs(ends[0] - ends[1]) < 0.25 * BACKLASH_DEG
    assert abs(np.mean(ends) - config.arm.home()[s_name]) < 0.25 * BACKLASH_DEG


def test_an_object_in_another_class_bin_is_not_counted_as_in_its_own(paper):
    """The sort's count of objects in their bins: an object the twin holds in another
    class's bin was counted as that class's (5-DOF perspective twin, seed 998026: a green
    in the blue bin; twin-scenes said "12 in their bins" of a sort that left it)."""
    from mearm.kinematics.bodies import object_name

    config, _ = paper
    arm = _twin(paper)

    def drop_into(object_id: str, cls_name: str) -> None:
        x, y = config.task.class_named(cls_name).bin_cm[:2]
        body = arm.model.body(object_name(object_id))
        adr = arm.model.jnt_qposadr[body.jntadr[0]]
        arm.data.qpos[adr : adr + 3] = (x * M_PER_CM, y * M_PER_CM, 0.03)
        arm.data.qvel[arm.model.jnt_dofadr[body.jntadr[0]] :][:6] = 0.0

    drop_into("red1", "red")
    drop_into("green1", "red")
    mujoco.mj_forward(arm.model, arm.data)  # placed at rest, 3 cm up, inside the walls
    assert arm.objects_in_bin() == {"red1": "red", "green1": "red"}
    assert arm.in_bin_counts() == {"red": 1, "green": 0, "blue": 0}


class _IntoTheWrongBin:
    """Every 20 ms of the twin's time: the first object of class ``fell`` to lie in its own
    bin is moved into class ``into``'s bin, 2 cm over the highest object there, at rest."""

    def __init__(self, bus: TwinArm, fell: str, into: str):
        colors = [o.color for o in bus.config.task.scene]  # its objects first, then the belt's
        self.classes = dict(zip(bus.object_ids[: len(colors)], colors, strict=True))
        self.fell, self.into = fell, into
        self.moved: str | None = None
        self._due = 0.0

    @property
    def due_s(self) -> float:
        return self._due

    def sample(self, bus: TwinArm) -> None:
        from mearm.kinematics.bodies import object_name

        self._due = bus.time_s + 0.02
        if self.moved is not None:
            return
        in_bins = bus.objects_in_bin()
        mine = [o for o, c in in_bins.items() if c == self.fell == self.classes[o]]
        if not mine:
            return
        there = [bus.object_pose(o).position_cm[2] for o, c in in_bins.items() if c == self.into]
        cls = bus.config.task.class_named(self.into)
        top_cm = max(there, default=0.0) + cls.height_cm
        m, d = bus.model, bus.data
        joint = m.body(object_name(mine[0])).jntadr[0]
        adr, dof = m.jnt_qposadr[joint], m.jnt_dofadr[joint]
        d.qpos[adr : adr + 3] = [*(np.array(cls.bin_cm[:2]) * M_PER_CM), (top_cm + 2) * M_PER_CM]
        d.qvel[dof : dof + 6] = 0.0
        mujoco.mj_forward(m, d)
        self.moved = mine[0]


@pytest.mark.heavy
def test_a_green_dropped_into_the_blue_bin_is_left_not_counted_in_its_bin():
    """The 5-DOF perspective twin, seed 998026: green2 ended in the blue bin. The sort
    left it, not confirmed in its bin; the twin's count said all 12 lay in their bins.
    Since the table has rolling friction (2026-12-01) no green falls there (seeds
    998000-998199 searched): the first green released into its bin is moved into the
    blue bin as that one fell, and the sort and the twin's count both leave it. One
    object per class: the move, not the seed's table, is the scenario now. Since
    2026-12-07 the place reads where the green went once the jaws opened: it fails,
    saying so, and the sort leaves the green as no longer on the table, where it had
    printed the place ``ok`` and left the green not confirmed in its bin."""
    from mearm.maker.camera_calibration.at_start import for_config
    from mearm.task.rig import run_sort
    from mearm.task.scene import random_scene

    twin = load_config(ROOT / "configs" / "sim_5dof_mujoco_perspective.yaml")
    moves: list[_IntoTheWrongBin] = []

    def move_a_green(rig) -> None:
        assert isinstance(rig.bus, TwinArm)
        rig.bus.sampler = _IntoTheWrongBin(rig.bus, "green", "blue")
        moves.append(rig.bus.sampler)

    scene = random_scene(twin, 3, seed=998026)
    report = run_sort(
        twin, scene=scene, echo=None, calibrate_first=for_config(twin), on_open=move_a_green
    )
    out = report.outcome
    assert moves[0].moved is not None
    assert (out.n_objects, sum(out.seen.values()), out.n_sorted) == (3, 3, 2), out.left
    assert dict(out.left) == {"off_table": 1}
    (place,) = (r for r in report.routes if r.object_id == moves[0].moved and r.step == "place")
    assert place.why_failed == "released, it fell into the blue bin"
    assert sum(out.in_bins.values()) == 2
