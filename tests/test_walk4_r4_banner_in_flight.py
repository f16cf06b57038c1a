"""A board whose restart banner is still arriving when the next command is due gets nothing.

A brown-out reboots the Uno; its firmware prints the banner at once, 29 bytes that take
2.5 ms at 115200 baud and may reach the host in more than one USB packet. The host reads
what arrived since the last reply before it writes (``ArduinoBus._settle``); it used to
look at whole lines only, so with ``READY mear`` in its buffer it wrote the next move,
which the freshly booted firmware makes at once, and only then read the rest of the banner.
"""

from __future__ import annotations

import threading
import time

import pytest
from fakeboard import FakeMearmBoard, MearmFaults
from hardware_helpers import HOME, command, fast_config

from mearm.hardware import ArduinoBus, ArmState
from mearm.hardware.errors import BoardResetError
from mearm.hardware.mearm_protocol import encode_line

BANNER = encode_line("READY mearm_servo 2.0 5")


class BrownOutBoard(FakeMearmBoard):
    """The fake Uno, rebooted on demand with its banner sent in two parts."""

    def __init__(self) -> None:
        self.lines_before_reset: int | None = None
        self._rest: tuple[float, bytes] | None = None
        super().__init__(MearmFaults(boot_noise=b""))  # starts the serving thread

    def brown_out(self, head: int, rest_after_s: float) -> None:
        """Reboot; send ``head`` bytes of the banner now and the rest ``rest_after_s`` later."""
        self._reboot()
        self.lines_before_reset = len(self.received)
        self._rest = (time.monotonic() + rest_after_s, BANNER[head:])
        self.send(BANNER[:head])

    def on_tick(self) -> None:
        if self._rest is not None and time.monotonic() >= self._rest[0]:
            self.send(self._rest[1])
            self._rest = None


@pytest.mark.parametrize("head", [1, 10, len(BANNER) - 1])
def test_a_banner_half_arrived_stops_the_next_move_before_it_is_sent(head):
    with BrownOutBoard() as board:
        config = fast_config("serial", board.port, ack_timeout_s=5.0)  # a hang bound only
        with ArduinoBus(config.arm, config.servo) as bus:
            bus.move(HOME)
            board.brown_out(head, rest_after_s=0.3)
            time.sleep(0.1)  # the banner's head is in the host's buffer, its end is not
            with pytest.raises(BoardResetError, match="restarted"):
                bus.move(command(119.0, 93.5, -131.0))
            assert bus.state == ArmState.from_command(HOME)
        assert board.lines_before_reset is not None
        assert board.received[board.lines_before_reset :] == [], "the rebooted board got a line"
        assert board.moves == []  # the fresh firmware made no move


def test_a_notice_half_arrived_is_read_whole_and_the_move_goes_out():
    """A line still arriving is waited for, not taken for junk: a ``! HOLD`` notice split
    in two is logged as a notice, and the next move is sent and acknowledged as usual."""
    with FakeMearmBoard(MearmFaults(boot_noise=b"")) as board:
        config = fast_config("serial", board.port, ack_timeout_s=5.0)
        with ArduinoBus(config.arm, config.servo) as bus:
            bus.move(HOME)
            notice = encode_line("! HOLD")
            board.send(notice[:3])
            time.sleep(0.1)
            later = threading.Timer(0.2, board.send, args=(notice[3:],))
            later.start()
            bus.move(command(119.0, 93.5, -131.0))
            later.join()
            assert bus.state == ArmState.from_command(command(119.0, 93.5, -131.0))
        assert len(board.moves) == 2
