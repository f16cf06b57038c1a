"""PD-PIJ's recovery when it stops short, and the typed reasons when nothing reaches."""

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.exceptions import JointLimitError, TargetOutsideBoxError, UnreachableTargetError
from mearm.ik import IKFailure, IKTarget, PdPij, failure_of_error, recovery
from mearm.ik.bounded import bounded_lstsq
from mearm.ik.failure import blocking_joints
from mearm.kinematics import ArmModel
from mearm.kinematics.closed_form import JointLimitTargetError, SingularTargetError

#: The arm leaning back against three limits; the target in front of it. PD-PIJ with
#: the safeguard walks into the corner (base 160°, shoulder 135°, elbow −20°) and stops.
CORNER_START_DEG = (159.61, 133.1, -20.09)
CORNER_TARGET_Q_DEG = (47.2, 85.2, -86.7)


@pytest.fixture(scope="module")
def model(config):
    return ArmModel(config.arm)


@pytest.fixture(scope="module")
def corner(model):
    q0 = model.chain.full(np.radians(CORNER_START_DEG))
    target = tuple(model.fk_cm(model.chain.full(np.radians(CORNER_TARGET_Q_DEG))))
    return target, q0


def test_pd_pij_alone_stalls_in_the_corner(model, config, corner):
    """Without the recovery: stalled against the limits, a 'limit' failure naming them."""
    result = PdPij(model, config.controller, recover=False).solve(*corner)
    assert result.status == "stalled" and result.method == "direct"
    assert result.final_error_cm > 40
    assert result.failure.kind == "limit"
    message = result.failure.message
    assert message.startswith("the solver stalled ") and "base at 160 deg" in message
    assert "shoulder at 135 deg" in message


def test_closed_form_recovery_reaches_the_target(model, config, corner):
    """The default solver: a joint-space move to the closed-form solution, converged."""
    target, q0 = corner
    result = PdPij(model, config.controller).solve(target, q0)
    assert result.converged and result.failure is None
    assert result.method == "closed_form" and result.recovered_from == "stalled"
    assert result.final_error_cm**2 < config.controller.tolerance_cm2
    np.testing.assert_array_equal(result.q_path[0], q0)
    assert result.iterations == len(result.q_path) - 1
    assert result.search_iterations >= 1  # the discarded attempt, counted apart
    assert np.all(result.q_path >= model.lower) and np.all(result.q_path <= model.upper)
    assert np.abs(result.q_path[:, 1:].sum(axis=1)).max() < 1e-12  # wrist coupling
    # every joint moves one way, at the PD loop's pace: the first step kp of the way
    a = model.chain.actuated_of(result.q_path)
    way = model.chain.actuated_of(model.chain.full(np.radians(CORNER_TARGET_Q_DEG))) - a[0]
    np.testing.assert_allclose(a[1] - a[0], config.controller.kp * way, atol=1e-9)
    assert np.all(np.diff(a, axis=0) * np.sign(way) >= 0)
    summary = result.summary()
    assert summary["method"] == "closed_form" and summary["failure_kind"] is None


def test_recovery_follows_the_safeguard_switch(model, config, corner):
    """safeguard: false is the bare paper algorithm: no recovery unless asked for."""
    bare = config.controller.updated(safeguard=False)
    assert PdPij(model, bare).recover is False
    assert PdPij(model, config.controller).recover is True
    assert PdPij(model, bare, recover=True).recover is True


def test_converged_solves_are_untouched(model, config):
    """A solve PD-PIJ converges on by itself is its own path: no search, no recovery."""
    result = PdPij(model, config.controller).solve((-10.99, 49.70, 12.76), model.home)
    assert result.iterations == 62 and result.method == "direct"
    assert result.search_iterations == 0 and result.recovered_from is None


def test_recovered_path_stays_above_the_floor():
    """Where the straight joint-space move would swing the TCP below the target box's
    bottom, the recovery goes through home and stays above it."""
    config = load_config(ROOT / "configs" / "sim_mearm_v1.yaml")
    model = ArmModel(config.arm)
    solver = PdPij(model, config.controller)
    q0 = model.chain.full(np.radians([56.4, 10.5, -149.9]))
    target = (-14.18, 14.35, 1.09)
    result = solver.solve(target, q0)
    assert result.converged and result.method == "closed_form"
    floor = config.arm.target_box.z_cm.min
    assert result.ee_path_cm[:, 2].min() >= floor
    # the straight move to the same solution dips below it
    measure = solver._met((np.array(target) / 100).tolist(), None)
    cfg = config.controller
    straight = recovery.joint_path(
        model.chain, q0, solver.closed_form.solve(target), measure,
        kp=cfg.kp, kd=cfg.kd, max_steps=cfg.max_iterations,
    )  # fmt: skip
    assert straight is not None and min(p[2] for p in straight[1]) * 100 < floor - 1.0


@pytest.fixture(scope="module")
def desk():
    config = load_config(ROOT / "configs" / "sim_5dof.yaml")
    return config, ArmModel(config.arm)


def test_multi_start_for_an_arm_without_closed_form(desk):
    """The 5-DOF arm (no closed form): after a stall, a solution from another start."""
    config, model = desk
    chain = model.chain
    q0 = chain.from_named(
        {"base_yaw": 0.0, "shoulder": 110.0, "elbow": -50.0, "wrist_pitch": 60.0,
         "wrist_roll": -40.0}
    )  # fmt: skip
    target = IKTarget((-9.0, 21.0, 3.0), (0.0, 0.0, -1.0))  # a pick from above
    alone = PdPij(model, config.controller, recover=False).solve(target, q0)
    assert alone.status == "stalled" and alone.failure.kind == "limit"
    result = PdPij(model, config.controller).solve(target, q0)
    assert result.converged and result.method == "multi_start"
    assert result.recovered_from == alone.status
    assert result.search_iterations > alone.iterations  # the attempt and the seeds
    assert result.final_approach_error_deg < 0.5
    assert np.all(result.q_path >= model.lower) and np.all(result.q_path <= model.upper)
    again = PdPij(model, config.controller).solve(target, q0)
    np.testing.assert_array_equal(again.q_path, result.q_path)  # seeded: reproducible


#: 5-DOF starts and goals (deg) from fresh random draws where every move to a solution,
#: straight or through home, dipped below the target box's bottom (0.3 cm): the arm
#: folded 4 mm over the table (it swings through it on its way home unless the shoulder
#: lifts first), and goals 4–5 mm above the table (reached only by lowering one joint
#: last).
LOW_CASES_DEG = [
    ([174.9, 35.5, -159.5, 62.5, -33.3], [75.2, 35.1, -137.5, -76.5, -13.2]),
    ([179.9, 54.4, -113.3, -89.5, 0.9], [60.6, 20.0, -159.5, 89.7, -75.3]),
    ([179.6, 61.6, -69.4, -89.7, 28.8], [6.1, 19.3, -159.7, 89.6, -85.2]),
]


@pytest.mark.parametrize("start_deg, goal_deg", LOW_CASES_DEG, ids=["folded", "low1", "low2"])
def test_one_joint_first_or_last_keeps_the_move_above_the_table(desk, start_deg, goal_deg):
    """Moves through home with one joint alone moved first (lifting) or last (lowering)
    reach what the straight and through-home moves refused, above the floor, within the
    limits."""
    config, model = desk
    chain = model.chain
    q0, q_goal = chain.full(np.radians(start_deg)), chain.full(np.radians(goal_deg))
    target = IKTarget(tuple(model.fk_cm(q_goal)), tuple(model.approach(q_goal)))
    floor = min(config.arm.target_box.z_cm.min, model.fk_cm(q0)[2], target.position_cm[2])
    result = PdPij(model, config.controller).solve(target, q0)
    assert result.converged and result.method == "multi_start", result.failure
    assert result.ee_path_cm[:, 2].min() >= floor - 1e-7
    assert np.all(result.q_path >= model.lower) and np.all(result.q_path <= model.upper)
    # the moves the recovery tried before: straight, and through home, each dip below
    measure = PdPij(model, config.controller)._met(
        (np.array(target.position_cm) / 100).tolist(), target.approach
    )
    cfg = config.controller
    for vias in ([], [model.home]):
        move = recovery.path_via(
            chain, q0, vias, result.q, measure,
            kp=cfg.kp, kd=cfg.kd, max_steps=cfg.max_iterations,
        )  # fmt: skip
        assert move is None or min(p[2] for p in move[1]) * 100 < floor


def test_unreachable_target_without_closed_form_fails_with_a_reason(desk):
    """Nothing converges from any start: PD-PIJ's own record, with its failure kind."""
    config, model = desk
    result = PdPij(model, config.controller).solve((0.0, 35.0, 35.0), model.home)
    assert not result.converged and result.method == "direct"
    assert result.failure.kind in ("stalled", "limit", "singular")
    assert result.failure.message.startswith("the solver stalled")
    assert result.search_iterations > 0


# --------------------------------------------------------------------------- pieces


def test_pd_fractions_fall_as_the_pd_loop():
    """ε: 1 − kp first, then ε − kp·ε − kd·Δε; non-increasing; ends exactly at 0."""
    eps = list(recovery.pd_fractions(0.1, 0.01))
    assert eps[0] == pytest.approx(0.9) and eps[1] == pytest.approx(0.9 - 0.09 + 0.001)
    assert all(b <= a for a, b in zip(eps, eps[1:], strict=False)) and eps[-1] == 0.0
    overshooting = list(recovery.pd_fractions(0.5, 0.7))  # complex roots: clipped at 0
    assert min(overshooting) == 0.0 and overshooting[-1] == 0.0


def test_seeds_are_inside_the_limits_and_reproducible(desk):
    _, model = desk
    chain = model.chain
    a = list(recovery.seeds(chain, 20))
    b = list(recovery.seeds(chain, 20))
    assert len(a) == 20 and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    for q in a:
        assert chain.within_limits(q, 0.0)


def test_blocking_joints_kinds(model):
    """Error orthogonal to every joint's motion: singular; pushing only into limits: limit."""
    chain = model.chain
    J = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
    mid = chain.full(0.5 * (chain.actuated_lower + chain.actuated_upper))
    assert blocking_joints(J, np.array([0.0, 0.0, 1.0]), mid, chain) == ("singular", [])
    assert blocking_joints(J, np.array([1.0, 0.0, 0.0]), mid, chain)[0] == "stalled"
    on_upper = chain.full(chain.actuated_upper)
    assert blocking_joints(J, np.array([1.0, 1.0, 0.0]), on_upper, chain) == ("limit", [0, 1])


@pytest.mark.parametrize(
    "error, kind",
    [
        (TargetOutsideBoxError((0, 70, 0), "y", (20, 60)), "outside_box"),
        (UnreachableTargetError((0, 70, 0), "out of reach"), "unreachable"),
        (JointLimitTargetError((0, 70, 0), "elbow", -10.0, -160.0, -20.0), "limit"),
        (SingularTargetError((0, 0, 30), "on the base axis"), "singular"),
        (JointLimitError("base", 10.0, 20.0, 160.0), "limit"),
    ],
)
def test_failure_of_error(error, kind):
    failure = failure_of_error(error)
    assert isinstance(failure, IKFailure) and failure.kind == kind and failure.message


def test_bounded_lstsq_leaves_a_dead_variable_at_zero():
    """A variable whose column is zero (a wrist roll under a position target) fits as
    well anywhere: the least-norm answer leaves it at 0, not on a bound."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        A = rng.normal(size=(3, 5))
        A[:, 4] = 0.0
        x = bounded_lstsq(A, 3 * rng.normal(size=3), -rng.random(5), rng.random(5))
        assert x[4] == 0.0


def test_joint_path_refuses_a_goal_that_is_not_a_solution(model, config):
    """Aiming at a pose that misses the target gives no path, not a false arrival."""
    target = (np.array([-10.99, 49.70, 12.76]) / 100).tolist()
    solver = PdPij(model, config.controller)
    cfg = config.controller
    not_a_solution = model.chain.full(np.radians([100.0, 80.0, -100.0]))
    path = recovery.joint_path(
        model.chain, model.home, not_a_solution, solver._met(target, None),
        kp=cfg.kp, kd=cfg.kd, max_steps=cfg.max_iterations,
    )  # fmt: skip
    assert path is None
    waypoint = recovery.joint_path(
        model.chain, model.home, not_a_solution, solver._met(target, None),
        kp=cfg.kp, kd=cfg.kd, max_steps=cfg.max_iterations, end_share=0.01,
    )  # fmt: skip
    shares = list(recovery.pd_fractions(cfg.kp, cfg.kd))
    assert (
        waypoint is not None and shares[len(waypoint[0]) - 1] <= 0.01 < shares[len(waypoint[0]) - 2]
    )
