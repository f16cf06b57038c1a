"""Calibrations that cannot be wrong quietly, and rigs that were never calibrated.

A fit far from the arm's own slope, or one that puts the limits outside the servo's pulse
range, is refused and nothing is written; a sort that a calibration file stops names the
file; a sort on servos never calibrated says so and runs. Real parts: the arm files, the
fit, the config's checks, the twin and the sort.
"""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest

from mearm import sort
from mearm.config import load_config
from mearm.config.servo_file import (
    CalibrationPoint,
    ServoCalibrationError,
    ServoCalibrationFile,
    apply_servo_calibration,
    check_fit,
    fit_actuator,
    fit_span,
    load_servo_calibration,
    narrowed,
    narrowing_text,
    save_servo_calibration,
    servo_of,
)
from mearm.errors import ConfigError
from mearm.maker import calibrate_servos
from mearm.task.check import calibration_note, check_consistency

ROOT = Path(__file__).resolve().parent.parent
V1 = ROOT / "configs" / "sim_mearm_v1.yaml"
V1_TWIN = ROOT / "configs" / "sim_mearm_v1_mujoco.yaml"
FIVE_TWIN = ROOT / "configs" / "sim_5dof_mujoco.yaml"
#: What the simulated keyboard calibration recorded for the MeArm v1's elbow servo when its
#: shoulder stood at 120° (issue 38): the elbow on its stop, the shoulder turned instead.
ISSUE_ELBOW = [CalibrationPoint(-45.0, 708), CalibrationPoint(45.0, 2028)]


def _fit(config_path: Path, name: str, points: list[CalibrationPoint], span: bool = True):
    arm = load_config(config_path).arm
    unit = "cm" if name == arm.tool.gripper.name else "deg"
    ends = fit_span(arm, name)[1:] if span else None
    return arm, fit_actuator(name, unit, servo_of(arm, name), points, ends)


def test_the_issues_elbow_fit_is_refused_naming_the_range_or_narrows_the_elbow():
    """Zero 1368 µs, 14.667 µs/deg: the forearm over the elbow's limits at home needs
    488 µs, outside the SG90's 544–2400 µs; refused, naming what and by how much. Its
    slope and zero within what real units and horns give, the fit narrows the elbow's
    limits to what its servo reaches instead, and says so."""
    arm, fit = _fit(V1, "elbow", ISSUE_ELBOW)
    assert fit.servo.us_per_unit == pytest.approx(1320 / 90)  # no line nearer keeps it inside
    with pytest.raises(ServoCalibrationError) as caught:
        check_fit(arm, fit, servo_of(arm, "elbow"))
    text = str(caught.value)
    assert "elbow's servo (shoulder + elbow) over elbow's limits, the other joints at home" in text
    assert "[-60, 70] deg, at [488, 2395] µs, outside the servo's [544, 2400] µs" in text
    assert "redo the references" in text
    fit = narrowed(arm, fit)
    assert fit.limits == (-146.18, -20.0)  # (544 - 1368) / 14.667 less shoulder's home 90
    check_fit(arm, fit, servo_of(arm, "elbow"))
    text = narrowing_text(arm, fit)
    assert "elbow: limits narrowed from [-150, -20] to [-146.18, -20] deg" in text


@pytest.mark.parametrize(
    ("name", "points", "words"),
    [
        # 17.3 µs per degree of forearm: 40 % steeper than the arm file's 12.373
        ("elbow", [CalibrationPoint(-10, 1299), CalibrationPoint(10, 1645)], "+40% off"),
        # the base at 7 µs/deg inside its pulse range: 36 % below the file's 11
        ("base", [CalibrationPoint(65, 1800), CalibrationPoint(115, 1450)], "-36% off"),
    ],
)
def test_a_slope_far_from_the_arms_is_refused(name, points, words):
    """More than 30 % from the arm file's µs per unit: a misread reference, not a servo."""
    arm, fit = _fit(V1, name, points)
    with pytest.raises(ServoCalibrationError, match="real servos differ by at most ±30%") as e:
        check_fit(arm, fit, servo_of(arm, name))
    assert words in str(e.value) and "redo the references" in str(e.value)


def test_the_arms_own_calibration_passes_its_checks():
    """The arm file's calibration, measured exactly, is a fit the checks take."""
    arm, fit = _fit(V1, "elbow", [CalibrationPoint(-45, 915), CalibrationPoint(45, 2029)])
    check_fit(arm, fit, servo_of(arm, "elbow"))
    assert fit.servo.us_per_unit == pytest.approx(12.3733, rel=1e-3)


def test_limits_that_span_the_whole_pulse_range_take_the_nearest_line_inside():
    """The 5-DOF wrist's ±90° are exactly 600–2400 µs: a reading 0.5° off puts an end a
    few µs out. The line through the points would be refused by the config; the nearest
    line that keeps the limits inside passes within a degree of both points and is taken.
    A point 3° off is not bent to fit: the fit stays outside and is refused."""
    points = [CalibrationPoint(-55, 957), CalibrationPoint(55, 2055)]
    arm, free = _fit(FIVE_TWIN, "wrist_pitch", points, span=False)
    assert free.servo.pulse_us(90.0) > 2400  # the plain line leaves the range
    arm, fit = _fit(FIVE_TWIN, "wrist_pitch", points)
    assert 600 < fit.servo.pulse_us(-90.0) and fit.servo.pulse_us(90.0) < 2400
    assert 0 < fit.residual_us <= 1.0 * fit.servo.us_per_unit
    check_fit(arm, fit, servo_of(arm, "wrist_pitch"))
    config = apply_servo_calibration(load_config(FIVE_TWIN), [fit])
    assert config.arm.joints[3].servo.zero_us == pytest.approx(fit.servo.zero_us, abs=1e-3)
    far = [CalibrationPoint(-55, 957), CalibrationPoint(55, 2085)]
    arm, off = _fit(FIVE_TWIN, "wrist_pitch", far)
    assert off.servo.pulse_us(90.0) > 2400  # 3° past: left as it is
    with pytest.raises(ServoCalibrationError, match=r"outside the servo's \[600, 2400\] µs"):
        check_fit(arm, off, servo_of(arm, "wrist_pitch"))


@pytest.mark.heavy
def test_a_refused_simulated_calibration_writes_nothing_and_exits_1(tmp_path, capsys):
    """Read 10° off (a protractor misread; reading seed 2), the 5-DOF shoulder's fit puts
    its shaft 16° off the arm's at the neutral pulse twice, more than a unit's centring and
    its horn's tooth give: exit 1, one line on stderr, the file already there untouched,
    no .bak. (A fit that only misses the ends of a joint's limits narrows them instead.)"""
    arm, fit = _fit(FIVE_TWIN, "base_yaw", [CalibrationPoint(35, 950), CalibrationPoint(145, 2050)])
    cal = ServoCalibrationFile(arm.name, "before", "", "2026-01-01T00:00:00+00:00", (fit,))
    out = save_servo_calibration(tmp_path / "five.servos.yaml", cal)
    before = out.read_bytes()
    argv = ["--config", str(FIVE_TWIN), "--simulate", "--output", str(out), "--force"]
    with pytest.raises(SystemExit) as e:
        calibrate_servos.run(
            calibrate_servos.main, [*argv, "--reading-error", "10", "--reading-seed", "2"]
        )
    assert e.value.code == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "fit refused twice" in err[0] and "nothing written" in err[0]
    assert "off the arm's at the neutral 1500 µs" in err[0]
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [out.name]


def _bad_elbow_file(tmp_path: Path, replaces: bool = True) -> Path:
    """The issue's elbow fit written as a file (it is no longer made by the command)."""
    arm, fit = _fit(V1, "elbow", ISSUE_ELBOW, span=False)
    if not replaces:
        fit = type(fit)(fit.name, fit.unit, fit.servo, fit.points, fit.residual_us, None)
    cal = ServoCalibrationFile(arm.name, "test", "", "2026-01-01T00:00:00+00:00", (fit,))
    path = save_servo_calibration(tmp_path / "v1.servos.yaml", cal)
    assert load_servo_calibration(path).actuators[0].replaces is not None or not replaces
    return path


def test_a_start_up_failure_the_calibration_file_causes_names_it(tmp_path):
    """The issue's file: the picks are reached nowhere with it, and everywhere they need
    without it; the error says so first (a CLI's one line cuts long ones at the end)."""
    path = _bad_elbow_file(tmp_path)
    config = load_config(V1, [f"servo.calibration_file={path}"])
    with pytest.raises(ConfigError) as caught:
        check_consistency(config)
    (problem,) = caught.value.problems
    assert problem.startswith(
        f"with the servo calibration from {path} (without it this holds: re-run mearm "
        "calibrate-servos or remove servo.calibration_file): task.classes.red."
    )
    assert "are reached nowhere in arm.target_box" in problem
    check_consistency(load_config(V1))  # the arm's own calibration: no problem


def test_a_file_naming_an_actuator_the_arm_lacks_is_named(tmp_path):
    """A calibration of another arm's servo: the error says which file, and which
    actuators this arm has."""
    arm, fit = _fit(V1, "elbow", [CalibrationPoint(-45, 915), CalibrationPoint(45, 2029)])
    knee = type(fit)("knee", fit.unit, fit.servo, fit.points, fit.residual_us, None)
    cal = ServoCalibrationFile(arm.name, "test", "", "2026-01-01T00:00:00+00:00", (knee,))
    path = save_servo_calibration(tmp_path / "knee.servos.yaml", cal)
    with pytest.raises(ServoCalibrationError) as caught:
        load_config(V1, [f"servo.calibration_file={path}"])
    assert str(caught.value).startswith(f"{path}: the calibration names 'knee'")
    assert "its actuators: base, shoulder, elbow" in str(caught.value)


def test_a_file_that_does_not_record_what_it_replaced_is_named_as_a_maybe(tmp_path):
    path = _bad_elbow_file(tmp_path, replaces=False)
    config = load_config(V1, [f"servo.calibration_file={path}"])
    with pytest.raises(ConfigError, match=r"from .*v1\.servos\.yaml \(maybe the cause: re-run"):
        check_consistency(config)


def test_a_failure_the_file_does_not_cause_does_not_name_it(tmp_path):
    """The arm's own calibration as a file, and picks above the target box: the problem is
    the box, with or without the file, and the message says only that."""
    arm, fit = _fit(V1, "elbow", [CalibrationPoint(-45, 915), CalibrationPoint(45, 2029)])
    cal = ServoCalibrationFile(arm.name, "test", "", "2026-01-01T00:00:00+00:00", (fit,))
    path = save_servo_calibration(tmp_path / "good.servos.yaml", cal)
    sets = [f"servo.calibration_file={path}", "arm.target_box.z_cm.min=5"]
    with pytest.raises(ConfigError) as caught:
        check_consistency(load_config(V1, sets))
    assert "outside arm.target_box.z_cm" in str(caught.value)
    assert "servo calibration" not in str(caught.value)


@pytest.mark.heavy
def test_the_sort_stops_on_such_a_file_with_one_line_naming_it(tmp_path, capsys):
    path = _bad_elbow_file(tmp_path)
    argv = ["--config", str(V1), "--set", f"servo.calibration_file={path}"]
    with pytest.raises(SystemExit) as e:
        sort.run(sort.main, argv)
    assert e.value.code == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert f"with the servo calibration from {path}" in line and "re-run mearm" in line


@pytest.mark.parametrize(
    ("config", "sets", "simulate"),
    [
        ("lab.yaml", [], False),
        ("sim.yaml", ["servo.backend=ssc32"], False),
        ("sim_mujoco_kits.yaml", [], True),
        ("sim_mearm_v1_mujoco.yaml", ["twin.kit.seed=3", "twin.kit.spread=0.12"], True),
    ],
)
def test_servos_never_calibrated_are_noticed(config, sets, simulate):
    """Real boards and the twin's kits: one line naming the command that calibrates them."""
    path = str(ROOT / "configs" / config)
    args = ["--config", path, *(a for s in sets for a in ("--set", s))]
    note = calibration_note(load_config(path, sets), args)
    assert note is not None and "\n" not in note
    command = shlex.join(["mearm", "calibrate-servos", *args, *(["--simulate"] * simulate)])
    assert note.startswith("note: ") and note.endswith(f"run {command}")
    assert "have never been calibrated (no servo.calibration_file)" in note


@pytest.mark.parametrize(
    "config",
    [
        "sim.yaml",  # the simulated arm: its servos are the config's
        "sim_mujoco.yaml",  # the twin with nominal servos
        "virtual_uno.yaml",  # the firmware's pulses: no servo to calibrate
    ],
)
def test_rigs_without_real_servos_get_no_note(config):
    path = ROOT / "configs" / config
    assert calibration_note(load_config(path), ["--config", str(path)]) is None


def test_a_calibration_file_silences_the_note(tmp_path):
    """The real board with a servo calibration file: nothing to say."""
    lab = ROOT / "configs" / "lab.yaml"
    arm, fit = _fit(lab, "base", [CalibrationPoint(60, 1200), CalibrationPoint(120, 1800)])
    cal = ServoCalibrationFile(arm.name, "test", "", "2026-01-01T00:00:00+00:00", (fit,))
    path = save_servo_calibration(tmp_path / "lab.servos.yaml", cal)
    config = load_config(lab, [f"servo.calibration_file={path}"])
    assert calibration_note(config, ["--config", str(lab)]) is None


def test_a_file_calibrated_on_a_simulated_board_is_named_on_a_real_one(tmp_path):
    """A file ``calibrate-servos --config virtual_uno`` wrote names its board as simulated;
    on the real board it was taken without a word (the board was never read back)."""
    lab = ROOT / "configs" / "lab.yaml"
    arm, fit = _fit(lab, "base", [CalibrationPoint(60, 1200), CalibrationPoint(120, 1800)])
    board = "simulated: the virtual Uno, the firmware in simavr (mearm_servo 2.0 5)"
    cal = ServoCalibrationFile(arm.name, board, "", "2026-01-01T00:00:00+00:00", (fit,))
    path = save_servo_calibration(tmp_path / "vu.servos.yaml", cal)
    config = load_config(lab, [f"servo.calibration_file={path}"])
    note = calibration_note(config, ["--config", str(lab)])
    assert note is not None
    assert note.startswith(f"note: {path} was calibrated on a simulated board ({board})")


@pytest.mark.heavy
def test_a_sort_on_an_uncalibrated_kit_says_so_first_and_runs(capsys):
    """The note is the first line on stderr, the sort runs to its summary; --quiet drops it."""
    kit = ["--set", "twin.kit.seed=3", "--set", "twin.kit.spread=0.12"]
    argv = ["--config", str(V1_TWIN), *kit, "--random", "1", "--seed", "0"]
    code = sort.main(argv)
    out, err = capsys.readouterr()
    assert code in (0, 1)  # the sort ran; the nominal calibration may be good enough
    assert out.strip().splitlines()[-1].startswith("sorted ")
    first = err.strip().splitlines()[0]
    assert first.startswith("mearm sort: note: the servos of the twin's kit (twin.kit) have")
    assert first.endswith(f"mearm calibrate-servos --config {V1_TWIN} {' '.join(kit)} --simulate")
    sort.main([*argv, "--quiet"])
    assert "note:" not in capsys.readouterr().err
