"""The kinematics called from Python: a bad argument is refused by name, not computed.

From a library walk: ``ArmModel.fk_cm`` and ``dh_fk`` of joints holding NaN returned NaN
positions silently (a non-number was already refused); ``dh_fk`` of three joints raised
a bare ValueError.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mearm.config import load_config
from mearm.kinematics import ArmModel, dh_fk, dh_jacobian
from mearm.kinematics.errors import InvalidJointsError

CONFIG = load_config("sim")
MODEL = ArmModel(CONFIG.arm)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_joints_not_finite_are_refused(bad) -> None:
    q = [bad, 1.0, 1.0, 1.0]
    for call in (MODEL.fk_cm, MODEL.jacobian, MODEL.approach, MODEL.check_limits):
        with pytest.raises(InvalidJointsError, match="joint values must be finite"):
            call(q)
    for call in (dh_fk, dh_jacobian):
        with pytest.raises(InvalidJointsError, match="joint values must be finite"):
            call(CONFIG.arm, q)


def test_huge_finite_joints_are_still_joints() -> None:
    """The cheap test sums the values: a sum that overflows is not taken for a NaN."""
    q = [1e308, 1e308, 0.0, 0.0]
    assert np.isfinite(MODEL.fk_cm(q)).all()


def test_dh_names_the_count_and_a_non_number() -> None:
    with pytest.raises(
        InvalidJointsError,
        match=r"expected 4 values, one per joint \(base, shoulder, elbow, wrist\)",
    ):
        dh_fk(CONFIG.arm, [1.0, 1.0, 1.0])
    with pytest.raises(InvalidJointsError, match="joint values must be numbers, got 'abc'"):
        dh_fk(CONFIG.arm, "abc")
    np.testing.assert_allclose(dh_fk(CONFIG.arm, MODEL.home), MODEL.fk_cm(MODEL.home), atol=1e-9)


@pytest.mark.parametrize("arm", [None, CONFIG, {"joints": []}], ids=["none", "config", "dict"])
def test_a_model_of_no_description_is_named(arm) -> None:
    """``ArmModel(None)`` stopped on an AttributeError; a ModelError says what it needs."""
    from mearm.kinematics import Chain, closed_form_for
    from mearm.kinematics.errors import ModelError

    for build in (ArmModel, Chain.from_description, closed_form_for):
        with pytest.raises(ModelError, match="needs an ArmDescription") as caught:
            build(arm)
        if arm is CONFIG:
            assert "a Config: pass its .arm" in str(caught.value)
    with pytest.raises(ModelError, match="the DH product needs an ArmDescription"):
        dh_fk(arm, MODEL.home)
