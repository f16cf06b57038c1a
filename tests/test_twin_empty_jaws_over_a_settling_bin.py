"""Jaws that closed on nothing carried nothing: a place is not ``ok`` because an object
placed before is still settling in the bin.

``mearm sort --config sim_mujoco_lamp --random 9 --seed 28050 --set twin.lamp.diffuse=0.4
--set twin.camera.height_cm=60`` (found by a fresh-seed sweep of the twin's variants: the
camera 5 cm higher than its calibration): green1's jaws closed beside it and pushed it
8 cm aside, out of the camera's reach, so the pick read ``ok``; over the green bin the
twin counted the green placed just before, not yet at rest among the others, as one just
let fall there, and the place said ``ok`` too. Only the sort's end found green1 on the
table ("not confirmed in its bin"). The place now says the jaws had closed on nothing.
(The sort itself is not the test: which object a push sends where changes with the
physics engine's release.)
"""

from __future__ import annotations

import mujoco
import numpy as np
from conftest import ROOT

from mearm.config import load_config
from mearm.kinematics.bodies import object_name
from mearm.sim.twin.mjcf import M_PER_CM
from mearm.sim.twin.twin_bus import TwinArm
from mearm.task.pick_place import holds_its_class, place_failure

CONFIG = ROOT / "configs" / "sim_mujoco.yaml"
NOTHING = "over the bin the jaws held nothing of its class: they had closed on nothing at the pick"


def test_empty_jaws_over_a_bin_whose_last_object_still_settles_hold_nothing() -> None:
    """green2, placed before, still falls onto the green bin's floor (the twin counts it as
    let fall there, :meth:`TwinArm.held_classes`); green1's jaws had closed on nothing
    (``gripped`` empty): its place fails, saying so. Once green2 rests, the same."""
    config = load_config(
        CONFIG, ["task.scene=[{color: green, x: 0, y: 45}, {color: green, x: 8, y: 45}]"]
    )
    x, y, _ = config.task.class_named("green").bin_cm
    arm = TwinArm(config)
    m, d = arm.model, arm.data
    joint = m.joint(object_name("green2"))
    q, v = int(joint.qposadr[0]), int(joint.dofadr[0])
    d.qpos[q : q + 3] = np.array([x, y, 1.5]) * M_PER_CM
    d.qvel[v : v + 6] = [0.0, 0.0, -0.05, 0.0, 0.0, 0.0]
    d.qfrc_applied[v] = 1e-300  # wakes its tree, as the twin's belt does
    mujoco.mj_forward(m, d)
    d.qfrc_applied[v] = 0.0
    held = holds_its_class(arm, "green")
    assert held and arm.held_ids() == frozenset()  # (what made the place read ok)
    assert place_failure(arm, "green", held=held, gripped=frozenset()) == NOTHING
    arm.settle(1.0)
    assert arm.in_own_bin("green2") == "green"
    assert place_failure(arm, "green", held=holds_its_class(arm, "green")) == NOTHING
