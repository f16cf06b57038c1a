"""IK that never stalls: the default solver reaches every reachable target (issue 12, item 5).

Targets are the TCP of random joint configurations within the limits (so reachable by
construction), a quarter of the joints within 0.5° of a limit, kept when inside the
target box. Starts cycle through the poses a sort starts from: home, where the previous
solve ended, and random poses — uniform, or with half the joints within 0.5° of a limit —
whose TCP is above the target box's bottom (an arm is not folded into its table).
"""

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import Config, load_config
from mearm.ik import IKTarget, make_solver
from mearm.kinematics import ArmModel

#: Within this of a limit a joint is "limit-adjacent" [deg].
ADJACENT_DEG = 0.5


def random_joints(rng, chain, p_adjacent):
    """Actuated joints (m,) uniform in their limits; each, with ``p_adjacent``, within
    :data:`ADJACENT_DEG` of one of its limits."""
    lo, hi = chain.actuated_lower, chain.actuated_upper
    q = rng.uniform(lo, hi)
    near = rng.random(chain.m) < p_adjacent
    offset = rng.uniform(0.0, np.radians(ADJACENT_DEG), chain.m)
    at_lower = rng.random(chain.m) < 0.5
    return np.where(near, np.where(at_lower, lo + offset, hi - offset), q)


def reachable_targets(config, model, n, rng):
    """``n`` reachable targets in the box: (pose (n,), IKTarget) pairs."""
    chain, box = model.chain, config.arm.target_box
    with_approach = config.arm.tool.pick_approach is not None
    out = []
    while len(out) < n:
        q = chain.full(random_joints(rng, chain, 0.25))
        x, y, z = (float(v) for v in model.fk_cm(q))
        if box.x_cm.contains(x) and box.y_cm.contains(y) and box.z_cm.contains(z):
            approach = tuple(float(v) for v in model.approach(q)) if with_approach else None
            out.append((q, IKTarget((x, y, z), approach)))
    return out


def random_start(rng, config, model, p_adjacent):
    """A random start whose TCP is at or above the target box's bottom."""
    floor = config.arm.target_box.z_cm.min
    while True:
        q = model.chain.full(random_joints(rng, model.chain, p_adjacent))
        if model.fk_cm(q)[2] >= floor:
            return q


def run_stall_test(config, n, seed=12):
    """Solve ``n`` targets with the default solver; return the stalls, the limit
    violations and how many solves the recovery made."""
    model = ArmModel(config.arm)
    chain = model.chain
    solver = make_solver(model, config.controller)
    rng = np.random.default_rng(seed)
    lower, upper = chain.lower, chain.upper
    tol = config.controller.tolerance_cm2
    stalls, violations, recovered = [], [], 0
    q_prev = model.home
    for k, (_, target) in enumerate(reachable_targets(config, model, n, rng)):
        kind = k % 4
        if kind == 0:
            q0 = model.home
        elif kind == 1:
            q0 = q_prev
        else:
            q0 = random_start(rng, config, model, 0.0 if kind == 2 else 0.5)
        result = solver.solve(target, q0)
        if not result.converged or not result.final_error_cm**2 < tol:
            stalls.append((k, target.position_cm, result.status, result.failure))
        path = result.q_path
        coupled = chain.actuated_of(path) @ chain.C.T + chain.c
        within = np.all(path >= lower) and np.all(path <= upper)
        moved_start = np.abs(path[0] - q0).max() > 1e-12
        if not within or np.abs(path - coupled).max() > 1e-9 or moved_start:
            violations.append(k)
        recovered += result.method != "direct"
        q_prev = result.q
    return stalls, violations, recovered


@pytest.mark.slow
def test_default_solver_never_stalls_on_1000_targets():
    """The paper arm, 1,000 reachable targets: 0 stalls, 0 poses outside the limits or off
    the coupling. Each kind of start (home, the previous solve's end, uniform, limit-
    adjacent) 250 times and the recovery about 18 times, so a solver or recovery that
    breaks on a kind of start, or a path that leaves the limits, fails here; stalls rarer
    than one target in a thousand are the soak's (the 20,000 below, `make soak`)."""
    stalls, violations, recovered = run_stall_test(Config(), 1_000, seed=12)
    assert stalls == [] and violations == []
    assert recovered > 5  # PD-PIJ alone stalls on a few percent: the recovery ran


@pytest.mark.soak
@pytest.mark.parametrize("part", range(4))
def test_default_solver_never_stalls_on_20000_targets(part):
    """The paper arm, 20,000 reachable targets (limit-adjacent ones included) in four
    parts of 5,000, each from a seed of its own: 0 stalls, 0 poses outside the limits or
    off the coupling."""
    stalls, violations, recovered = run_stall_test(Config(), 5_000, seed=12 + part)
    assert stalls == [] and violations == []
    assert recovered > 25  # PD-PIJ alone stalls on a few percent: the recovery ran


@pytest.mark.heavy
def test_mearm_v1_never_stalls():
    """The MeArm v1 kit (another closed-form arm), 1,000 targets: 0 stalls, 0 violations."""
    config = load_config(ROOT / "configs" / "sim_mearm_v1.yaml")
    stalls, violations, recovered = run_stall_test(config, 1000)
    assert stalls == [] and violations == []
    assert recovered > 0


@pytest.mark.slow
def test_generic_arm_without_closed_form_never_stalls():
    """The 5-DOF desk arm (no closed form: multi-start), 800 targets, each with the
    approach of the pose it came from: 0 stalls, 0 limit violations. Fewer targets than
    for the paper arm: here PD-PIJ alone stops short on about one solve in nine (one in
    three from limit-adjacent starts), and a solve costs a few milliseconds (six-row
    Jacobian, bounded steps, the seeds)."""
    config = load_config(ROOT / "configs" / "sim_5dof.yaml")
    stalls, violations, recovered = run_stall_test(config, 800)
    assert stalls == [] and violations == []
    assert recovered > 40
