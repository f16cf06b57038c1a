"""The reach bound: it never calls a reachable target out of reach, and the solver's
answers with it are the full recovery's, status, joints and failure."""

import math

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import Config, load_config
from mearm.exceptions import MearmError
from mearm.ik import IKTarget, PdPij
from mearm.ik.reach import ReachBound
from mearm.ik.solver import APPROACH_TOLERANCE_DEG
from mearm.kinematics import ArmModel

#: (config, overrides): the paper arm and the MeArm v1 with their closed forms and
#: without (then PD-PIJ's multi-start is their recovery), and the 5-DOF arm.
ARMS = [
    ("sim.yaml", []),
    ("sim.yaml", ["arm.closed_form=null"]),
    ("sim_mearm_v1.yaml", []),
    ("sim_mearm_v1.yaml", ["arm.closed_form=null"]),
    ("sim_5dof.yaml", []),
]


def _arm(name: str, sets: list[str]):
    config = load_config(ROOT / "configs" / name, sets)
    return config, ArmModel(config.arm)


def _random_poses(model: ArmModel, rng: np.random.Generator, count: int, *, limits: bool):
    """Poses with the actuated joints drawn inside the limits (or over a whole turn)."""
    chain = model.chain
    lo, hi = chain.actuated_lower, chain.actuated_upper
    if not limits:
        lo, hi = np.full_like(lo, -math.pi), np.full_like(hi, math.pi)
    return [chain.full(rng.uniform(lo, hi)) for _ in range(count)]


def _just_within(
    config: Config, model: ArmModel, q: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Pose ``q``'s TCP moved by just under the solver's tolerance [m], and its approach
    turned by just under the approach tolerance about an axis across it."""
    tol_cm = 0.999 * math.sqrt(config.controller.tolerance_cm2)
    turn = math.radians(0.999 * APPROACH_TOLERANCE_DEG)
    p_cm, R = model.tcp_pose(q)
    a = R @ model.approach_axis
    way = rng.normal(size=3)
    target_m = (p_cm + tol_cm * way / np.linalg.norm(way)) / 100.0
    axis = np.cross(a, rng.normal(size=3))
    axis /= np.linalg.norm(axis)
    return target_m, a * math.cos(turn) + np.cross(axis, a) * math.sin(turn)


@pytest.mark.parametrize(("name", "sets"), ARMS)
def test_no_pose_is_beyond_reach_nor_a_target_within_the_tolerance_of_one(name, sets):
    """Every pose's TCP (limits ignored), moved by just under the tolerances, is not beyond."""
    config, model = _arm(name, sets)
    bound = ReachBound(model, config.controller.tolerance_cm2, APPROACH_TOLERANCE_DEG)
    assert bound.anchor_m is not None  # every arm here has a bound to test
    rng = np.random.default_rng(41)
    for q in _random_poses(model, rng, 400, limits=False):
        target_m, a_t = _just_within(config, model, q, rng)
        assert not bound.beyond(target_m.tolist(), tuple(a_t)), (q, target_m, a_t)
        assert not bound.beyond(target_m.tolist(), None), (q, target_m)


def _targets(model: ArmModel, rng: np.random.Generator) -> list[np.ndarray]:
    """Reachable targets (poses inside the limits) and the same pushed out from the base."""
    box = model.arm.target_box
    near = [model.fk_cm(q) for q in _random_poses(model, rng, 12, limits=True)]
    far = [p * s for p in near[:8] for s in (1.3, 2.0)]
    inside = [
        np.array([rng.uniform(r.min, r.max) for r in (box.x_cm, box.y_cm, box.z_cm)])
        for _ in range(10)
    ]
    return near + far + inside


def _answer(solver: PdPij, target: IKTarget, q0: np.ndarray):
    try:
        r = solver.solve(target, q0)
    except MearmError as e:
        return type(e).__name__, str(e)
    failure = None if r.failure is None else (r.failure.kind, r.failure.message)
    return r.status, r.method, r.recovered_from, r.q_path.tobytes(), failure


@pytest.mark.parametrize(("name", "sets"), ARMS)
def test_answers_are_the_full_recoverys_and_the_bound_cuts_only_failures(name, sets):
    """Against the same solver whose bound never answers: the same answer for each target
    (from home and from a pose against the limits); no target the recovery reaches is
    beyond, and some unreachable ones are."""
    config, model = _arm(name, sets)
    fast = PdPij(model, config.controller)
    full = PdPij(model, config.controller)
    full._reach.anchor_m = None  # the bound gives no answer: every recovery runs in full
    approach = config.arm.tool.pick_approach
    rng = np.random.default_rng(7)
    corner = model.chain.full(model.chain.actuated_lower + 1e-3)
    cut = 0
    for p in _targets(model, rng):
        target = IKTarget(tuple(float(v) for v in p), approach)
        for q0 in (model.home, corner):
            new, old = _answer(fast, target, q0), _answer(full, target, q0)
            assert new == old, (p, q0)
        beyond = fast._reach.beyond((p / 100.0).tolist(), target.approach)
        if old[0] == "converged":
            assert not beyond, p
        cut += beyond
    assert cut >= 4  # the bound answered for some: the test compares something


@pytest.mark.parametrize(("name", "sets"), ARMS)
def test_no_pose_within_the_limits_is_beyond_them_nor_a_target_within_the_tolerance(name, sets):
    """As above with the anchor joint's limits: every pose within them (a third with that
    joint at one of its limits, where the bound is tightest), moved by just under the
    tolerances, is not beyond; and the limits refuse targets the lengths alone do not."""
    config, model = _arm(name, sets)
    bound = ReachBound(model, config.controller.tolerance_cm2, APPROACH_TOLERANCE_DEG)
    rng = np.random.default_rng(43)
    chain = model.chain
    lo, hi = chain.actuated_lower, chain.actuated_upper
    second = list(chain.actuated_index).index(1) if 1 in chain.actuated_index else None
    for k in range(600):
        a_q = rng.uniform(lo, hi)
        if second is not None and k % 3:
            a_q[second] = (lo if k % 3 == 1 else hi)[second]
        q = chain.full(a_q)
        if not chain.within_limits(q, 1e-12):  # (a passive joint past its own)
            continue
        target_m, a_t = _just_within(config, model, q, rng)
        assert not bound.beyond_limits(target_m.tolist(), tuple(a_t)), (q, target_m, a_t)
        assert not bound.beyond_limits(target_m.tolist(), None), (q, target_m)
    if name == "sim_5dof.yaml":  # its shoulder may not turn below 15°: far out, low down
        down = config.arm.tool.pick_approach
        far = [[0.0, y / 100.0, 0.005] for y in np.arange(28.2, 29.8, 0.1)]
        assert not any(bound.beyond(t, down) for t in far)
        assert all(bound.beyond_limits(t, down) for t in far)
