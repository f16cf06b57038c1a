"""A board whose servo count cannot be moved on one line is refused at the handshake.

A move names every channel the board drives, and a line holds at most 80 characters.
A board that reported more channels than fit (another sketch, a corrupted build) passed
the handshake, and then every move failed to encode: a ``ValueError`` (an unexpected
error, a crash record), not a fault of the bus. The pty fake Uno stands in for the board.
"""

from __future__ import annotations

import pytest
from fakeboard import FakeMearmBoard
from hardware_helpers import HOME, fast_config

from mearm.backends import open_bus
from mearm.hardware import ArduinoBus
from mearm.hardware.errors import HandshakeError


def test_a_board_with_more_channels_than_a_line_holds_is_refused():
    with FakeMearmBoard(servo_count=15) as board:
        bus = open_bus(fast_config("serial", board.port))
        with pytest.raises(HandshakeError, match="15 servo channels"):
            bus.connect()
        assert not bus.is_connected
        assert board.moves == []


def test_the_most_channels_a_line_holds_still_move():
    """14 channels at 4 digits: ``255 M 2500 … 2500*HHHH`` is 80 characters, the most a
    line holds (15 would be 85)."""
    with FakeMearmBoard(servo_count=14) as board:
        bus = open_bus(fast_config("serial", board.port))
        assert isinstance(bus, ArduinoBus)
        with bus:
            bus.move(HOME)
        assert len(board.moves) == 1 and len(board.moves[0]) == 14
