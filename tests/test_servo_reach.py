"""A fitted servo that cannot reach a joint's whole limits narrows them; one far off is refused.

Real parts: the 5-DOF arm file (its wrist's and base's limits fill the servo's pulse
range), the fit, the file's writer and reader, the config loader and the sort's start-up.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from mearm import sort
from mearm.config import load_config
from mearm.config.servo_file import (
    CalibrationPoint,
    ServoCalibrationError,
    ServoCalibrationFile,
    check_fit,
    fit_actuator,
    fit_span,
    load_servo_calibration,
    narrowed,
    narrowing_text,
    save_servo_calibration,
    servo_of,
    servo_overrides,
)
from mearm.config.servo_reach import MAX_ZERO_OFF_DEG, zero_off_deg
from mearm.task.check import calibration_note

ROOT = Path(__file__).resolve().parent.parent
FIVE_TWIN = ROOT / "configs" / "sim_5dof_mujoco.yaml"
FIVE = ROOT / "configs" / "sim_5dof.yaml"
#: A wrist_pitch read 3° past its reference at 55°: 10.25 µs/deg, zero 1521 µs; its
#: line puts 90° at 2444 µs, past the servo's 2400.
STEEP_WRIST = [CalibrationPoint(-55, 957), CalibrationPoint(55, 2085)]


def _fit(name: str, points: list[CalibrationPoint], config: Path = FIVE_TWIN):
    arm = load_config(config).arm
    return arm, fit_actuator(name, "deg", servo_of(arm, name), points, fit_span(arm, name)[1:])


def _file(tmp_path: Path, fit, arm) -> Path:
    cal = ServoCalibrationFile(arm.name, "test", "", "2026-11-28T00:00:00+00:00", (fit,))
    return save_servo_calibration(tmp_path / "five.servos.yaml", cal)


def test_a_servo_that_reaches_less_narrows_its_limits_to_what_it_reaches():
    """Each limit the line cannot reach comes in to the last 0.01° it reaches; the checks
    then pass, and the change is said."""
    arm, fit = _fit("wrist_pitch", STEEP_WRIST)
    s = fit.servo
    assert s.pulse_us(-90.0) < s.min_us and s.pulse_us(90.0) > s.max_us  # both ends out
    with pytest.raises(ServoCalibrationError, match=r"outside the servo's \[600, 2400\] µs"):
        check_fit(arm, fit, servo_of(arm, "wrist_pitch"))
    fit = narrowed(arm, fit)
    lo, hi = fit.limits
    assert s.pulse_us(lo - 0.01) < s.min_us <= s.pulse_us(lo)
    assert s.pulse_us(hi) <= s.max_us < s.pulse_us(hi + 0.01)
    check_fit(arm, fit, servo_of(arm, "wrist_pitch"))
    assert narrowing_text(arm, fit) == (
        f"wrist_pitch: limits narrowed from [-90, 90] to [{lo:g}, {hi:g}] deg: its servo, as "
        "fitted, reaches no farther inside [600, 2400] µs"
    )


def test_a_servo_that_reaches_all_of_its_limits_is_not_narrowed():
    arm, fit = _fit("wrist_pitch", [CalibrationPoint(-55, 950), CalibrationPoint(55, 2050)])
    assert narrowed(arm, fit).limits is None
    assert narrowing_text(arm, narrowed(arm, fit)) is None


def test_the_file_keeps_narrowed_limits_and_a_config_that_uses_it_applies_them(tmp_path):
    """Written, read back, applied by the loader (never wider than the config's own), in
    the overrides printed, and named by the note a sort prints at start-up."""
    arm, fit = _fit("wrist_pitch", STEEP_WRIST)
    fit = narrowed(arm, fit)
    path = _file(tmp_path, fit, arm)
    assert load_servo_calibration(path).actuators[0].limits == fit.limits
    config = load_config(FIVE_TWIN, [f"servo.calibration_file={path}"])
    limits = config.arm.joint_limits()["wrist_pitch"]
    assert (limits.min, limits.max) == fit.limits
    note = calibration_note(config, ["--config", str(FIVE_TWIN)])
    assert note == (
        f"note: the servo calibration {path} narrows wrist_pitch to [{limits.min:g}, "
        f"{limits.max:g}] deg: its servos, as calibrated, reach no farther inside their "
        "pulse ranges"
    )
    lo, hi = fit.limits
    assert f"arm.joints.wrist_pitch.limits={{min: {lo!r}, max: {hi!r}}}" in (
        servo_overrides(arm, [fit])
    )
    narrower = ["arm.joints.wrist_pitch.limits={min: -85, max: 80}"]
    config = load_config(FIVE_TWIN, [*narrower, f"servo.calibration_file={path}"])
    limits = config.arm.joint_limits()["wrist_pitch"]
    assert (limits.min, limits.max) == (-85.0, 80.0)


@pytest.mark.heavy
def test_a_sort_says_which_limits_its_calibration_narrowed_before_it_moves(tmp_path, capsys):
    arm, fit = _fit("wrist_pitch", STEEP_WRIST)
    path = _file(tmp_path, narrowed(arm, fit), arm)
    argv = ["--config", str(FIVE), "--set", f"servo.calibration_file={path}", "--random", "1"]
    sort.main([*argv, "--seed", "2"])
    out, err = capsys.readouterr()
    assert out.strip().splitlines()[-1].startswith("sorted ")
    first = err.strip().splitlines()[0]
    assert first.startswith(f"mearm sort: note: the servo calibration {path} narrows wrist_pitch")


def test_a_narrowing_past_what_a_datasheet_allows_is_refused():
    """Twice the arm's µs per degree reaches half the base's limits: refused, not narrowed."""
    arm, fit = _fit("base_yaw", [CalibrationPoint(80, 1300), CalibrationPoint(100, 1700)])
    with pytest.raises(ServoCalibrationError) as caught:
        narrowed(arm, fit)
    text = str(caught.value)
    assert "base_yaw: the fit reaches only [" in text
    assert "a servo within its datasheet leaves at most 25% of them" in text


def test_a_narrowing_that_leaves_out_home_is_refused():
    """The wrist's home, -80°, would need a pulse below 600 µs: refused, naming it."""
    arm, fit = _fit("wrist_pitch", [CalibrationPoint(-50, 890), CalibrationPoint(50, 1890)])
    with pytest.raises(ServoCalibrationError, match="without its home -80"):
        narrowed(arm, fit)


@pytest.mark.parametrize(("off_deg", "refused"), [(10.0, False), (13.0, True)])
def test_a_zero_far_from_the_arms_is_refused(off_deg, refused):
    """A unit's centring (2°) and a horn on its nearest tooth (9°) keep its shaft within
    12° of the arm's at the neutral pulse: 10° is taken, 13° is not (the pulses 10° higher:
    the shaft 10° lower at the neutral pulse)."""
    shift = off_deg * 10.0  # the base's 10 µs per degree
    points = [CalibrationPoint(45, round(1050 + shift)), CalibrationPoint(135, round(1950 + shift))]
    arm, fit = _fit("base_yaw", points)
    fit = narrowed(arm, fit)
    assert zero_off_deg(fit, servo_of(arm, "base_yaw")) == pytest.approx(-off_deg)
    assert refused == (off_deg > MAX_ZERO_OFF_DEG)
    if refused:
        with pytest.raises(ServoCalibrationError, match=r"-13\.0° off the arm's at the neutral"):
            check_fit(arm, fit, servo_of(arm, "base_yaw"))
    else:
        check_fit(arm, fit, servo_of(arm, "base_yaw"))
        assert fit.limits is not None and math.isclose(fit.limits[1], 170.0)


@pytest.mark.parametrize(
    ("limits", "said"),
    [
        ("{min: 5, max: 1}", "wrist_pitch.limits: min (5) must be below max (1)"),
        ("[0, 1]", "wrist_pitch.limits must be {min: …, max: …}"),
        ("{min: 0, max: .inf}", "wrist_pitch.limits.max must be a number"),
    ],
)
def test_a_bad_limits_entry_is_refused_naming_it(tmp_path, limits, said):
    arm, fit = _fit("wrist_pitch", STEEP_WRIST)
    path = _file(tmp_path, narrowed(arm, fit), arm)
    text = path.read_text()
    start = text.index("limits: {min: ")
    end = text.index("}", start) + 1
    path.write_text(text[:start] + f"limits: {limits}" + text[end:])
    with pytest.raises(ServoCalibrationError, match=f"{path}: ") as caught:
        load_servo_calibration(path)
    assert said in str(caught.value)
