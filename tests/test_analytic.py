"""The closed-form IK plug-in: exact round trips and honest refusals."""

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.exceptions import InvalidTargetError, TargetOutsideBoxError, UnreachableTargetError
from mearm.kinematics import ArmModel, check_target, closed_form_for
from mearm.kinematics.closed_form import JointLimitTargetError, SingularTargetError


@pytest.fixture(scope="module")
def model(config):
    return ArmModel(config.arm)


@pytest.fixture(scope="module")
def closed_form(config):
    return closed_form_for(config.arm)


def closed_form_deg(closed_form, target):
    return np.degrees(closed_form.solve(target))


def box_grid(config, step=2.5):
    b = config.arm.target_box
    xs = np.arange(b.x_cm.min, b.x_cm.max + 1e-9, step)
    ys = np.arange(b.y_cm.min, b.y_cm.max + 1e-9, step)
    zs = np.arange(b.z_cm.min, b.z_cm.max + 1e-9, step)
    return np.array(np.meshgrid(xs, ys, zs, indexing="ij")).reshape(3, -1).T


def test_round_trip_over_reachable_box(model, config, closed_form):
    """IK → FK returns every reachable grid point of the Table 3 box within 1e-9 cm."""
    reached = unreachable = 0
    for p in box_grid(config):
        try:
            q = closed_form.solve(p)
        except UnreachableTargetError:
            unreachable += 1
            continue
        reached += 1
        assert model.within_limits(q)
        assert np.abs(model.fk_cm(q) - p).max() < 1e-9
    assert reached > 1000 and unreachable > 100  # the box is partly out of reach (paper §3)


def test_home_pose_recovered(closed_form):
    np.testing.assert_allclose(
        closed_form_deg(closed_form, [-20.156502976, 34.912087272, 19.945846311]),
        [120, 93, -132, 39],
        atol=1e-6,
    )


def test_too_far_is_reported(closed_form):
    with pytest.raises(UnreachableTargetError, match="out of reach: the wrist point is") as exc:
        closed_form.solve([0, 60, 60])
    assert exc.value.target_cm == (0, 60, 60)


def test_needs_joint_outside_limits(closed_form):
    # close in front of the base and high: the elbow would have to fold past the shoulder's limit
    with pytest.raises(
        JointLimitTargetError,
        match=r"needs shoulder = 169.09 deg, outside its limits \[30, 135\] deg",
    ) as exc:
        closed_form.solve([5, 25, 30])
    err = exc.value
    assert isinstance(err, UnreachableTargetError)  # callers catching that still do
    assert (err.joint, err.lower, err.upper, err.unit) == ("shoulder", 30.0, 135.0, "deg")
    assert err.value == pytest.approx(169.09, abs=0.01)


def test_on_the_base_axis_is_singular():
    """The MeArm v1's box holds the base axis, where the base angle is undefined."""
    config = load_config(ROOT / "configs" / "sim_mearm_v1.yaml")
    with pytest.raises(SingularTargetError, match="on the base axis") as exc:
        closed_form_for(config.arm).solve([0.0, 0.0, 10.0])
    assert isinstance(exc.value, UnreachableTargetError)


def test_check_target_box_first(config, closed_form):
    with pytest.raises(TargetOutsideBoxError) as exc:
        check_target([0, 70, 20], config.arm, closed_form)
    assert exc.value.axis == "y" and exc.value.bounds_cm == (20, 60)
    assert "y = 70 is outside the target box y ∈ [20, 60] cm" in str(exc.value)


def test_check_target_without_closed_form(config):
    """An arm without a closed form: the box check only, no joints."""
    assert check_target([0, 40, 20], config.arm, None) is None


def test_bad_target_shape(closed_form):
    with pytest.raises(InvalidTargetError, match="three finite numbers"):
        closed_form.solve([1.0, np.nan, 2.0])
    with pytest.raises(InvalidTargetError):
        closed_form.solve([1.0, 2.0])
