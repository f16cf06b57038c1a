"""A servo calibration file that narrowed a joint's limits keeps the arm's own.

The paper arm's base: its own calibration 0° at 600 µs, 10 µs/°, limits 20 … 160°. A
servo of 12 µs/° at 520 µs (8° off at the neutral pulse) reaches 156.66° at most inside
600 … 2400 µs, so its fit narrows the limits to 20 … 156.66° and the file records that,
and the arm's own 20 … 160° in ``replaces``. A config using the file holds only the
narrowed limits: :func:`replaced_calibration` put back zero, direction and µs per unit
but not the limits (the virtual Uno's stops stayed narrowed), and a recalibration over
the file was narrowed against 20 … 156.66°, which the servo reaches: it recorded no
limits, and the file it wrote loaded with no config (``arm.joints.base.limits.max: 160
needs a 2440 µs pulse, outside the servo's [600, 2400] µs``). The camera's procedure on a
real board recorded the file's fit as ``replaces``, every other path the arm's own.
"""

from __future__ import annotations

import io
from pathlib import Path
from types import SimpleNamespace

import pytest

from mearm.config import Config, load_config
from mearm.config.servo_file import load_servo_calibration, replaced_calibration
from mearm.hardware import ServoMap
from mearm.maker import calibrate_by_camera
from mearm.maker.keyboard_calibration.calibrator import Calibrator
from mearm.maker.keyboard_calibration.pulse_session import PulseSession, open_arm_bus
from mearm.maker.keyboard_calibration.references import Actuator, actuators_of
from mearm.maker.servo_output import write_calibration
from mearm.sim.virtual_uno import uno_bus

HEADER = """\
format: mearm-servo-calibration
version: 1
kind: servos
arm: mearm_paper
board_id: a real board
port: ''
date: '2026-12-01T00:00:00+00:00'
actuators:
"""
#: The base at 12 µs/°, its limits narrowed to what it reaches; the arm's own recorded.
NARROWING = (
    HEADER
    + """\
  base:
    {channel: 0, unit: deg, zero_us: 520.0, direction: 1, us_per_unit: 12.0, min_us: 600,
     max_us: 2400, residual_us: 0.0, limits: {min: 20.0, max: 156.66},
     replaces: {zero_us: 600.0, direction: 1, us_per_unit: 10.0,
                limits: {min: 20.0, max: 160.0}}}
"""
)
#: The same, written before the arm's own limits were recorded.
OLD = NARROWING.replace(",\n                limits: {min: 20.0, max: 160.0}", "")
#: The base servo's true map (zero [µs], µs per degree): the maker finds its pulses.
LINE = (520.0, 12.0)
#: What the servo reaches of the arm's limits [deg].
REACHED = (20.0, 156.66)


def _config(path: Path | None = None, *extra: str) -> Config:
    sets = ["servo.backend=sim", "task.scene=[]", *extra]
    if path is not None:
        sets.append(f"servo.calibration_file={path}")
    return load_config(None, overrides=sets)


def _file(tmp_path: Path, text: str, name: str = "servos.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _limits(config: Config, name: str = "base") -> tuple[float, float]:
    r = config.arm.joint_limits()[name]
    return (r.min, r.max)


class TrueMaker(Calibrator):
    """A maker who reads the base exactly: each reference at the servo's true pulse (the
    pulse recorded, not sent: the kinematic sim checks a long sweep for collisions)."""

    line = LINE

    def _jog_until_recorded(self, act: Actuator, ref: float) -> str:
        zero, slope = self.line
        self.session.pulses_us[act.name] = round(zero + slope * ref)
        return "record"

    def refuse(self, act: Actuator, exc: Exception) -> None:  # type: ignore[override]
        raise AssertionError(f"refused: {exc}")  # the same pulses would be refused again


def _recalibrate_base(config: Config, output: Path, line: tuple[float, float] = LINE) -> None:
    (base,) = [a for a in actuators_of(config) if a.name == "base"]
    with open_arm_bus(config) as bus:
        session = PulseSession(config, bus)
        session.send()
        maker = TrueMaker(config, session, None, io.StringIO())
        maker.line = line
        fit = maker.calibrate(base, 1, 1)
    assert fit is not None
    assert write_calibration(config, [fit], "a real board", "", output, force=True) == 0


def test_the_arm_s_own_limits_are_put_back(tmp_path: Path) -> None:
    """With the file the base has 20 … 156.66°; the calibration it replaced, 20 … 160°
    (it gave 20 … 156.66°)."""
    config = _config(_file(tmp_path, NARROWING))
    assert _limits(config) == REACHED
    before = replaced_calibration(config)
    assert before is not None
    assert _limits(before) == (20.0, 160.0) == _limits(_config())
    assert before.arm.joints[0].servo is not None
    assert before.arm.joints[0].servo.zero_us == 600.0


def test_limits_the_config_narrowed_since_stay_its_own(tmp_path: Path) -> None:
    """A config whose base limits are 30 … 150° (narrower than the file's) has those
    before the file too: the file's record of the arm's own is older."""
    narrow = "arm.joints.base.limits={min: 30.0, max: 150.0}"
    config = _config(_file(tmp_path, NARROWING), narrow)
    before = replaced_calibration(config)
    assert before is not None
    assert _limits(config) == _limits(before) == (30.0, 150.0)


def test_an_old_file_still_loads_its_narrowed_limits_kept(tmp_path: Path) -> None:
    """A file that does not record the arm's own limits loads; before it the limits are
    the narrowed ones (the arm's own are not known)."""
    config = _config(_file(tmp_path, OLD))
    before = replaced_calibration(config)
    assert before is not None
    assert _limits(config) == _limits(before) == REACHED
    (base,) = load_servo_calibration(tmp_path / "servos.yaml").actuators
    assert base.own_limits is None


def test_recalibrating_over_a_narrowing_file_writes_a_file_that_loads(tmp_path: Path) -> None:
    """The same servo fitted again over the file: narrowed against the arm's own 20 …
    160°, the fit records 20 … 156.66° and the arm's own, and a config loads it (it
    recorded no limits, and loading it was refused: 160° needs 2440 µs)."""
    config = _config(_file(tmp_path, NARROWING))
    output = tmp_path / "again.yaml"
    _recalibrate_base(config, output)
    (base,) = load_servo_calibration(output).actuators
    assert (base.servo.zero_us, base.servo.us_per_unit) == pytest.approx(LINE)
    assert base.limits == REACHED
    assert base.own_limits == (20.0, 160.0)
    again = _config(output)
    assert _limits(again) == REACHED
    before = replaced_calibration(again)
    assert before is not None
    assert _limits(before) == (20.0, 160.0)


def test_recalibrating_over_an_old_narrowing_file_keeps_its_narrowing(tmp_path: Path) -> None:
    """Over a file that does not say the arm's own limits, the fit keeps at least the
    file's narrowing, and the file it writes loads."""
    config = _config(_file(tmp_path, OLD))
    output = tmp_path / "again.yaml"
    _recalibrate_base(config, output)
    (base,) = load_servo_calibration(output).actuators
    assert base.limits == REACHED
    assert base.own_limits is None
    assert _limits(_config(output)) == REACHED


def test_a_fit_that_reaches_the_arm_s_limits_records_none(tmp_path: Path) -> None:
    """A servo recalibrated to the arm's own map reaches 20 … 160°: the file narrows
    nothing and records no limits, so the config's are the arm's own again."""
    config = _config(_file(tmp_path, NARROWING))
    output = tmp_path / "again.yaml"
    _recalibrate_base(config, output, (600.0, 10.0))
    (base,) = load_servo_calibration(output).actuators
    assert (base.limits, base.own_limits) == (None, None)
    assert "limits" not in output.read_text()
    assert _limits(_config(output)) == (20.0, 160.0)


def test_the_virtual_uno_stops_at_the_arm_s_own_limits(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The virtual Uno's base stops at 20 and 160°, not at the file's 156.66° (the board is
    not built: only its stops are looked at)."""
    monkeypatch.setattr(uno_bus, "build_virtual_uno", lambda defines: None)
    config = _config(_file(tmp_path, NARROWING))
    bus = uno_bus.VirtualUnoBus(config)
    assert (bus._stops["base"].min, bus._stops["base"].max) == (20.0, 160.0)


def test_the_camera_s_fit_on_a_real_board_replaces_the_arm_s_own(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On a real board the camera's fit, made over the file, records the arm's own base
    (600 µs) as ``replaces``, not the file's fit (520 µs), and the arm's own limits."""
    config = _config(_file(tmp_path, NARROWING))
    for name in ("report", "_park", "seen_points"):
        monkeypatch.setattr(calibrate_by_camera, name, lambda *a, **k: {})
    servos = [j for j in ServoMap.from_arm(config.arm).joints if j.name == "base"]
    fit = SimpleNamespace(servos=servos)
    session = SimpleNamespace(
        run=lambda: fit,
        present=config,
        above=[],
        below=[],
        claw=None,
        say=lambda text: None,
        out=io.StringIO(),
        motion_s=lambda: 0.0,
        rising_play_us=lambda fit: {},
    )
    (base,) = calibrate_by_camera.measure(session)  # type: ignore[arg-type]
    assert base.replaces is not None
    assert base.replaces.zero_us == 600.0
    assert (base.limits, base.own_limits) == (REACHED, (20.0, 160.0))
