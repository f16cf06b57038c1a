"""The closed-form IK: exact round trips and honest refusals."""

import numpy as np
import pytest

from mearm.exceptions import InvalidTargetError, TargetOutsideBoxError, UnreachableTargetError
from mearm.kinematics import analytic_ik_deg, check_target


def box_grid(config, step=2.5):
    b = config.robot.target_box
    xs = np.arange(b.x_cm.min, b.x_cm.max + 1e-9, step)
    ys = np.arange(b.y_cm.min, b.y_cm.max + 1e-9, step)
    zs = np.arange(b.z_cm.min, b.z_cm.max + 1e-9, step)
    return np.array(np.meshgrid(xs, ys, zs, indexing="ij")).reshape(3, -1).T


def test_round_trip_over_reachable_box(model, config):
    """IK → FK returns every reachable grid point of the Table 3 box within 1e-9 cm."""
    reached = unreachable = 0
    for p in box_grid(config):
        try:
            q_deg = analytic_ik_deg(p, config.robot)
        except UnreachableTargetError:
            unreachable += 1
            continue
        reached += 1
        q = np.radians(q_deg)
        assert model.within_limits(q)
        assert np.abs(model.fk_cm(q) - p).max() < 1e-9
    assert reached > 1000 and unreachable > 100  # the box is partly out of reach (SPEC §3)


def test_home_pose_recovered(config):
    np.testing.assert_allclose(
        analytic_ik_deg([-20.156502976, 34.912087272, 19.945846311], config.robot),
        [120, 93, -132, 39],
        atol=1e-6,
    )


def test_too_far_is_reported(config):
    with pytest.raises(UnreachableTargetError, match="out of reach: the wrist point is") as exc:
        analytic_ik_deg([0, 60, 60], config.robot)
    assert exc.value.target_cm == (0, 60, 60)


def test_needs_joint_outside_limits(config):
    # close in front of the base and high: the elbow would have to fold past joint2's limit
    with pytest.raises(
        UnreachableTargetError,
        match=r"needs joint2 = 169.09 deg, outside its limits \[30, 135\] deg",
    ):
        analytic_ik_deg([5, 25, 30], config.robot)


def test_check_target_box_first(config):
    with pytest.raises(TargetOutsideBoxError) as exc:
        check_target([0, 70, 20], config.robot)
    assert exc.value.axis == "y" and exc.value.bounds_cm == (20, 60)
    assert "y = 70 is outside the target box y ∈ [20, 60] cm" in str(exc.value)


def test_bad_target_shape(config):
    with pytest.raises(InvalidTargetError, match="three finite numbers"):
        analytic_ik_deg([1.0, np.nan, 2.0], config.robot)
    with pytest.raises(InvalidTargetError):
        analytic_ik_deg([1.0, 2.0], config.robot)
