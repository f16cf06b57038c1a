"""A banner with noise before it on its line is a banner: at connect and mid-session.

A restarting ATmega328P can put a byte or two on the wire before its banner (its TX pin
floats while the chip resets; 0x00 and 0xF0 are the usual ones), with no newline between.
The host took such a line for junk: at connect it waited out ``servo.banner_timeout_s``
and said no banner came (quoting the banner it had received), and mid-session it dropped
the line as unasked and sent the next move to the freshly booted board, which made it.
"""

from __future__ import annotations

import time

import pytest
from fakeboard import FakeMearmBoard, MearmFaults
from hardware_helpers import HOME, command, fast_config

from mearm.hardware import ArduinoBus, ArmState
from mearm.hardware.errors import BoardResetError, FirmwareVersionError
from mearm.hardware.mearm_protocol import (
    BadChecksum,
    Reply,
    Unparseable,
    decode_line,
    decode_protocol1_banner,
    encode_line,
)

BANNER = encode_line("READY mearm_servo 2.0 5").rstrip(b"\n")


@pytest.mark.parametrize("noise", [b"\x00", b"\xf0", b"\x00\xfe", b"READY \xff"])
def test_a_banner_after_noise_on_its_line_is_decoded_as_the_banner(noise):
    decoded = decode_line(noise + BANNER + b"\n")
    assert isinstance(decoded, Reply) and decoded.kind == "READY"
    assert decoded.raw == BANNER
    assert decode_protocol1_banner(noise + b"READY mearm_servo 1.0 5*25") is not None


def test_only_a_whole_banner_frame_is_found_after_noise():
    assert isinstance(decode_line(b"\x00" + encode_line("OK 3")), Unparseable)
    assert isinstance(decode_line(b"\x00" + BANNER[:-1] + b"0"), Unparseable)  # its CRC wrong
    assert isinstance(decode_line(b"x" + BANNER[:-1] + b"0"), BadChecksum)


@pytest.mark.parametrize("noise", [b"\x00", b"\x00\xfe"])
def test_connects_to_a_board_whose_banner_follows_noise(noise):
    with FakeMearmBoard(MearmFaults(boot_noise=noise)) as board:
        config = fast_config("serial", board.port, banner_timeout_s=5.0)  # a hang bound
        with ArduinoBus(config.arm, config.servo) as bus:
            assert bus.banner == BANNER
            bus.move(HOME)
        assert board.moves == [[1800, 1530, 1080, 2100, 1000]]


def test_connect_refuses_a_protocol_1_board_whose_banner_follows_noise():
    faults = MearmFaults(boot_noise=b"\x00READY mearm_servo 1.0 5*25\n", banner=False)
    with FakeMearmBoard(faults) as board:
        config = fast_config("serial", board.port, banner_timeout_s=5.0)
        with pytest.raises(FirmwareVersionError, match="mearm_servo 1.0"):
            ArduinoBus(config.arm, config.servo).connect()
        assert board.received == []  # refused from its banner, nothing sent


def test_a_board_that_restarted_with_noise_before_its_banner_gets_no_move():
    with FakeMearmBoard(MearmFaults(boot_noise=b"")) as board:
        config = fast_config("serial", board.port, ack_timeout_s=5.0)
        with ArduinoBus(config.arm, config.servo) as bus:
            bus.move(HOME)
            board.faults.boot_noise = b"\x00"
            lines_before = len(board.received)
            board.on_open()  # a brown-out while the host pauses: reboot, noise, banner
            time.sleep(0.1)
            with pytest.raises(BoardResetError, match="restarted"):
                bus.move(command(119.0, 93.5, -131.0))
            assert bus.state == ArmState.from_command(HOME)
        assert board.received[lines_before:] == []  # the rebooted board got nothing
        assert board.moves == []
