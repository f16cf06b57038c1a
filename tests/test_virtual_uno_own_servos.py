"""The virtual Uno's servos are its own: they turn by the rig's calibration, not the host's.

A simulated board stands for a physical one. The host makes its pulses by its present
map — a servo calibration file fitted to the board, or the map ``calibrate-servos`` puts
on the bus while it measures — and the rig's servos turn each pulse by theirs: the paper
arm's calibration as described, before any fitted file. Read back through the host's map,
the arm always ended where the host intended, and a calibration done on the virtual Uno
could never find an error.

The fitted file here says the base's servo is at 0° at 650 µs (the arm's: 600 µs) and the
shoulder's at 450 µs with 11 µs/° (the arm's: 600 µs, 10 µs/°); for base 90° and shoulder
100° the host sends 1550 and 1550 µs, which the rig's servos turn to 95° and 95°.
"""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
from test_maker_own_servos import _config as rig_config
from test_virtual_uno import cache_home  # noqa: F401  (a fixture)

from mearm.config import Config
from mearm.hardware import ArmCommand, ServoMap
from mearm.sim import World
from mearm.sim.kinematic.joint_stops import joints_at_stops
from mearm.sim.virtual_uno import VirtualUnoBus
from mearm.sim.virtual_uno.own_servos import own_servo_map

#: A servo calibration file fitted off the paper arm's servos; each entry's ``replaces``
#: (:data:`REPLACES`, the arm's own: 0° at 600 µs, 10 µs/°) optional.
FITTED = """\
format: mearm-servo-calibration
version: 1
kind: servos
arm: mearm_paper
board_id: 'simulated: the virtual Uno, the firmware in simavr'
port: /dev/pts/0
date: '2026-12-01T00:00:00+00:00'
actuators:
  base:
    {{channel: 0, unit: deg, zero_us: 650.0, direction: 1, us_per_unit: 10.0,
     min_us: 600, max_us: 2400, residual_us: 0.0{base_replaces}}}
  shoulder:
    {{channel: 1, unit: deg, zero_us: 450.0, direction: 1, us_per_unit: 11.0,
     min_us: 600, max_us: 2400, residual_us: 0.0{shoulder_replaces}}}
"""
REPLACES = ", replaces: {zero_us: 600.0, direction: 1, us_per_unit: 10.0}"
#: Where the host sends the arm (inside every limit, clear of the empty table).
COMMAND = ArmCommand({"base": 90.0, "shoulder": 100.0, "elbow": -90.0}, {"gripper_arm": 0.0})
#: Where the rig's own servos take that command under the fitted map [deg].
OWN_BASE_DEG = (650.0 + 10.0 * 90.0 - 600.0) / 10.0
OWN_SHOULDER_DEG = (450.0 + 11.0 * 100.0 - 600.0) / 10.0


def _config(calibration: Path | None = None) -> Config:
    """The paper rig on the virtual Uno, with the servo calibration file if given."""
    return rig_config("virtual_uno", calibration)


def _fitted(tmp_path: Path, *, replaces: bool = True) -> Path:
    path = tmp_path / "servos.yaml"
    extra = REPLACES if replaces else ""
    path.write_text(FITTED.format(base_replaces=extra, shoulder_replaces=extra))
    return path


def _tolerance_deg(config: Config) -> float:
    """How far a measured pulse may put a 10 µs/° servo from the sent one's value [deg]."""
    return config.servo.virtual_uno.pulse_tolerance_us / 10.0


def test_the_rig_servos_are_the_calibration_the_file_replaced(tmp_path: Path) -> None:
    """A fitted file changes the host's map, not the rig's servos: they are the arm's own."""
    config = _config(_fitted(tmp_path))
    own = own_servo_map(config)
    assert own == ServoMap.from_arm(_config().arm)
    assert ServoMap.from_arm(config.arm)["base"].zero_us == 650.0  # the host's: the fit


def test_without_a_file_the_rig_servos_are_the_config_s() -> None:
    """No servo calibration file: the rig's servos are the host's map, to the bit."""
    config = _config()
    assert own_servo_map(config) == ServoMap.from_arm(config.arm)


def test_a_file_that_records_nothing_replaced_is_taken_as_the_rig_s_with_a_warning(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A file written before ``replaces`` was recorded: its calibration, and a warning."""
    path = _fitted(tmp_path, replaces=False)
    config = _config(path)
    with caplog.at_level(logging.WARNING, logger="mearm.sim.virtual_uno.own_servos"):
        own = own_servo_map(config)
    assert own == ServoMap.from_arm(config.arm)
    assert f"{path} records no replaced calibration" in caplog.text


def test_the_sort_says_so_without_debug(tmp_path: Path) -> None:
    """The warning is a log record, seen with --debug only; the sort's start-up line
    says it too (until 2026-12-06 the docs' "with a warning" showed nowhere else)."""
    from mearm.task.check import calibration_note

    path = _fitted(tmp_path, replaces=False)
    note = calibration_note(_config(path), ["--config", "rig.yaml"])
    assert note is not None
    assert note.startswith(f"warning: {path} records no calibration it replaced")
    assert "mearm calibrate-servos again" in note
    assert calibration_note(_config(_fitted(tmp_path)), []) is None  # with replaces


@pytest.mark.heavy
def test_a_fitted_file_moves_the_arm_by_the_rig_s_servos(
    tmp_path: Path,
    cache_home: Path,  # noqa: F811  (the fixture imported above)
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """With a fitted file the host sends its pulses (1550 µs for base 90°) and the arm
    ends where the rig's servos turn them (base 95°, shoulder 95°), not where the host
    believed (90°, 100°)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    config = _config(_fitted(tmp_path))
    tolerance = _tolerance_deg(config)
    with VirtualUnoBus(config, World()) as bus:
        bus.move(COMMAND)
        pulses = bus.measured_pulses_us()
        assert pulses[0] == pytest.approx(1550, abs=10)
        assert pulses[1] == pytest.approx(1550, abs=10)
        joints = bus.actual_joints
    assert joints["base"] == pytest.approx(OWN_BASE_DEG, abs=tolerance)
    assert joints["shoulder"] == pytest.approx(OWN_SHOULDER_DEG, abs=tolerance)
    assert joints["elbow"] == pytest.approx(-90.0, abs=tolerance)  # not in the file


@pytest.mark.heavy
def test_a_map_put_on_the_bus_moves_the_arm_by_the_rig_s_servos(
    tmp_path: Path,
    cache_home: Path,  # noqa: F811  (the fixture imported above)
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``calibrate-servos`` puts its map on the bus while it measures: the rig's servos
    stay the ones the bus was opened with."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    config = _config()
    fitted_map = ServoMap.from_arm(_config(_fitted(tmp_path)).arm)
    tolerance = _tolerance_deg(config)
    with VirtualUnoBus(config, World()) as bus:
        bus.servo_map = fitted_map
        bus.move(COMMAND)
        joints = bus.actual_joints
    assert joints["base"] == pytest.approx(OWN_BASE_DEG, abs=tolerance)
    assert joints["shoulder"] == pytest.approx(OWN_SHOULDER_DEG, abs=tolerance)


@pytest.mark.heavy
def test_without_a_fitted_map_the_arm_ends_as_the_host_s_map_reads_the_pulses(
    cache_home: Path,  # noqa: F811  (the fixture imported above)
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """No fitted map: the joints are the host's map's reading of the measured frame, to
    the bit, and where the command sent them."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    config = _config()
    with VirtualUnoBus(config, World()) as bus:
        bus.move(COMMAND)
        pulses = bus.measured_pulses_us()
        smap = bus.servo_map
        joints = bus.actual_joints
    servo = {j.name: j.value_of(pulses[j.channel]) for j in smap.joints}
    assert joints == joints_at_stops(smap, servo, config.arm.joint_limits())
    for name, value in COMMAND.joints.items():
        assert joints[name] == pytest.approx(value, abs=_tolerance_deg(config))
