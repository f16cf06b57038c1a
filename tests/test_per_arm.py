"""Worked out once per arm description: the arm model's Pinocchio model and the jaws' frame."""

from __future__ import annotations

import gc

import numpy as np
from conftest import ROOT

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.kinematics.per_arm import PerArm
from mearm.kinematics.urdf import jaw_frame


def _arm(name: str = "sim"):  # noqa: ANN202  (an ArmDescription)
    return load_config(ROOT / "configs" / f"{name}.yaml").arm


def test_arm_models_of_one_description_share_its_pinocchio_model() -> None:
    """The start-up check, the rig and the simulated servos each build an arm model of the
    run's one description: the URDF and its model are built once, each keeps its own data;
    another description (even an equal copy) builds its own."""
    arm = _arm()
    a, b = ArmModel(arm), ArmModel(arm)
    assert a.model is b.model and a.urdf is b.urdf
    assert a.data is not b.data
    other = ArmModel(arm.model_copy(deep=True))
    assert other.model is not a.model
    q = a.home + 0.1
    assert np.array_equal(a.fk_cm(q), other.fk_cm(q))


def test_the_jaw_frame_kept_is_not_the_callers() -> None:
    """A caller that changes the jaws' frame it was given changes no later answer."""
    arm = _arm("sim_5dof")
    first = jaw_frame(arm)
    expected = first.copy()
    first[:] = 0.0
    assert np.array_equal(jaw_frame(arm), expected)


def test_a_value_goes_with_its_description() -> None:
    """Nothing is kept for a description no longer in use, and each gets its own value."""
    made = []
    per_arm = PerArm(lambda arm: made.append(arm.name) or len(made))
    arm = _arm()
    assert per_arm(arm) == per_arm(arm) == 1
    copy = arm.model_copy(deep=True)
    assert per_arm(copy) == 2
    del copy
    gc.collect()
    assert len(per_arm._kept) == 1
