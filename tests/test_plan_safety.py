"""A route is planned in full before any of it is sent; a failed plan is a typed reason.

The sort runs on the simulated rig with its servo bus wrapped to record every command
(a bus spy) and the planner wrapped to record every route it planned, and the tests
check that no pose of a failed plan ever reached the bus.
"""

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import SceneObject, config_from_dict, load_config
from mearm.ik import FAILURE_KINDS, IKResult, IKTarget, PdPij
from mearm.kinematics import ArmModel
from mearm.task import Planner, Route, Sorter, open_rig
from mearm.task.timing import SpeedLimits


class SpySort:
    """Run a sort and keep every command the bus received and every route planned."""

    def __init__(self, config, scene, solver_wrapper=None):
        self.sent: list[np.ndarray] = []  # full joint vectors commanded, model units
        self.routes: list[Route] = []
        self.joint_moves: list[np.ndarray] = []  # the executor's own joint-space moves
        with open_rig(config, scene) as rig:
            chain = rig.model.chain
            move = rig.bus.move

            def spy_move(command):
                self.sent.append(chain.from_named(command.joints))
                move(command)

            rig.bus.move = spy_move  # every command the executor sends passes here
            sorter = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None)
            plan = sorter.planner.plan

            def spy_plan(route, q_start, **kwargs):
                self.routes.append(plan(route, q_start, **kwargs))
                return route

            sorter.planner.plan = spy_plan
            joint_path = sorter.executor.joint_path

            def spy_joint_path(q_to):
                path = joint_path(q_to)
                self.joint_moves.append(path)
                return path

            sorter.executor.joint_path = spy_joint_path  # the park at home, planned whole
            if solver_wrapper is not None:
                sorter.planner.solver = solver_wrapper(sorter.planner.solver, rig.model)
            self.report = sorter.run()
            self.world = rig.world
            self.model = rig.model
            self.config = config

    @property
    def failed(self) -> list[Route]:
        return [r for r in self.routes if not r.planned]

    def was_sent(self, q: np.ndarray) -> bool:
        return any(np.allclose(q, s, rtol=0, atol=1e-9) for s in self.sent)


def on_path(q, path, atol=1e-9):
    """Whether ``q`` lies on the polyline through the poses of ``path`` (k, n)."""
    path = np.asarray(path, dtype=float)
    if len(path) == 1:
        return bool(np.allclose(q, path[0], rtol=0, atol=atol))
    a, d = path[:-1], np.diff(path, axis=0)
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    t = np.clip(np.einsum("ij,ij->i", q - a, d) / dd, 0.0, 1.0)
    return bool(np.min(np.abs(a + t[:, None] * d - q).max(axis=1)) <= atol)


def assert_only_planned_poses_sent(spy):
    """Every command is home or a point of the path of a planned route (its start: a hold
    where the arm is) or of a planned joint-space move, as the executor samples it at the
    servo rate (:mod:`mearm.task.timing`); no pose of a failed plan (after its start,
    where the arm already is) was sent."""
    paths = [spy.model.home[None, :], *spy.joint_moves]
    paths += [r.plan.q_path for r in spy.routes if r.planned]
    for q in spy.sent:
        assert any(on_path(q, path) for path in paths)
    assert_no_step_outruns_a_servo(spy)


def assert_no_step_outruns_a_servo(spy):
    """Between two commands no actuated joint turns faster than its servo's speed limit
    (``seconds_per_60deg``): the stream the bus received, from the first command on."""
    chain, config = spy.model.chain, spy.config
    limits = SpeedLimits.of_arm(config.arm, chain)
    sent = chain.actuated_of(np.array(spy.sent))
    step = np.abs(np.diff(sent, axis=0))
    assert np.all(step <= limits.velocity / config.servo.rate_hz * (1 + 1e-9) + 1e-12)
    for r in spy.failed:
        assert r.failure and r.failure_kind in FAILURE_KINDS
        assert not r.executed
        if r.plan is not None:
            assert not any(spy.was_sent(q) for q in r.plan.q_path[1:]), r.failure


class StallNear:
    """A solver that stops short (20 updates, no recovery) on targets near ``xy``."""

    def __init__(self, xy):
        self.xy = np.asarray(xy, dtype=float)

    def __call__(self, solver, model):
        short = PdPij(model, solver.config.updated(max_iterations=20), recover=False)
        xy = self.xy

        class Wrapped:
            def solve(self, target, q_start=None):
                if np.hypot(*(IKTarget.of(target).position[:2] - xy)) < 1.0:
                    return short.solve(target, q_start)
                return solver.solve(target, q_start)

        return Wrapped()


def test_a_stalled_plan_is_never_sent(config):
    """A pick whose solve stops short is skipped as 'stalled'; none of its poses is sent,
    and the other objects are sorted."""
    scene = [
        SceneObject(color="red", x=-5.0, y=40.0),
        SceneObject(color="green", x=5.0, y=45.0),  # its pick stops short
        SceneObject(color="blue", x=0.0, y=50.0),
    ]
    spy = SpySort(config, scene, StallNear((5.0, 45.0)))
    stalled = [r for r in spy.failed if r.failure_kind == "stalled"]
    assert len(stalled) == 1 and stalled[0].step == "pick"
    assert stalled[0].plan is not None and len(stalled[0].plan.q_path) == 21
    assert "no plan: the solver reached its iteration cap" in stalled[0].failure
    assert_only_planned_poses_sent(spy)
    assert [o.bin for o in spy.world.objects] == ["red", None, "blue"]
    assert len(spy.sent) > 15  # the others were sorted: the spy saw the traffic


def test_unreachable_and_outside_box_plans_send_nothing(tmp_path):
    """Out of reach (a joint limit) and outside the box: typed reasons, nothing sent."""
    config = config_from_dict(
        {"calibration": {"homography": [[0.0625, 0, -20.5], [0, -0.0625, 64.0], [0, 0, 1]]}},
        overrides=["arm.joints.elbow.limits={min: -160, max: -85}"],
    )
    scene = [
        SceneObject(color="red", x=-5.0, y=40.0),
        SceneObject(color="green", x=0.0, y=57.0),  # needs elbow ≈ −80°
        SceneObject(color="blue", x=5.0, y=62.0),  # y > 60: outside the target box
    ]
    spy = SpySort(config, scene)
    kinds = {r.class_name: r.failure_kind for r in spy.failed}
    assert kinds == {"green": "limit", "blue": "outside_box"}
    assert all(r.plan is None for r in spy.failed)  # refused before any solve
    assert_only_planned_poses_sent(spy)
    assert [o.bin for o in spy.world.objects] == ["red", None, None]


def test_every_sent_pose_of_a_recovered_plan_is_within_limits(config):
    """A route the recovery planned (the arm starts against its limits) is sent whole,
    each pose within the limits."""
    model = ArmModel(config.arm)
    planner = Planner(config, model)
    q0 = model.chain.full(np.radians([159.61, 133.1, -20.09]))
    target = tuple(model.fk_cm(model.chain.full(np.radians([47.2, 85.2, -86.7]))))
    route = planner.plan(Route("", "", "home", 1, IKTarget(target)), q0)
    assert route.planned and route.failure_kind is None
    assert route.plan.method == "closed_form" and route.plan.recovered_from == "stalled"
    assert np.all(route.plan.q_path >= model.lower) and np.all(route.plan.q_path <= model.upper)


# --------------------------------------------------------------------------- kinds


@pytest.fixture(scope="module")
def mearm_v1():
    config = load_config(ROOT / "configs" / "sim_mearm_v1.yaml")
    model = ArmModel(config.arm)
    return Planner(config, model), model


def plan(planner, model, target, q_start=None):
    route = Route("", "", "pick", 1, IKTarget(target))
    return planner.plan(route, model.home if q_start is None else q_start)


@pytest.mark.parametrize(
    "target, kind, needle",
    [
        ((0.0, 30.0, 10.0), "outside_box", "y = 30 is outside the target box"),
        ((20.0, 20.0, 24.0), "unreachable", "out of reach"),
        ((0.0, 0.0, 10.0), "singular", "on the base axis"),
        ((-20.0, 5.0, 5.0), "limit", "needs base = 165.96 deg"),
    ],
)
def test_refused_targets_have_a_kind(mearm_v1, target, kind, needle):
    """Each refusal before any motion names its kind and says why."""
    planner, model = mearm_v1
    route = plan(planner, model, target)
    assert not route.planned and route.plan is None
    assert route.failure_kind == kind and needle in route.failure


def test_start_outside_the_limits_is_a_limit_failure(mearm_v1):
    planner, model = mearm_v1
    q0 = model.chain.full(np.radians([30.0, 90.0, -90.0]))  # base below its 45°
    route = plan(planner, model, (0.0, 15.0, 10.0), q0)
    assert route.failure_kind == "limit" and "base = 30" in route.failure


def test_a_plan_with_a_pose_outside_the_limits_is_refused(config):
    """The planner's last check: a converged plan with a pose off the limits is not sent."""
    model = ArmModel(config.arm)
    planner = Planner(config, model)
    good = planner.solver.solve((-10.99, 49.70, 12.76), model.home)
    q_path = np.array(good.q_path)
    q_path[5, 1] = model.upper[1] + 0.01  # the shoulder 0.6° past its limit
    bad = IKResult.from_paths(
        "converged", good.solver, good.target_cm, q_path, good.ee_path_cm.copy(),
        joint_names=good.joint_names, scale=good.scale,
    )  # fmt: skip

    class Fixed:
        def solve(self, q_start, target):
            return bad

    planner.solver = Fixed()
    route = plan(planner, model, (-10.99, 49.70, 12.76))
    assert not route.planned and route.failure_kind == "limit"
    assert "pose 5 of" in route.failure and "shoulder" in route.failure


@pytest.mark.heavy
def test_a_plan_past_a_combined_servos_pulse_range_is_refused_and_not_sent(monkeypatch):
    """The MeArm's elbow servo turns shoulder + elbow: a pick inside every joint's limits
    whose forearm would need a pulse past the servo's range is refused (``limit``, the
    servo named) before anything moves, and the sort goes on without it."""
    from mearm.hardware.mapping import ServoMap
    from mearm.sim.kinematic.servo_bus import SimArm
    from mearm.task.rig import run_sort

    config = load_config(ROOT / "configs" / "sim_mearm_v1.yaml")
    model = ArmModel(config.arm)
    route = Planner(config, model).plan(
        Route("", "red", "pick", 1, IKTarget((0.0, 12.0, 1.0))), model.home
    )
    assert route.failure_kind == "limit" and route.failure is not None
    assert "elbow's servo (shoulder + elbow)" in route.failure
    assert "pulse range" in route.failure
    sent: list[dict[str, float]] = []
    real_move = SimArm.move

    def spy(self: SimArm, command) -> None:
        sent.append(dict(command.joints))
        real_move(self, command)

    monkeypatch.setattr(SimArm, "move", spy)
    scene = [SceneObject(color="red", x=0.0, y=12.0), config.task.scene[0]]
    report = run_sort(config, scene=scene, echo=None)
    assert report.outcome.left == {"limit": 1} and report.outcome.n_sorted == 1
    smap = ServoMap.from_arm(config.arm)
    for joints in sent:  # every command sent was inside every servo's pulse range
        for name, value in smap.servo_values(joints).items():
            lo, hi = smap[name].pulse_limits
            assert lo - 1e-6 <= value <= hi + 1e-6


def test_a_solve_that_swings_a_combined_servo_past_its_range_becomes_a_joint_move():
    """PD-PIJ on the arm's own limits reaches this MeArm target, but its updates swing the
    elbow servo (shoulder + elbow) past its pulse range on the way: the plan is a straight
    joint-space move to the same solution, every pose inside the range (the servo's value
    is linear in the joints). The planner's own solver, on the limits the servos reach
    (``ArmDescription.within_servos``), keeps inside the range all the way."""
    from mearm.hardware.mapping import ServoMap
    from mearm.ik import make_solver

    config = load_config(ROOT / "configs" / "sim_mearm_v1_mujoco.yaml")
    model = ArmModel(config.arm)
    planner = Planner(config, model)
    start = np.array([2.1013, 0.8934, -2.1775, 1.2841])
    target = IKTarget((5.2439, 18.1416, 3.2690))
    smap = ServoMap.from_arm(config.arm)
    lo, hi = smap["elbow"].pulse_limits

    def elbow_servo(q_path: np.ndarray) -> np.ndarray:
        return np.array([smap.servo_values(model.chain.named_actuated(q))["elbow"] for q in q_path])

    own = planner.solver.solve(target, start)
    assert own.converged and np.all(
        (elbow_servo(own.q_path) >= lo - 1e-9) & (elbow_servo(own.q_path) <= hi + 1e-9)
    )
    planner.solver = make_solver(model, config.controller)  # the arm's own limits
    direct = planner.solver.solve(target, start)
    assert direct.converged and not np.all(
        (elbow_servo(direct.q_path) >= lo) & (elbow_servo(direct.q_path) <= hi)
    )
    route = planner.plan(Route("", "red", "pick", 1, target), start)
    assert route.planned and route.plan is not None and route.plan.method == "joint_move"
    values = elbow_servo(route.plan.q_path)
    assert np.all((values >= lo - 1e-9) & (values <= hi + 1e-9))
    np.testing.assert_allclose(route.plan.q, direct.q)
    assert np.linalg.norm(route.plan.ee_path_cm[-1] - target.position_cm) < 0.05
