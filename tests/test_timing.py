"""The streamed trajectory: within every servo's speed limit, on the planned path."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mearm.config import Config
from mearm.kinematics import Chain
from mearm.task.timing import MotionTime, SpeedLimits, time_path, tool_move_s
from mearm.tools.bench import PAPER_MOTION_S, BenchOptions, bench_motion

CONFIG = Config()
CHAIN = Chain.from_description(CONFIG.arm)


def arm_with(seconds_per_60deg, accel_deg_s2):
    """The default arm, each actuated joint's servo given its own speed and acceleration."""
    joints = []
    for j, s, a in zip(
        (j for j in CONFIG.arm.joints if j.servo is not None),
        seconds_per_60deg,
        accel_deg_s2,
        strict=True,
    ):
        servo = j.servo.model_copy(update={"seconds_per_60deg": s, "max_accel_deg_s2": a})
        joints.append(j.model_copy(update={"servo": servo}))
    by_name = {j.name: j for j in joints}
    return CONFIG.arm.model_copy(
        update={"joints": [by_name.get(j.name, j) for j in CONFIG.arm.joints]}
    )


def route(rng, k):
    """``k`` random poses within the limits, full joints, (k, n)."""
    lo, hi = CHAIN.actuated_lower, CHAIN.actuated_upper
    poses = [CHAIN.full(rng.uniform(lo, hi)) for _ in range(k)]
    return np.array([q for q in poses if CHAIN.within_limits(q)] or [CHAIN.home.copy()])


def distance_to_path(q, path):
    """The largest joint difference from ``q`` to the nearest point of the polyline."""
    a, d = path[:-1], np.diff(path, axis=0)
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    t = np.clip(np.einsum("ij,ij->i", q - a, d) / dd, 0.0, 1.0)
    return float(np.min(np.abs(a + t[:, None] * d - q).max(axis=1)))


speeds = st.lists(st.floats(0.03, 1.0), min_size=3, max_size=3)
accels = st.lists(st.one_of(st.none(), st.floats(100.0, 1e5)), min_size=3, max_size=3)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    k=st.integers(1, 40),
    seconds=speeds,
    accel=accels,
    rate_hz=st.sampled_from([10.0, 50.0, 333.0]),
)
@pytest.mark.heavy
def test_no_step_outruns_a_speed_limit(seed, k, seconds, accel, rate_hz):
    """No streamed step exceeds any servo's speed limit; every pose within the limits."""
    limits = SpeedLimits.of_arm(arm_with(seconds, accel), CHAIN)
    path = route(np.random.default_rng(seed), k)
    timed = time_path(path, CHAIN, limits, rate_hz)
    step = np.abs(np.diff(CHAIN.actuated_of(timed.q), axis=0))
    assert np.all(step <= limits.velocity / rate_hz * (1 + 1e-9) + 1e-12)
    assert all(CHAIN.within_limits(q, tol=1e-9) for q in timed.q)
    assert timed.duration_s == pytest.approx((len(timed.q) - 1) / rate_hz)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(2, 30), seconds=speeds, accel=accels)
@pytest.mark.heavy
def test_the_streamed_poses_follow_the_planned_path(seed, k, seconds, accel):
    """Every streamed pose lies on the planned polyline, from its start to its end."""
    limits = SpeedLimits.of_arm(arm_with(seconds, accel), CHAIN)
    path = route(np.random.default_rng(seed), k)
    timed = time_path(path, CHAIN, limits, 50.0)
    assert np.allclose(timed.q[0], path[0], atol=1e-12)
    assert np.allclose(timed.q[-1], path[-1], atol=1e-9)
    if len(path) > 1:
        assert max(distance_to_path(q, path) for q in timed.q) <= 1e-9


def test_full_speed_takes_the_slowest_joints_time():
    """Without an acceleration limit a straight move takes its slowest joint's time."""
    limits = SpeedLimits.of_arm(arm_with([0.10] * 3, [None] * 3), CHAIN)
    a0 = CHAIN.actuated_of(CHAIN.home.copy())
    a1 = a0 + np.deg2rad([30.0, -12.0, 6.0])
    timed = time_path([CHAIN.full(a0), CHAIN.full(a1)], CHAIN, limits, 50.0)
    assert timed.duration_s == pytest.approx(0.06)  # 30° at 600°/s (0.10 s/60°), 3 periods
    assert np.allclose(timed.q[-1], CHAIN.full(a1))


def test_a_path_outside_the_limits_is_refused():
    """A path leaving the joint limits is refused, naming the joints."""
    limits = SpeedLimits.of_arm(CONFIG.arm, CHAIN)
    q0 = CHAIN.home.copy()
    q1 = q0.copy()
    q1[CHAIN.actuated_index[0]] = CHAIN.upper[CHAIN.actuated_index[0]] + 0.5
    with pytest.raises(ValueError, match="leaves the limits at .*base"):
        time_path([q0, CHAIN.full(CHAIN.actuated_of(q1))], CHAIN, limits, 50.0)


def test_a_pose_held_takes_no_time():
    """A path that does not move streams nothing."""
    limits = SpeedLimits.of_arm(CONFIG.arm, CHAIN)
    q = CHAIN.home.copy()
    assert time_path([q, q], CHAIN, limits, 50.0).duration_s == 0.0


def test_a_tool_setting_takes_its_slowest_servo_and_the_settle_time():
    """The gripper's stroke at its speed, or the gripper arm's turn, plus the settle time."""
    tool = CONFIG.arm.tool
    arm = tool.actuators[0]
    travel = {arm.name: arm.travel}
    grip = {arm.name: arm.grip}
    stroke_s = (tool.gripper.open_cm - tool.gripper.closed_cm) / tool.gripper.servo.max_speed()
    turn_s = abs(arm.grip - arm.travel) / arm.servo.max_speed()
    assert tool_move_s(tool, grip, grip, before_closed=False, after_closed=True) == pytest.approx(
        stroke_s + tool.settle_s
    )
    assert tool_move_s(
        tool, travel, grip, before_closed=False, after_closed=False
    ) == pytest.approx(turn_s + tool.settle_s)
    assert tool_move_s(tool, grip, grip, before_closed=True, after_closed=True) == 0.0
    assert tool_move_s(tool, None, grip, before_closed=None, after_closed=True) == tool.settle_s


def test_the_motion_line_says_what_it_counts():
    """The summary line names the arm's speed limits, the rate and the tool settings."""
    line = MotionTime(50.0, arm_s=2.0, tool_s=3.5, tool_moves=14).line()
    assert line.startswith("motion 5.5 s")
    assert "speed limits" in line and "50 Hz" in line and "14 settings" in line
    assert "waiting" not in line
    waited = MotionTime(50.0, arm_s=2.0, tool_s=3.5, tool_moves=14, wait_s=0.5).line()
    assert waited.startswith("motion 6.0 s") and "0.5 s waiting for the measured joints" in waited


@pytest.mark.heavy
def test_the_paper_scene_moves_in_a_quarter_of_the_papers_time():
    """The bench's motion section: the paper's scene sorted in both orders, its predicted
    motion (speed limits, gripper settings, settling: deterministic, not a wall time)
    within a quarter of the paper's ≈ 144 s."""
    rows = {r.name: r for r in bench_motion(BenchOptions(repeat=1))}
    for label in ("the paper's colour order", "nearest object first"):
        row = rows[f"paper scene, {label}: motion"]
        assert "sorted 12 of 12" in row.note and "INCOMPLETE" not in row.note
        assert 0 < row.value <= PAPER_MOTION_S / 4
        assert rows[f"paper scene, {label}: ÷ the paper's ≈ 144 s"].value == pytest.approx(
            row.value / PAPER_MOTION_S
        )


def test_a_servo_over_a_combination_is_timed_on_its_own_value():
    """The MeArm v1's elbow servo turns shoulder + elbow: its speed limit holds for that sum.

    The shoulder and elbow turning 40° each the same way swing the forearm servo 80°, so
    the move takes that servo's time for 80°; turning opposite ways, the forearm servo
    stands still and the shoulder's own 40° sets the time.
    """
    from mearm.config import load_config  # noqa: PLC0415

    config = load_config("sim_mearm_v1")
    chain = Chain.from_description(config.arm)
    limits = SpeedLimits.of_arm(config.arm, chain)
    servo = {j.name: j.servo for j in config.arm.joints if j.servo is not None}
    sec = {n: s.seconds_per_60deg for n, s in servo.items()}
    home = chain.home.copy()
    rate = 1000.0
    durations = []
    for elbow_sign, forearm_deg in ((1, 80.0), (-1, 0.0)):
        a = dict(zip(chain.actuated, np.degrees(chain.actuated_of(home)), strict=True))
        a["shoulder"] -= 40
        a["elbow"] -= 40 * elbow_sign
        path = np.array([home, chain.from_named(a)])
        timed = time_path(path, chain, limits, rate)
        values = np.degrees(limits.values(chain.actuated_of(timed.q)))
        k = chain.actuated.index("elbow")
        assert abs(values[-1, k] - values[0, k]) == pytest.approx(forearm_deg, abs=1e-6)
        speed = np.array([60.0 / sec[n] for n in chain.actuated])  # each servo's [deg/s]
        rates = np.abs(np.diff(values, axis=0)) * rate
        assert np.all(rates <= speed * (1 + 1e-6))
        durations.append(timed.duration_s)
        if forearm_deg:  # timed joint by joint, the forearm servo would be outrun
            naive = time_path(path, chain, SpeedLimits(limits.velocity, limits.acceleration), rate)
            naive_rates = np.abs(np.diff(np.degrees(limits.values(chain.actuated_of(naive.q))),
                                         axis=0)) * rate  # fmt: skip
            assert naive_rates[:, k].max() > 1.5 * speed[k]
    assert durations[0] > 1.5 * durations[1]  # 80° of the forearm servo against 40°


class _Spy:
    """A view that records the joints it is shown."""

    def __init__(self) -> None:
        self.shown: list[np.ndarray] = []

    def show_joints(self, q, opening_cm=None) -> None:  # noqa: ANN001
        self.shown.append(np.array(q, dtype=float))

    def show_bodies(self, *args) -> None:  # noqa: ANN002
        raise AssertionError("the kinematic rig has no bodies to show")

    def set_target(self, target_cm) -> None:  # noqa: ANN001
        pass

    def add_path(self, ee_path_cm, color) -> object:  # noqa: ANN001
        return None

    def hold(self, held) -> None:  # noqa: ANN001
        pass


@pytest.mark.parametrize(("rate_hz", "every"), [(50.0, 1), (60.0, 1), (200.0, 4), (1000.0, 17)])
def test_the_view_is_shown_at_most_sixty_times_a_second_and_every_routes_end(rate_hz, every):
    """A fast stream shows the view every k-th move (k from VIEW_HZ) and always the last."""
    from mearm.kinematics import ArmModel  # noqa: PLC0415
    from mearm.sim import SimArm, World  # noqa: PLC0415
    from mearm.task.execute import VIEW_HZ, Executor  # noqa: PLC0415
    from mearm.task.plan import Planner  # noqa: PLC0415
    from mearm.task.route import Route  # noqa: PLC0415

    config = Config()
    config = config.model_copy(
        update={"servo": config.servo.model_copy(update={"rate_hz": rate_hz})}
    )
    model = ArmModel(config.arm)
    world = World.from_config(config)
    spy = _Spy()
    with SimArm(config, world) as bus:
        ex = Executor(config, bus, model, spy)
        assert ex.view_every == every and rate_hz / every <= VIEW_HZ
        planner = Planner(config, model)
        red = config.task.class_named("red")
        route = planner.plan(
            Route("", "red", "pick", 1, planner.pick_target(red, 0.0, 45.0)), model.home
        )
        assert route.planned and route.plan is not None
        sent = len(ex.timed(route.plan.q_path).q) - 1
        ex.stream(route, "travel", closed=False)
    assert len(spy.shown) == -(-sent // every)  # every k-th move, and the last if it was not
    np.testing.assert_allclose(spy.shown[-1], ex.q_now(), atol=1e-12)
