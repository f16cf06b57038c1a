"""DH reference vs Pinocchio vs yourdfpy; Jacobians vs finite differences (SPEC §2)."""

import numpy as np
import pytest
import yourdfpy
from conftest import ROOT

from mearm.config import JOINT_NAMES
from mearm.exceptions import JointLimitError, ModelError
from mearm.kinematics import COUPLING, ArmModel, couple, dh_fk, dh_jacobian

URDF = ROOT / "robot_description" / "mearm.urdf"


def random_q(model: ArmModel, n: int, seed: int) -> np.ndarray:
    """n coupled joint vectors (θ4 = −(θ2+θ3)) within the actuated limits, (n, 4) rad."""
    rng = np.random.default_rng(seed)
    q3 = rng.uniform(model.lower_rad[:3], model.upper_rad[:3], size=(n, 3))
    return q3 @ COUPLING.T


def test_home_check_value(model):
    """SPEC §2: the DH product at home is (−20.16, 34.91, 19.95) cm."""
    ee = model.fk_cm(model.home_rad)
    np.testing.assert_allclose(ee, [-20.16, 34.91, 19.95], atol=0.01)


def test_fk_agrees_pinocchio_dh_yourdfpy(model, config):
    """1 000 random poses: Pinocchio, the DH product and yourdfpy agree within 1e-9 cm."""
    urdf = yourdfpy.URDF.load(str(URDF), load_meshes=False, build_collision_scene_graph=False)
    rng = np.random.default_rng(1)
    # all four joints free (coupled or not): the URDF must equal the DH product everywhere
    qs = rng.uniform(model.lower_rad, model.upper_rad, size=(1000, 4))
    worst = 0.0
    for q in qs:
        p_pin = model.fk_cm(q)
        p_dh = dh_fk(q, config.robot.dh)
        urdf.update_cfg(dict(zip(JOINT_NAMES, q, strict=True)))
        p_yd = urdf.get_transform("ee", "base_link")[:3, 3] * 100.0
        worst = max(worst, np.abs(p_pin - p_dh).max(), np.abs(p_yd - p_dh).max())
    assert worst < 1e-9


def _central_difference(f, q, eps=1e-6):
    cols = []
    for i in range(len(q)):
        dq = np.zeros_like(q)
        dq[i] = eps
        cols.append((f(q + dq) - f(q - dq)) / (2 * eps))
    return np.stack(cols, axis=1)


def test_jacobian_matches_finite_differences(model):
    """200 random poses: the 3×4 Jacobian matches central differences within 1e-6."""
    for q in random_q(model, 200, seed=2):
        J_fd = _central_difference(model.fk_cm, q)
        np.testing.assert_allclose(model.jacobian(q), J_fd, atol=1e-6, rtol=0)


def test_coupled_jacobian_matches_finite_differences(model):
    """200 random poses: J·C matches central differences of FK(couple(θ1..θ3))."""
    for q in random_q(model, 200, seed=3):
        J_fd = _central_difference(lambda q3: model.fk_cm(couple(q3)), q[:3])
        Jc = model.coupled_jacobian(q)
        assert Jc.shape == (3, 3)
        np.testing.assert_allclose(Jc, J_fd, atol=1e-6, rtol=0)


def test_pinocchio_jacobian_equals_eq9(model, config):
    """The Pinocchio Jacobian is the paper's eq. 9 Jacobian."""
    for q in random_q(model, 200, seed=4):
        np.testing.assert_allclose(model.jacobian(q), dh_jacobian(q, config.robot.dh), atol=1e-10)


def test_fk_and_jacobian_one_pass(model):
    q = random_q(model, 1, seed=5)[0]
    ee, J = model.fk_and_jacobian(q)
    np.testing.assert_allclose(ee, model.fk_cm(q), atol=1e-12)
    np.testing.assert_allclose(J, model.jacobian(q), atol=1e-12)


def test_check_limits_names_joint_value_and_range(model):
    q = np.radians([120.0, 140.0, -132.0, -8.0])
    with pytest.raises(JointLimitError) as exc:
        model.check_limits(q)
    e = exc.value
    assert (e.joint, round(e.value_deg), e.lower_deg, e.upper_deg) == ("joint2", 140, 30, 135)
    assert "joint2 = 140 deg is outside its limits [30, 135] deg" in str(e)
    assert not model.within_limits(q) and model.within_limits(model.home_rad)


def test_bad_urdf_is_a_model_error(config, tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text('<robot name="x"><link name="a"/></robot>')
    with pytest.raises(ModelError, match="URDF joints are"):
        ArmModel(config.robot, urdf_path=bad)
    with pytest.raises(ModelError, match="cannot read URDF"):
        ArmModel(config.robot, urdf_path=tmp_path / "missing.urdf")
