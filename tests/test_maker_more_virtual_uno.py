"""``calibrate-servos`` reads a simulated board's pins through an interface, not by name.

A bus whose board measures the pulses it outputs says so by
:class:`~mearm.hardware.bus.MeasuresPulses` (its
``measured_pulses_us``): the virtual Uno's bus does, and the calibration session reads a
tool actuator's or the gripper's value from it, mapped through the present calibration
(not the widened map the session sends with). The session is driven in-process, first
over the kinematic arm with a stand-in for a board that measures its pins (a mocked
board: its pulses read a few µs off those sent, so a reading from the commands shows),
then over the real virtual Uno (the firmware in simavr).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from test_maker_calibrate import ROOT
from test_virtual_uno import cache_home  # noqa: F401  (a fixture)

from mearm.config import Config, config_from_dict, load_config
from mearm.hardware import ArmCommand
from mearm.maker.keyboard_calibration.pulse_session import PulseSession
from mearm.sim import World
from mearm.sim.kinematic.servo_bus import SimArm

SIM = load_config(ROOT / "configs" / "sim.yaml")
#: How far the stand-in board's measured pulses are off those sent [µs].
OFF_US = 7


class PinMeasuringArm(SimArm):
    """The kinematic arm behind a board that measures its pins: every pulse reads
    :data:`OFF_US` wider than the one sent. Only the measuring method is there, no
    ``last_frame``: the interface, nothing the virtual Uno's bus happens to hold."""

    def __init__(self, config: Config):
        super().__init__(config, World())
        self.sent_us: dict[int, int] = {}

    def _send_move(self, command: ArmCommand, pulses_us: dict[int, int]) -> None:
        super()._send_move(command, pulses_us)
        self.sent_us = dict(pulses_us)

    def measured_pulses_us(self) -> dict[int, float]:
        """Channel → the measured width [µs]."""
        return {channel: pulse + OFF_US for channel, pulse in self.sent_us.items()}


@pytest.mark.parametrize("name", ["gripper", "gripper_arm"])
def test_a_bus_that_measures_its_pins_gives_the_readings(name):
    """The gripper (which the kinematic arm only opens or closes) and the tool actuator
    read as the board's measured pulse under the present calibration, 7 µs off the one
    sent; they follow the pulse; a pin the board left silent has no reading."""
    with PinMeasuringArm(SIM) as bus:
        session = PulseSession(SIM, bus)
        session.send()
        a = session.servo_map[name]
        for pulse in (session.pulses_us[name], session.pulses_us[name] + 40):
            session.set_pulse(name, pulse)
            assert session.simulated_value(name) == pytest.approx(a.value_of(pulse + OFF_US))
        bus.sent_us.pop(a.channel)
        assert session.simulated_value(name) is None


def test_the_kinematic_arm_has_no_reading_of_the_gripper():
    """Without the interface (the kinematic arm itself): no gripper reading, as before."""
    with SimArm(SIM, World()) as bus:
        session = PulseSession(SIM, bus)
        session.send()
        assert session.simulated and session.simulated_value("gripper") is None
        assert session.simulated_value("gripper_arm") == pytest.approx(
            session.servo_map["gripper_arm"].value_of(session.pulses_us["gripper_arm"])
        )


@pytest.mark.heavy
def test_the_virtual_unos_bus_reports_what_its_board_measured(
    cache_home: Path,  # noqa: F811  (the fixture imported above)
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The virtual Uno's bus is a MeasuresPulses: nothing measured before the first move,
    then every channel's pulse within the board's tolerance of the one sent; a session
    over it reads the gripper 40 µs on from its start through the present calibration."""
    from mearm.hardware.bus import MeasuresPulses
    from mearm.sim.virtual_uno import VirtualUnoBus

    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    config = config_from_dict(
        {"servo": {"backend": "virtual_uno", "ack_timeout_s": 10.0, "virtual_uno": {"speed": 0}}}
    )
    tolerance = config.servo.virtual_uno.pulse_tolerance_us
    with VirtualUnoBus(config) as bus:
        assert isinstance(bus, MeasuresPulses)
        assert bus.measured_pulses_us() == {}
        home = ArmCommand.home(config.arm)
        bus.move(home)
        sent = bus.servo_map.pulses_us(home)
        measured = bus.measured_pulses_us()
        assert set(measured) == set(sent)
        for channel, pulse in sent.items():
            assert measured[channel] == pytest.approx(pulse, abs=tolerance)
        session = PulseSession(config, bus)
        g = session.servo_map.gripper
        pulse = session.pulses_us[g.name] + 40
        session.set_pulse(g.name, pulse)
        reading = session.simulated_value(g.name)
        assert reading == pytest.approx(g.value_of(pulse), abs=tolerance / g.us_per_unit)
        assert reading == pytest.approx(g.value_of(bus.measured_pulses_us()[g.channel]))
