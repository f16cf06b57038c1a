import numpy as np
import pytest
from conftest import planar_yaw_arm_data, yourdfpy_urdf

from mearm.config import ArmDescription
from mearm.exceptions import JointLimitError, ModelError
from mearm.kinematics import ArmModel, Chain, dh_fk, dh_jacobian, generate_urdf


def _random_poses(chain: Chain, n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    act = rng.uniform(chain.actuated_lower, chain.actuated_upper, size=(n, chain.m))
    return np.array([chain.full(a) for a in act])


@pytest.fixture(scope="module", params=["reference", "rail"])
def arm(request, reference_config) -> ArmDescription:
    if request.param == "rail":
        return ArmDescription.model_validate(planar_yaw_arm_data(rail=True))
    return reference_config.arm


def test_paper_home_check_value(model):
    """The paper's check value: the DH product at home is (-20.16, 34.91, 19.95) cm."""
    np.testing.assert_allclose(model.fk_cm(model.home), [-20.16, 34.91, 19.95], atol=0.005)


def test_fk_agrees_pinocchio_dh_yourdfpy(arm):
    """Pinocchio, the DH product and yourdfpy give the same TCP within 1e-9 cm."""
    model = ArmModel(arm)
    urdf = yourdfpy_urdf(model.urdf, build_scene_graph=True)
    for q in _random_poses(model.chain, 200):
        p_pin = model.fk_cm(q)
        np.testing.assert_allclose(p_pin, dh_fk(arm, q), atol=1e-9)
        urdf.update_cfg(dict(zip(model.chain.names, q, strict=True)))
        p_yd = urdf.get_transform("tcp")[:3, 3] * 100.0
        np.testing.assert_allclose(p_pin, p_yd, atol=1e-9)


def test_jaws_are_joints_in_both_readers(arm):
    """The gripper's jaws are joints: the right one a mimic of the left."""
    urdf = yourdfpy_urdf(generate_urdf(arm))
    g = arm.tool.gripper.name
    assert f"{g}_jaw_left" in urdf.actuated_joint_names
    assert urdf.joint_map[f"{g}_jaw_right"].mimic.joint == f"{g}_jaw_left"
    import pinocchio as pin

    full = pin.buildModelFromXML(generate_urdf(arm))
    assert full.existJointName(f"{g}_jaw_left") and full.existJointName(f"{g}_jaw_right")


def test_jacobian_matches_finite_differences(arm):
    """Pinocchio's position Jacobian equals central differences within 1e-5."""
    model = ArmModel(arm)
    h = 1e-6
    for q in _random_poses(model.chain, 20, seed=1):
        J = model.jacobian(q)
        fd = np.stack(
            [(model.fk_cm(q + h * e) - model.fk_cm(q - h * e)) / (2 * h) for e in np.eye(len(q))],
            axis=1,
        )
        np.testing.assert_allclose(J, fd, atol=1e-5 * max(1.0, np.abs(fd).max()))
        np.testing.assert_allclose(J, dh_jacobian(arm, q), atol=1e-9)


def test_coupled_and_approach_jacobians_match_finite_differences(arm):
    """J·C over the actuated joints and the approach-axis Jacobian match central differences."""
    model = ArmModel(arm)
    ch = model.chain
    h = 1e-6
    for q in _random_poses(ch, 10, seed=2):
        qa = ch.actuated_of(q)
        fd = np.stack(
            [
                (model.fk_cm(ch.full(qa + h * e)) - model.fk_cm(ch.full(qa - h * e))) / (2 * h)
                for e in np.eye(ch.m)
            ],
            axis=1,
        )
        np.testing.assert_allclose(model.coupled_jacobian(q), fd, atol=1e-4)
        _, Ja = model.approach_jacobian(q)
        fda = np.stack(
            [
                (model.approach(q + h * e) - model.approach(q - h * e)) / (2 * h)
                for e in np.eye(ch.n)
            ],
            axis=1,
        )
        np.testing.assert_allclose(Ja, fda, atol=1e-6)


def test_chain_coupling_and_names(config):
    """The paper arm: wrist = -(shoulder + elbow); names round-trip; passive limits derived."""
    ch = Chain.from_description(config.arm)
    assert ch.names == ("base", "shoulder", "elbow", "wrist")
    assert ch.actuated == ("base", "shoulder", "elbow")
    np.testing.assert_array_equal(ch.C[3], [0.0, -1.0, -1.0])
    np.testing.assert_allclose(np.degrees([ch.lower[3], ch.upper[3]]), [-115, 130])
    q = ch.from_named({"base": 120.0, "shoulder": 93.0, "elbow": -132.0})
    assert ch.named(q) == pytest.approx({"base": 120, "shoulder": 93, "elbow": -132, "wrist": 39})


def test_check_limits_names_joint_value_and_range(model):
    q = model.home
    q[1] = np.radians(140)
    with pytest.raises(JointLimitError) as info:
        model.check_limits(q)
    assert info.value.joint == "shoulder"
    assert "shoulder = 140 deg is outside its limits [30, 135] deg" in str(info.value)


def test_prismatic_limit_error_in_cm():
    arm = ArmDescription.model_validate(planar_yaw_arm_data(rail=True))
    model = ArmModel(arm)
    q = model.home
    q[0] = 0.2  # 20 cm, beyond the rail's 10
    with pytest.raises(JointLimitError, match=r"rail = 20 cm is outside its limits \[0, 10\] cm"):
        model.check_limits(q)


def test_bad_urdf_is_a_model_error(config, tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'/></robot>")
    with pytest.raises(ModelError, match="URDF joints are"):
        ArmModel(config.arm, urdf_path=bad)
    with pytest.raises(ModelError, match="cannot read URDF"):
        ArmModel(config.arm, urdf_path=tmp_path / "missing.urdf")


def test_a_urdf_of_another_arm_or_a_stale_one_is_a_model_error(config, tmp_path):
    """Joint names alone let another arm's URDF (or one written before the description
    changed) through: limits from the description, FK from the file, 30 cm apart."""
    from conftest import ROOT

    other = ROOT / "robot_description" / "mearm_v1.urdf"
    with pytest.raises(ModelError, match=r"is not the arm 'mearm_paper' described: .* cm apart"):
        ArmModel(config.arm, urdf_path=other)
    stale = tmp_path / "stale.urdf"
    stale.write_text(generate_urdf(config.arm))
    data = config.arm.model_dump()
    data["joints"][1]["dh"]["a_cm"] += 0.5
    longer = ArmDescription.model_validate(data)
    with pytest.raises(ModelError, match=r"write it again from the description"):
        ArmModel(longer, urdf_path=stale)
    assert np.allclose(ArmModel(config.arm, urdf_path=stale).fk_cm(ArmModel(config.arm).home),
                       ArmModel(config.arm).fk_cm(ArmModel(config.arm).home))  # fmt: skip
