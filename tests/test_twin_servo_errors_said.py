"""The kinematic simulator's servo errors on the twin are said to do nothing.

A fresh-seed sweep: ``mearm sort --config sim_mujoco --random 3 --seed 24401 --set
'servo.error_model.offset_deg={shoulder: 30}'`` sorted 3 of 3, exit 0, with no word, its
routes the same as without it (``offset_deg`` 1000 and ``noise_std_deg`` 360 too), where
``--config sim`` sorts none of the three: the twin's servos miss their commands by their
physics (and as real units do, ``twin.kit``), and read only ``error_model.seed``. The
twin already said so of the kinematic renderer's camera settings.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from mearm.config import load_config
from mearm.task.check import kinematic_servo_warning, twin_only_warning

CONFIGS = sorted((Path(__file__).resolve().parents[1] / "configs").glob("*.yaml"))
SAID = (
    "the kinematic simulator's servos' (simulator: kinematic); this config's simulator is "
    "mujoco, whose servos miss their commands by their physics (and as real units do, "
    "twin.kit): "
)


def test_the_twin_says_the_servo_errors_it_does_not_use() -> None:
    config = load_config(
        "sim_mujoco",
        ["servo.error_model.offset_deg={shoulder: 30}", "servo.error_model.noise_std_deg=2"],
    )
    assert twin_only_warning(config) == (
        "servo.error_model.offset_deg, servo.error_model.noise_std_deg: "
        + SAID
        + "they do nothing here"
    )
    both = load_config("sim_mujoco", ["servo.error_model.quantization=degree", "camera.seed=3"])
    said = twin_only_warning(both)
    assert said is not None and said.endswith(
        "; servo.error_model.quantization: " + SAID + "it does nothing here"
    ), said


def test_the_kinematic_rig_and_the_twin_s_seed_say_nothing() -> None:
    """The kinematic rig reads them all; the twin reads the seed (its kit's units)."""
    kinematic = load_config("sim", ["servo.error_model.offset_deg={shoulder: 3}"])
    assert kinematic_servo_warning(kinematic) is None
    seeded = load_config("sim_mujoco", ["servo.error_model.seed=7"])
    assert kinematic_servo_warning(seeded) is None


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_no_shipped_config_is_told(path: Path) -> None:
    assert kinematic_servo_warning(load_config(path)) is None
