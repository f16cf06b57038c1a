"""A servo calibration file never widens a servo's pulse range, and its refusals name it.

The file records each servo's ``[min_us, max_us]`` as the config had it when measured.
A config that narrowed a range since (a servo that binds at 2000 µs) got it widened back
by the old file, and pulses up to 2400 µs could be sent. And a file whose calibration
the config's checks refuse was reported as ``--set: …`` although nothing was set.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.config.servo_file import (
    ActuatorFit,
    CalibrationPoint,
    ServoCalibrationFile,
    fitted_servo,
    now_iso,
)
from mearm.exceptions import ConfigError

SIM = ROOT / "configs" / "sim.yaml"


def _base_file(path: Path, zero_us: float) -> Path:
    """A calibration of the paper arm's base (600 … 2400 µs, 10 µs/deg) at ``zero_us``."""
    config = load_config(SIM)
    template = config.arm.joints[0].servo
    servo = fitted_servo(template, "base", zero_us, 10.0)
    points = (
        CalibrationPoint(50, round(zero_us + 500)),
        CalibrationPoint(130, round(zero_us + 1300)),
    )
    fit = ActuatorFit("base", "deg", servo, points, 0.0, replaces=template)
    path.write_text(ServoCalibrationFile(config.arm.name, "test", "", now_iso(), (fit,)).text())
    return path


def test_the_file_keeps_a_range_the_config_narrowed(tmp_path):
    """Base narrowed to 700 … 2000 µs in the config, the file says 600 … 2400: 700 … 2000."""
    servo_file = _base_file(tmp_path / "base.servos.yaml", 600.0)
    config = load_config(
        SIM,
        [
            "arm.joints.base.servo.min_us=700",
            "arm.joints.base.servo.max_us=2000",
            "arm.joints.base.limits={min: 20, max: 140}",
            f"servo.calibration_file={servo_file}",
        ],
    )
    servo = config.arm.joints[0].servo
    assert (servo.min_us, servo.max_us) == (700, 2000)


def test_a_file_the_config_refuses_is_named(tmp_path):
    """No --set given: the error names the calibration file, not ``--set``."""
    servo_file = _base_file(tmp_path / "far.servos.yaml", 2000.0)  # 20° needs 2200 µs
    config_path = tmp_path / "my.yaml"
    config_path.write_text(f"extends: {SIM}\nservo:\n  calibration_file: {servo_file}\n")
    with pytest.raises(ConfigError) as exc:
        load_config(config_path)
    message = str(exc.value)
    assert message.startswith(f"{servo_file}: arm.joints.base.limits"), message
