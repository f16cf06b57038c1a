"""A refusal the IK controller's settings cause names them, not the arm's DH rows.

``mearm sort --config sim --set controller.max_iterations=1`` (or ``controller.kp=0.001``)
was refused with "3 bins … cannot be reached from home within the joint limits: the arm's
description is the likely cause; check the signs of its DH rows", and the picks "reached
nowhere": the arm was the shipped one, and what the user changed was the solver's
iteration cap. The check now runs again with the default controller settings; what holds
then is the settings' doing, and the refusal says so.
"""

from __future__ import annotations

import pytest

from mearm.config import load_config
from mearm.errors import ConfigError
from mearm.task.check import check_consistency

#: A bin 80 cm to the side: in no arm's target box, whatever the solver's settings.
FAR_BIN = "task.classes.red.bin_cm=[-80, 16, 6]"


def _refusal(overrides: list[str]) -> ConfigError:
    with pytest.raises(ConfigError) as caught:
        check_consistency(load_config("sim", overrides))
    return caught.value


def test_an_iteration_cap_too_low_is_named_not_the_dh_rows() -> None:
    error = _refusal(["controller.max_iterations=1"])
    text = str(error)
    assert "likely cause" not in text and "DH rows" not in text, text
    assert "reached nowhere" not in text, text
    assert len(error.problems) == 1, text
    assert error.problems[0].startswith("controller.max_iterations = 1 (default 1000): "), text


def test_every_setting_off_its_default_is_named() -> None:
    error = _refusal(["controller.kp=0.01", "controller.max_iterations=20"])
    first = error.problems[0]
    assert first.startswith(
        "controller.kp = 0.01 (default 0.1), controller.max_iterations = 20 (default 1000): "
    ), first
    assert "likely cause" not in str(error)


def test_a_failure_the_defaults_share_is_not_blamed_on_the_controller() -> None:
    """A bin out of reach stays out of reach with the default settings: said as before."""
    plain = str(_refusal([FAR_BIN]))
    tuned = str(_refusal([FAR_BIN, "controller.kd=0.02"]))
    assert tuned == plain
    assert "controller" not in tuned
