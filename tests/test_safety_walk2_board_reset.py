"""A board that restarted between two commands gets nothing more: the real firmware in simavr.

A brown-out reboots the Uno's ATmega328P on its own (the USB chip stays up, and the
bootloader starts the sketch at once after a reset that was not external): the firmware
prints its banner and sends no pulse, the arm's pose unknown. The host used to write its
next command first and read the banner after it, so the freshly booted firmware made that
move before the host raised ``BoardResetError``.
"""

from __future__ import annotations

import pytest
from conftest import firmware_build, simulator_build
from fakeboard import SimavrBoard
from hardware_helpers import HOME, command, fast_config

from mearm.hardware import ArduinoBus, ArmState
from mearm.hardware.errors import BoardResetError, ServoFaultedError


@pytest.fixture
def chip(tmp_path_factory):
    firmware_build(tmp_path_factory)
    folder = simulator_build(tmp_path_factory)
    with SimavrBoard(str(folder / "mearm_sim"), str(folder / "mearm_servo.elf")) as board:
        yield board


@pytest.mark.heavy
def test_a_board_that_restarted_during_a_pause_gets_no_move(chip):
    # generous timeouts: simavr on a loaded machine is slow, and a hang is the failure
    config = fast_config("serial", chip.port, banner_timeout_s=30.0, ack_timeout_s=30.0)
    with ArduinoBus(config.arm, config.servo) as bus:
        bus.move(HOME)
        chip._restart()  # a brown-out while the host pauses: the chip boots again
        chip.sleep_s(0.5)  # its banner is printed within milliseconds of the boot
        assert chip.pulses == []  # the booted firmware sends no pulse until a move
        with pytest.raises(BoardResetError, match="restarted") as fault:
            bus.move(command(119.0, 93.5, -131.0))
        assert fault.value.last_state == ArmState.from_command(HOME)
        assert bus.state == ArmState.from_command(HOME)
        with pytest.raises(ServoFaultedError):
            bus.move(HOME)
        bus.stop()  # sends nothing after a fault
        chip.sleep_s(0.5)  # a move that reached the chip would be pulsing by now
        assert chip.pulses == [], "the restarted board was sent a move"
