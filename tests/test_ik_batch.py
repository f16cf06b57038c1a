"""The batch solve (many targets in one call) and the lean start of the fast solves."""

import numpy as np
import pytest
from conftest import planar_yaw_arm_data

from mearm.config import ArmDescription, Config, load_config
from mearm.exceptions import JointLimitError
from mearm.ik import NewtonIK, fastest_solver
from mearm.ik.batch import _DHBatch, solve_batch
from mearm.kinematics import ArmModel, closed_form_for
from mearm.kinematics.errors import InvalidTargetError, UnreachableTargetError

PAPER = ArmModel(Config().arm)
DESK = ArmModel(load_config("sim_5dof").arm)
RAIL = ArmModel(ArmDescription.model_validate(planar_yaw_arm_data(rail=True)))


def box_targets(model: ArmModel, n: int, seed: int) -> np.ndarray:
    """``n`` points uniform in the arm's target box, reachable or not, (n, 3) [cm]."""
    box = model.arm.target_box
    lo = [box.x_cm.min, box.y_cm.min, box.z_cm.min]
    hi = [box.x_cm.max, box.y_cm.max, box.z_cm.max]
    return np.random.default_rng(seed).uniform(lo, hi, (n, 3))


@pytest.mark.parametrize("model", [PAPER, DESK, RAIL], ids=["paper", "5dof", "rail"])
def test_dh_batch_is_pinocchio(model):
    """The batched DH product and Jacobian equal Pinocchio's FK and Jacobian."""
    chain = model.chain
    rng = np.random.default_rng(3)
    q = np.array(
        [chain.full(rng.uniform(chain.actuated_lower, chain.actuated_upper)) for _ in range(20)]
    )
    tcp, R, J = _DHBatch(model).fk_and_jacobian(q)
    for k in range(len(q)):
        p, rotation = model.tcp_pose(q[k])
        np.testing.assert_allclose(tcp[k], p, atol=1e-9)
        np.testing.assert_allclose(
            R[k] @ model.approach_axis, rotation @ model.approach_axis, atol=1e-12
        )
        np.testing.assert_allclose(J[k, :3], model.jacobian(q[k]), atol=1e-9)


def test_dh_batch_angular_rows_by_finite_differences():
    """The approach axis moves as ω × a with ω from the Jacobian's angular rows."""
    chain, batch = DESK.chain, _DHBatch(DESK)
    rng = np.random.default_rng(4)
    q = chain.full(rng.uniform(chain.actuated_lower, chain.actuated_upper))[None]
    _, R, J = batch.fk_and_jacobian(q)
    a = R[0] @ DESK.approach_axis
    for i in range(chain.n):
        dq = np.zeros_like(q)
        dq[0, i] = 1e-6
        _, R2, _ = batch.fk_and_jacobian(q + dq)
        moved = (R2[0] @ DESK.approach_axis - a) / 1e-6
        np.testing.assert_allclose(moved, np.cross(J[0, 3:, i], a), atol=1e-5)


def test_closed_form_batch_is_the_closed_form_target_by_target():
    """With a closed form each row is its solution, and unreachable rows are NaN."""
    targets = box_targets(PAPER, 200, 1)
    sol = solve_batch(PAPER, targets)
    cf = closed_form_for(PAPER.arm)
    for t, q, ok in zip(targets, sol.q, sol.reached, strict=True):
        try:
            expected = cf.solve(t)
        except UnreachableTargetError:
            assert not ok and np.isnan(q).all()
        else:
            assert ok and q.tolist() == expected.tolist()
    assert 0 < sol.reached.sum() < len(targets)


@pytest.mark.parametrize("model", [DESK, RAIL], ids=["5dof", "rail"])
def test_newton_batch_reaches_what_newton_reaches(model):
    """Gauss–Newton on arrays reaches the targets the scalar NewtonIK reaches, within limits."""
    targets = box_targets(model, 60, 2)
    sol = solve_batch(model, targets)
    newton = NewtonIK(model)
    for t, q, ok, err in zip(targets, sol.q, sol.reached, sol.error_cm, strict=True):
        assert ok == newton.solve(t).converged
        if ok:
            assert np.linalg.norm(model.fk_cm(q) - t) < 0.01 and err < 0.01
            assert model.within_limits(q)
        else:
            assert np.isnan(q).all() and err >= 0.01


def test_newton_batch_meets_an_approach():
    """With an approach each reached row points the tool's axis along it, within 0.5°."""
    chain = DESK.chain
    rng = np.random.default_rng(6)
    poses = [chain.full(rng.uniform(chain.actuated_lower, chain.actuated_upper)) for _ in range(30)]
    targets = np.array([DESK.fk_cm(q) for q in poses])
    down = (0.0, 0.0, -1.0)
    sol = solve_batch(DESK, targets, down)
    free = solve_batch(DESK, targets)
    assert free.reached.all()  # each is the TCP of joints within the limits
    assert 0 < sol.reached.sum() < len(targets)  # jaws down is not always possible
    for q, ok in zip(sol.q, sol.reached, strict=True):
        if ok:
            angle = np.degrees(np.arccos(np.clip(DESK.approach(q) @ down, -1, 1)))
            assert angle < 0.5


def test_batch_refuses_bad_input():
    """Targets that are not (N, 3) finite numbers, or a zero approach, are named, with the
    error every solver gives a bad target (a bare ValueError before)."""
    with pytest.raises(InvalidTargetError, match=r"\(N, 3\) finite numbers.*\[\[x, y, z\]\]"):
        solve_batch(DESK, [1.0, 2.0, 3.0])  # one target, not a list of one
    with pytest.raises(InvalidTargetError, match=r"\(N, 3\) finite numbers"):
        solve_batch(PAPER, [0.0, 40.0, 20.0])  # the closed form's arm too
    with pytest.raises(InvalidTargetError, match="a value that is not finite"):
        solve_batch(DESK, [[1.0, np.nan, 3.0]])
    with pytest.raises(InvalidTargetError, match="got 'abc'"):
        solve_batch(DESK, "abc")
    with pytest.raises(InvalidTargetError, match="non-zero 3-vectors"):
        solve_batch(DESK, [[10.0, 10.0, 5.0]], (0.0, 0.0, 0.0))
    with pytest.raises(InvalidTargetError, match=r"\(3,\) or one per target \(1, 3\)"):
        solve_batch(DESK, [[10.0, 10.0, 5.0]], (0.0, 1.0))


def test_jump_start_tcp_is_computed_when_read():
    """A fast solve from a start reads its TCP only when the path is asked for."""
    solver = fastest_solver(PAPER)
    start = PAPER.chain.actuated_of(PAPER.home)
    start[1] += 0.1
    result = solver.solve((-10.99, 49.70, 12.76), start)
    jump = result.__dict__["_jump"][2]
    assert jump._ee_cm is None  # not computed by the solve
    np.testing.assert_allclose(
        result.ee_path_cm[0], PAPER.fk_cm(PAPER.chain.full(start)), atol=1e-12
    )
    assert result.q_path[0].tolist() == solver._start(start).tolist()


def test_the_same_start_again_is_not_checked_again_but_a_changed_one_is():
    """The last start is kept by value: the same values reuse it, new values are checked."""
    solver = fastest_solver(PAPER)
    target = (-10.99, 49.70, 12.76)
    start = PAPER.chain.actuated_of(PAPER.home)
    first = solver.solve(target, start)
    again = solver.solve(target, start.copy())
    assert again.__dict__["_jump"][2] is first.__dict__["_jump"][2]
    start[1] = PAPER.chain.upper[1] + 0.5  # the same array, now outside the limits
    with pytest.raises(JointLimitError):
        solver.solve(target, start)
