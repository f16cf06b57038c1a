"""An arm with a prismatic joint has no reach bound: asked with the limits, it cannot
tell, never fails (a 5-DOF whose wrist roll became a rail stopped ``mearm sort --random``
with an AttributeError)."""

from conftest import ROOT

from mearm.config import load_config
from mearm.ik.reach import ReachBound
from mearm.kinematics import ArmModel


def test_beyond_limits_cannot_tell_on_an_arm_with_a_prismatic_joint():
    config = load_config(
        ROOT / "configs" / "sim_5dof.yaml", ["arm.joints.wrist_roll.type=prismatic"]
    )
    bound = ReachBound(ArmModel(config.arm), config.controller.tolerance_cm2, 5.0)
    assert bound.anchor_m is None  # (no bound for a rail: the module docstring)
    far_m = [0.0, 5.0, 0.1]  # 5 m out: only a bound could call it beyond
    assert not bound.beyond_limits(far_m, None)
    assert not bound.beyond_limits(far_m, (0.0, 0.0, -1.0))
