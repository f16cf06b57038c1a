"""The fast solves (closed form, generic Gauss–Newton) and the bench's peer plumbing."""

import math

import numpy as np
import pytest

from mearm.config import Config, config_from_dict, load_config
from mearm.exceptions import (
    InvalidTargetError,
    JointLimitTargetError,
    ModelError,
    SingularTargetError,
    TargetOutsideBoxError,
    UnreachableTargetError,
)
from mearm.ik import AnalyticSolver, IKResult, NewtonIK, PdPij, fastest_solver
from mearm.kinematics import ArmModel, closed_form_for
from mearm.tools import bench
from mearm.tools.bench import BenchOptions, reachable_targets, rtb_ets

PAPER = Config()
MODEL = ArmModel(PAPER.arm)
N = 60


@pytest.fixture(scope="module")
def targets():
    return reachable_targets(PAPER, N, seed=5)


def reached(model, q, target, tol_cm=0.01):
    return np.linalg.norm(model.fk_cm(q) - target) < tol_cm and model.within_limits(q)


def test_fastest_is_the_closed_form_where_one_is_registered():
    """An arm with a closed form gets it; one without gets the generic solve."""
    assert isinstance(fastest_solver(MODEL), AnalyticSolver)
    desk = ArmModel(load_config("sim_5dof").arm)
    assert isinstance(fastest_solver(desk), NewtonIK)
    with pytest.raises(ModelError, match="has no closed form"):
        AnalyticSolver(desk)


def test_closed_form_list_is_the_array(targets):
    """solve_list and solve give the same joints, bit for bit."""
    cf = closed_form_for(PAPER.arm)
    for t in targets:
        assert cf.solve_list(t) == cf.solve(t).tolist() == cf.solve(tuple(t)).tolist()


@pytest.mark.parametrize("make", [AnalyticSolver, NewtonIK], ids=["closed_form", "newton"])
def test_fast_solves_reach_every_target_within_limits(make, targets):
    """Zero error at the target (|e| < 0.01 cm), joints within limits, on the coupling."""
    solver = make(MODEL)
    chain = MODEL.chain
    for t in targets:
        s = solver.solve(t)
        assert isinstance(s, IKResult) and s.converged
        assert reached(MODEL, s.q, t)
        np.testing.assert_allclose(s.q, chain.full(chain.actuated_of(s.q)), atol=1e-12)


def test_fast_solves_agree_with_pdpij_and_each_other(targets):
    """Closed form, Gauss–Newton and PD-PIJ land on the same joints (one elbow branch)."""
    pdpij = PdPij(MODEL, PAPER.controller.updated(tolerance_cm2=1e-8))
    closed, newton = AnalyticSolver(MODEL), NewtonIK(MODEL, tolerance_cm=1e-4)
    for t in targets[:20]:
        q_cf = closed.solve(t).q
        np.testing.assert_allclose(newton.solve(t).q, q_cf, atol=1e-5)
        np.testing.assert_allclose(pdpij.solve(t, MODEL.home).q, q_cf, atol=1e-3)


def test_newton_respects_limits_from_any_seed(targets):
    """From seeds on the limits' corners the iterates never leave the box."""
    newton = NewtonIK(MODEL)
    chain = MODEL.chain
    rng = np.random.default_rng(3)
    for t in targets[:20]:
        corner = np.where(rng.random(chain.m) < 0.5, chain.actuated_lower, chain.actuated_upper)
        s = newton.solve(t, chain.full(corner))
        assert MODEL.within_limits(s.q)
        if s.converged:
            assert reached(MODEL, s.q, t)


def test_unreachable_is_reported():
    """The closed form raises with the reason, and so does Gauss–Newton on its arm; on an
    arm without one, Gauss–Newton returns a stop, not a solution.

    On the paper arm with a target box wide enough to hold such targets.
    """
    wide_box = [
        f"arm.target_box.{axis}={{min: -300, max: 300}}" for axis in ("x_cm", "y_cm", "z_cm")
    ]
    model = ArmModel(config_from_dict({}, overrides=wide_box).arm)
    closed, newton = AnalyticSolver(model), NewtonIK(model)
    with pytest.raises(UnreachableTargetError, match="out of reach"):
        closed.solve((0.0, 200.0, 10.0))
    with pytest.raises(UnreachableTargetError, match="out of reach"):
        newton.solve((0.0, 200.0, 10.0))
    with pytest.raises(SingularTargetError):
        closed.solve((0.0, 0.0, 30.0))
    with pytest.raises(JointLimitTargetError):
        closed.solve((0.0, -30.0, 20.0))  # behind the base: the base limits forbid it
    generic = ArmModel(config_from_dict({}, overrides=[*wide_box, "arm.closed_form=null"]).arm)
    s = NewtonIK(generic).solve((0.0, 200.0, 10.0))
    assert not s.converged and s.final_error_cm > 1.0 and MODEL.within_limits(s.q)
    assert s.failure is not None


@pytest.mark.parametrize("config", ["sim", "sim_mearm_v1"])
def test_newton_refuses_what_every_solver_refuses(config):
    """On an arm with a closed form, Gauss–Newton raises as the other solvers do
    (IKSolver.solve's contract), with the closed form's reason, before any search."""
    model = ArmModel(load_config(config).arm)
    box = model.arm.target_box
    target = (0.0, box.y_cm.max, box.z_cm.max)  # the box's far top edge: out of reach
    with pytest.raises(UnreachableTargetError, match="the arm reaches") as expected:
        AnalyticSolver(model).solve(target)
    with pytest.raises(UnreachableTargetError) as caught:
        NewtonIK(model).solve(target)
    assert str(caught.value) == str(expected.value)


def test_every_fast_solve_checks_the_box():
    """A target outside the arm's target box is refused, naming the axis, by both."""
    for solver in (AnalyticSolver(MODEL), NewtonIK(MODEL)):
        with pytest.raises(TargetOutsideBoxError, match="y"):
            solver.solve((0.0, 200.0, 10.0))


@pytest.mark.parametrize("bad", [(1.0, 2.0), (math.nan, 1.0, 2.0), "abc", [[1.0], [2.0], [3.0]]])
def test_bad_targets_name_the_value(bad):
    for solver in (AnalyticSolver(MODEL), NewtonIK(MODEL)):
        with pytest.raises(InvalidTargetError, match="three finite numbers"):
            solver.solve(bad)


def test_newton_rejects_bad_settings():
    with pytest.raises(ValueError, match="tolerance_cm"):
        NewtonIK(MODEL, tolerance_cm=0.0)
    with pytest.raises(ValueError, match="max_iterations"):
        NewtonIK(MODEL, max_iterations=0)


@pytest.mark.heavy
def test_rtb_ets_is_the_arms_kinematics():
    """The peer's ETS maps the 3 actuated joints to mearm's TCP (when RTB is installed)."""
    ets, note = rtb_ets(PAPER)
    if ets is None:
        pytest.skip(note)
    chain = MODEL.chain
    rng = np.random.default_rng(1)
    for q in rng.uniform(chain.actuated_lower, chain.actuated_upper, (20, chain.m)):
        np.testing.assert_allclose(ets.fkine(q).t, MODEL.fk_cm(chain.full(q)), atol=1e-9)


def test_peer_rows_skip_rtb_in_one_line_without_it(monkeypatch):
    """Without roboticstoolbox the section says so in one row and still runs the rest."""
    import sys

    monkeypatch.setitem(sys.modules, "roboticstoolbox", None)  # import raises ImportError
    rows = bench.ik_peer_rows(PAPER, BenchOptions(repeat=1), n_targets=5)
    skipped = [r for r in rows if r.name.startswith("RTB")]
    assert len(skipped) == 1 and "not installed" in skipped[0].note
    names = {r.name for r in rows}
    assert "mearm fastest (closed form): per solve" in names
    assert "PD-PIJ coupled: per iteration" in names
    # no ratio to a peer that did not run, but its target is kept: not measured, not met
    (held,) = [r for r in rows if "/ RTB" in r.name]
    assert held.name == "mearm fastest / RTB ik_LM, per solve"
    assert math.isnan(held.value) and held.met is False and "not measured" in held.note
    by_name = {r.name: r for r in rows}
    for name in (  # from home, from a new start each call, all in one batch: every target
        "mearm fastest (closed form): per solve",
        "mearm fastest (closed form), a new start each: per solve",
        "mearm batch (closed form): per solve",
    ):
        assert by_name[name].note.startswith("success 5/5"), by_name[name]


def test_prepare_start_is_start_joints_bit_for_bit():
    """The scalar start check gives start_joints' joints exactly, and its errors."""
    from mearm.exceptions import InvalidJointsError, JointLimitError
    from mearm.ik.solver import start_joints

    solver = PdPij(MODEL, PAPER.controller)
    chain = MODEL.chain
    rng = np.random.default_rng(9)
    for qa in rng.uniform(chain.actuated_lower - 1e-10, chain.actuated_upper + 1e-10, (50, 3)):
        for q in (qa, chain.full(qa), [float(v) for v in qa]):
            assert solver._start(q).tolist() == start_joints(q, MODEL).tolist()
    assert solver._start(np.array([2, 1, -2])).dtype == float
    with pytest.raises(JointLimitError):
        solver._start(chain.actuated_upper + 0.1)
    with pytest.raises(InvalidJointsError, match="off its coupling"):
        solver._start(chain.full(chain.actuated_of(MODEL.home)) + [0, 0, 0, 0.1])
