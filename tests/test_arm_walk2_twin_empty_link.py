"""A maker's arm whose zero-length row is followed by a passive joint builds in the twin.

The 5-joint desk arm with its wrist roll made passive (coupled to the base yaw, so the jaws
keep their heading): the wrist-pitch row has a = d = 0, so no plate, and the servo that
would sit in its body is gone with the roll's. MuJoCo refused that empty moving body
("mass and inertia of moving bodies must be larger than mjMINVAL"), and ``mearm sort``
on the twin stopped with exit 2 on a description the docs allow (docs/your-arm.md).
"""

from __future__ import annotations

import math

import mujoco
import pytest

from mearm.config.files import load_config
from mearm.kinematics.bodies import LINK_THICKNESS_M, link_width_m, plate_mass_kg
from mearm.sim.twin.mjcf import ACRYLIC_DENSITY, twin_model

PASSIVE_ROLL = (
    "arm.joints.wrist_roll.servo=null",
    "arm.joints.wrist_roll.home=null",
    "arm.joints.wrist_roll.limits=null",
    "arm.joints.wrist_roll.coupling={terms: {base_yaw: 1.0}, offset: -90.0}",
)


def test_an_empty_link_body_gets_a_hubs_mass() -> None:
    config = load_config("sim_5dof_mujoco", PASSIVE_ROLL)
    model = twin_model(config)
    width = link_width_m(config.arm)
    hub = plate_mass_kg(width, width, ACRYLIC_DENSITY)
    body = model.body("link_wrist_pitch")
    assert body.mass[0] == pytest.approx(hub)
    assert body.inertia == pytest.approx(
        [
            hub * (width**2 + LINK_THICKNESS_M**2) / 12,
            hub * (width**2 + LINK_THICKNESS_M**2) / 12,
            hub * width**2 / 6,
        ]
    )
    # the coupling holds it: at home the roll is base_yaw - 90 (0 for the yaw's 90)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.keyframe("home").id)
    mujoco.mj_step(model, data, nstep=200)
    assert data.joint("wrist_roll").qpos[0] == pytest.approx(
        data.joint("base_yaw").qpos[0] - math.pi / 2, abs=1e-3
    )


def test_bodies_with_shapes_keep_only_their_shapes_mass() -> None:
    """The reference arm's bodies all carry a plate or a servo: none gets a hub."""
    config = load_config("sim_5dof_mujoco")
    model = twin_model(config)
    width = link_width_m(config.arm)
    hub = plate_mass_kg(width, width, ACRYLIC_DENSITY)
    for joint in config.arm.joints:
        assert model.body(f"link_{joint.name}").mass[0] != pytest.approx(hub)
