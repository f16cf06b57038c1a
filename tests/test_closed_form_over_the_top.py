"""The closed form reaches back over the top where the base facing the target cannot.

A target behind the base (y < 0 on the paper's arm) needs the base outside its limits if
the arm faces it, but the base half a turn round with the shoulder past the vertical
puts the TCP there within every limit. The default target box holds no such target; a
widened one does, and the closed form must not refuse what the arm reaches.
"""

import numpy as np
import pytest

from mearm.config import load_config
from mearm.ik import AnalyticSolver
from mearm.ik.batch import solve_batch
from mearm.kinematics import ArmModel, closed_form_for
from mearm.kinematics.closed_form import JointLimitTargetError

WIDE = ["arm.target_box.y_cm.min=-60", "arm.target_box.z_cm.max=90"]


@pytest.fixture(scope="module")
def wide_model():
    return ArmModel(load_config(None, WIDE).arm)


def test_a_pose_over_the_top_is_found(wide_model):
    """The tester's pose: base 45.84, shoulder 134.8, elbow -39.56 deg, refused before."""
    q = wide_model.chain.full(np.radians([45.84, 134.8, -39.56]))
    target = wide_model.fk_cm(q)
    assert target[1] < 0  # behind the base: facing it needs base = -134.16 deg
    solved = closed_form_for(wide_model.arm).solve(target)
    np.testing.assert_allclose(solved, q, atol=1e-9)
    result = AnalyticSolver(wide_model).solve(target)
    assert result.status == "converged"
    np.testing.assert_allclose(result.q, q, atol=1e-9)


def test_every_in_limit_pose_is_found_again(wide_model):
    """Each of 600 random poses within the limits: its own TCP is solved, exactly."""
    chain = wide_model.chain
    rng = np.random.default_rng(3)
    poses = [
        chain.full(q)
        for q in rng.uniform(chain.actuated_lower, chain.actuated_upper, (600, chain.m))
    ]
    targets = np.array([wide_model.fk_cm(q) for q in poses])
    assert (targets[:, 1] < 0).any()  # some reach back over the top
    closed_form = closed_form_for(wide_model.arm)
    for t in targets:
        solved = closed_form.solve(t)
        assert wide_model.within_limits(solved)
        assert np.abs(wide_model.fk_cm(solved) - t).max() < 1e-9
    batch = solve_batch(wide_model, targets)
    assert batch.reached.all()
    fk = np.array([wide_model.fk_cm(q) for q in batch.q])
    assert np.abs(fk - targets).max() < 1e-9


def test_the_facing_branch_is_preferred(wide_model):
    """A target both branches could reach keeps the base facing it (the old answer)."""
    closed_form = closed_form_for(wide_model.arm)
    q = closed_form.solve([-10.99, 49.70, 12.76])
    assert np.isclose(q[0], np.arctan2(49.70, -10.99))


def test_neither_branch_names_the_facing_one(wide_model):
    """Refused by both: the error is the facing branch's, as before."""
    closed_form = closed_form_for(wide_model.arm)
    with pytest.raises(JointLimitTargetError, match="needs base = 10.00 deg") as caught:
        closed_form.solve([40 * np.cos(np.radians(10)), 40 * np.sin(np.radians(10)), 20])
    assert caught.value.joint == "base"
