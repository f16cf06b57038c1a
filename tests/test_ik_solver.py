"""One IK interface: every solver's ``solve(target, q_start=None)`` and its one record."""

import dataclasses

import numpy as np
import pytest

import mearm.ik  # MinkSolver on first use: mink costs each worker's collection 0.3 s
from mearm.config import Config
from mearm.exceptions import InvalidTargetError, JointLimitError, TargetOutsideBoxError
from mearm.ik import AnalyticSolver, IKResult, IKSolver, IKTarget, NewtonIK, PdPij
from mearm.kinematics import ArmModel

CONFIG = Config()
MODEL = ArmModel(CONFIG.arm)
TARGET = (-10.99, 49.70, 12.76)
SOLVERS = {
    "pdpij": lambda: PdPij(MODEL, CONFIG.controller),
    "mink": lambda: mearm.ik.MinkSolver(MODEL, CONFIG.controller),
    "analytic": lambda: AnalyticSolver(MODEL, CONFIG.controller),
    "newton": lambda: NewtonIK(MODEL),
}


@pytest.fixture(scope="module", params=list(SOLVERS))
def solver(request) -> IKSolver:
    return SOLVERS[request.param]()


def start_pose() -> np.ndarray:
    return MODEL.chain.full(np.radians([100.0, 80.0, -100.0]))


def test_every_solver_is_an_iksolver(solver):
    """One base class for all four."""
    assert isinstance(solver, IKSolver)


@pytest.mark.parametrize("given", ["none", "full", "actuated"])
def test_the_path_starts_at_the_start(solver, given):
    """The record's first row is the start (home when none is given), its last the result,
    every row's TCP its FK, every error its distance to the target."""
    q0 = MODEL.home if given == "none" else start_pose()
    q_start = {"none": None, "full": q0, "actuated": MODEL.chain.actuated_of(q0)}[given]
    result = solver.solve(TARGET, q_start)
    assert isinstance(result, IKResult) and result.converged
    np.testing.assert_allclose(result.q_path[0], q0, atol=1e-12)
    np.testing.assert_array_equal(result.q, result.q_path[-1])
    np.testing.assert_array_equal(result.ee_cm, result.ee_path_cm[-1])
    assert result.iterations == len(result.q_path) - 1 >= 1
    for q, ee in zip(result.q_path, result.ee_path_cm, strict=True):
        np.testing.assert_allclose(MODEL.fk_cm(q), ee, atol=1e-9)
    errors = np.linalg.norm(result.ee_path_cm - np.array(TARGET), axis=1)
    np.testing.assert_allclose(result.error_path_cm, errors, atol=1e-12)
    assert result.initial_error_cm == result.error_path_cm[0]
    assert result.final_error_cm == result.error_path_cm[-1] < 0.0316
    np.testing.assert_array_equal(result.target_cm, TARGET)
    assert result.joint_names == MODEL.chain.names and result.failure is None


def test_a_target_as_a_tuple_or_an_iktarget_is_the_same_solve(solver):
    """The same joints for (x, y, z) and IKTarget((x, y, z))."""
    a = solver.solve(TARGET, MODEL.home)
    b = solver.solve(IKTarget(TARGET), MODEL.home)
    np.testing.assert_array_equal(a.q_path, b.q_path)


def test_a_start_passed_first_is_refused(solver):
    """Joint angles [rad] read as a target [cm] fall outside the box: nothing moves."""
    with pytest.raises(TargetOutsideBoxError):
        solver.solve(MODEL.chain.actuated_of(MODEL.home), TARGET)


def test_a_start_outside_the_limits_is_refused(solver):
    """Every solver checks the start the same way."""
    q = MODEL.home.copy()
    q[0] = MODEL.chain.upper[0] + 0.1
    with pytest.raises(JointLimitError):
        solver.solve(TARGET, q)


def test_records_are_read_only(solver):
    """Every array of a record is read-only: a record, not a buffer."""
    result = solver.solve(TARGET)
    for name in ("q", "q_path", "ee_path_cm", "error_path_cm", "target_cm", "ee_cm", "scale"):
        with pytest.raises(ValueError):
            getattr(result, name)[0] = 1.0


def test_a_jump_reads_like_any_record():
    """The fast solves' record (arrays made on first use) replaces, prints and summarises
    like one built from paths."""
    result = AnalyticSolver(MODEL).solve(TARGET)
    moved = dataclasses.replace(result, method="joint_move")
    assert moved.method == "joint_move" and moved.iterations == 1
    np.testing.assert_array_equal(moved.q_path, result.q_path)
    assert "q_path=" in repr(result)
    assert result.summary()["joints"] == result.joints
    assert result.summary()["final_error_cm"] == 0.0
    with pytest.raises(AttributeError, match="no attribute 'nonsense'"):
        result.nonsense  # noqa: B018
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.status = "stalled"  # type: ignore[misc]


def test_newton_searches_but_its_path_is_one_update():
    """Gauss–Newton's own updates are searched, not sent: one update in the path."""
    result = NewtonIK(MODEL).solve(TARGET, start_pose())
    assert result.iterations == 1 and result.search_iterations >= 1


def test_newton_refuses_an_approach_naming_the_solvers_that_take_one():
    """Gauss–Newton places the TCP only: an approach target is refused with what to use."""
    with pytest.raises(InvalidTargetError, match="places the TCP only.*PdPij or MinkSolver"):
        NewtonIK(MODEL).solve(IKTarget(TARGET, (0.0, 0.0, -1.0)))
