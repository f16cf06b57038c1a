"""The SSC-32 backend against a fake SSC-32U on a pseudo-terminal."""

from __future__ import annotations

import logging

import pytest
from fakeboard import FakeSSC32Board, SSC32Faults
from hardware_helpers import HOME, command, fast_config, route

from mearm.exceptions import (
    GarbledReplyError,
    HandshakeError,
    InvalidCommandError,
    LinkDroppedError,
    NoAckError,
    ServoFaultedError,
)
from mearm.hardware import ArmCommand, ArmState, SSC32Bus, open_bus
from mearm.hardware.ssc32 import encode_group_move, encode_query_pulse


def connected(board: FakeSSC32Board, **servo) -> SSC32Bus:
    bus = open_bus(fast_config("ssc32", board.port, **servo))
    assert isinstance(bus, SSC32Bus)
    bus.connect()
    return bus


def test_frames_byte_exact():
    """Group moves list channels in ascending order, T last, ending in a carriage return."""
    assert encode_group_move({4: 1000, 0: 1800, 2: 1080, 1: 1530, 3: 2100}, 20) == (
        b"#0P1800#1P1530#2P1080#3P2100#4P1000T20\r"
    )
    assert encode_group_move({5: 500}) == b"#5P500\r"
    assert encode_query_pulse(31) == b"QP31\r"


@pytest.mark.parametrize(
    ("pulses", "time_ms", "match"),
    [({32: 1500}, None, "channels are 0..31"), ({0: 499}, None, "500..2500"),
     ({0: 2501}, None, "500..2500"), ({0: 1500}, 0, "1..65535 ms")],
)  # fmt: skip
def test_frame_errors(pulses, time_ms, match):
    with pytest.raises(ValueError, match=match):
        encode_group_move(pulses, time_ms)


def test_handshake_and_move():
    """VER identifies the board; each move is one group move with T = the period, then Q."""
    with FakeSSC32Board() as board, connected(board, rate_hz=50.0) as bus:
        assert bus.version == "SSC32-V2.50USB"
        bus.move(HOME)
        assert board.received == [b"VER", b"#0P1800#1P1530#2P1080#3P2100#4P1000T20", b"Q"]
        assert board.moves[-1] == ({0: 1800, 1: 1530, 2: 1080, 3: 2100, 4: 1000}, 20)
        assert bus.state == ArmState.from_command(HOME)
        assert bus.is_moving() is True  # T20 still running
        assert bus.wait_until_done(1.0) is True and bus.is_moving() is False


def test_stop_holds_at_queried_pulses():
    """stop() reads every channel with QP and commands those pulses without T."""
    with FakeSSC32Board() as board, connected(board) as bus:
        bus.move(command(120.0, 93.0, -132.0, 60.0, closed=True))
        bus.stop()
        assert board.received[-7:-2] == [b"QP0", b"QP1", b"QP2", b"QP3", b"QP4"]
        assert board.received[-2:] == [b"#0P1800#1P1530#2P1080#3P2100#4P1900", b"Q"]


def test_misnamed_command_refused_before_sending():
    """A command naming a joint the arm lacks sends nothing to the SSC-32 either."""
    with FakeSSC32Board() as board, connected(board) as bus:
        before = list(board.received)
        with pytest.raises(InvalidCommandError, match="names unknown wrist_roll"):
            bus.move(ArmCommand({**HOME.joints, "wrist_roll": 0.0}, HOME.tool))
        assert board.received == before == [b"VER"] and bus.state is None


def test_silent_board():
    """No answer to VER: NoAckError naming the query."""
    with FakeSSC32Board(SSC32Faults(silent=True)) as board:
        bus = open_bus(fast_config("ssc32", board.port))
        with pytest.raises(NoAckError, match="VER"):
            bus.connect()
        assert not bus.is_connected


def test_not_an_ssc32():
    """A board answering VER with something else is refused."""
    with FakeSSC32Board(SSC32Faults(version=b"mearm_servo")) as board:
        with pytest.raises(HandshakeError, match="not an SSC-32"):
            connected(board)


def test_garbled_q_retried_then_ok(caplog):
    """A junk byte instead of '.'/'+' is logged and Q resent."""
    with FakeSSC32Board(SSC32Faults(garbage_q=2)) as board, connected(board) as bus:
        with caplog.at_level(logging.WARNING):
            bus.move(HOME)
        assert board.received[-3:] == [b"Q", b"Q", b"Q"]
        assert sum("answered" in r.message for r in caplog.records) == 2


def test_garbled_q_every_try_raises():
    """Junk on every Q: GarbledReplyError with the tries and the last pose; nothing after."""
    with FakeSSC32Board() as board:
        bus = connected(board)
        bus.move(route(2)[0])
        board.faults.garbage_q = 100
        with pytest.raises(GarbledReplyError) as err:
            bus.move(route(2)[1])
        assert err.value.attempts == 3 and err.value.reply == b"\x87"
        assert err.value.last_state == ArmState.from_command(route(2)[0])
        sent = list(board.received)
        with pytest.raises(ServoFaultedError):
            bus.move(HOME)
        assert board.received == sent


def test_link_dropped_mid_route():
    """The cable pulled mid-route: LinkDroppedError with the last confirmed pose."""
    with FakeSSC32Board(SSC32Faults(drop_at_move=3)) as board:
        bus = connected(board)
        with pytest.raises(LinkDroppedError) as err:
            for cmd in route(5):
                bus.move(cmd)
        assert err.value.last_state == ArmState.from_command(route(2)[-1])
        with pytest.raises(ServoFaultedError):
            bus.move(HOME)
        bus.close()
