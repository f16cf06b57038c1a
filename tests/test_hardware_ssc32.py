"""The SSC-32 backend against a fake SSC-32U on a pseudo-terminal.

Every fault test ends the same way (:func:`assert_fault_end_state`): the error and the
bus hold the last confirmed pose, the fake received no group move after the fault
struck, and ``stop()`` and later moves send nothing.
"""

from __future__ import annotations

import logging
import time

import pytest
from fakeboard import FakeSSC32Board, SSC32Faults
from hardware_helpers import HOME, command, fast_config, route, timed_move

from mearm.backends import open_bus
from mearm.exceptions import (
    BoardResetError,
    GarbledReplyError,
    HandshakeError,
    InvalidCommandError,
    LinkDroppedError,
    MoveNotConfirmedError,
    NoAckError,
    ServoError,
    ServoFaultedError,
    UnsolicitedBytesError,
)
from mearm.hardware import ArmCommand, ArmState, SSC32Bus
from mearm.hardware.ssc32 import (
    encode_group_move,
    encode_query_pulse,
    encode_status_query,
    looks_like_banner,
)

STATUS = [b"Q", b"QP0", b"QP1", b"QP2", b"QP3", b"QP4"]


def connected(board: FakeSSC32Board, **servo) -> SSC32Bus:
    """A bus connected to ``board``; its first answer may take 2 s (a loaded CI worker once
    starved the fake board's thread past 0.5 s there, before the fault under test)."""
    servo = {"banner_timeout_s": 2.0, **servo}
    bus = open_bus(fast_config("ssc32", board.port, **servo))
    assert isinstance(bus, SSC32Bus)
    bus.connect()
    return bus


def drive_until_fault(bus: SSC32Bus, n: int = 6) -> ServoError:
    """Send a route; return the error that stopped it."""
    with pytest.raises(ServoError) as err:
        for cmd in route(n):
            bus.move(cmd)
    return err.value


def assert_fault_end_state(
    bus: SSC32Bus, board: FakeSSC32Board, fault: ServoError, confirmed: int
) -> None:
    """The last confirmed pose is kept, and no move was or will be sent after the fault."""
    last = ArmState.from_command(route(confirmed)[-1]) if confirmed else None
    assert fault.last_state == last and bus.state == last and bus.fault is fault
    assert board.fault_line is not None, "the fault never struck"
    assert board.moves_after_fault() == []
    board.drained()  # (the queries that found the fault may still be in the pty)
    sent = list(board.received)
    with pytest.raises(ServoFaultedError) as again:
        bus.move(HOME)
    assert again.value.fault is fault
    bus.stop()
    bus.close()
    board.drained()
    assert board.received == sent


# ------------------------------------------------------------------ frames


def test_frames_byte_exact():
    """Group moves list channels in ascending order, T last, ending in a carriage return."""
    assert encode_group_move({4: 1000, 0: 1800, 2: 1080, 1: 1530, 3: 2100}, 20) == (
        b"#0P1800#1P1530#2P1080#3P2100#4P1000T20\r"
    )
    assert encode_group_move({5: 500}) == b"#5P500\r"
    assert encode_query_pulse(31) == b"QP31\r"
    assert encode_status_query([0, 2]) == b"Q\rQP0\rQP2\r"


@pytest.mark.parametrize(
    ("pulses", "time_ms", "match"),
    [({32: 1500}, None, "channels are 0..31"), ({0: 499}, None, "500..2500"),
     ({0: 2501}, None, "500..2500"), ({0: 1500}, 0, "1..65535 ms")],
)  # fmt: skip
def test_frame_errors(pulses, time_ms, match):
    with pytest.raises(ValueError, match=match):
        encode_group_move(pulses, time_ms)


def test_banner_recognised():
    assert looks_like_banner(b"\x00SSC32-V2.50USB") and looks_like_banner(b"ssc-32 v2")
    assert not looks_like_banner(b"READY mearm_servo 2.0 5*8003")


# ------------------------------------------------------------------ the happy path


def test_handshake_move_and_confirmation():
    """VER identifies the board; a move is one group move with T = the period, then Q and
    QP of every channel in one write; it returns once the move is done and read back."""
    with FakeSSC32Board() as board, connected(board, rate_hz=50.0) as bus:
        assert bus.version == "SSC32-V2.50USB"
        t0 = time.monotonic()
        bus.move(HOME)
        assert time.monotonic() - t0 >= 0.020
        head, status = board.received[:2], board.received[2:]
        assert head == [b"VER", b"#0P1800#1P1530#2P1080#3P2100#4P1000T20"]
        # Q and QP of every channel, asked again while the board still glides (on a loaded
        # machine the fake board's 20 ms glide can outlast the first answer)
        assert status and status == STATUS * (len(status) // len(STATUS))
        assert board.moves[-1] == ({0: 1800, 1: 1530, 2: 1080, 3: 2100, 4: 1000}, 20)
        assert bus.state == ArmState.from_command(HOME)
        assert bus.is_moving() is False and bus.wait_until_done(1.0) is True


def test_confirmation_waits_while_the_board_still_moves():
    """A move that runs past its T: Q answers '+' (and QP pulses on the way) until it is
    done; only then is the move confirmed."""
    with FakeSSC32Board(SSC32Faults(slow_s=0.05)) as board, connected(board) as bus:
        bus.move(HOME)
        bus.move(route(2)[1])
        assert board.received.count(b"Q") > 3
        assert bus.state == ArmState.from_command(route(2)[1])
        assert bus.fault is None


def test_stop_sends_nothing_and_holds_the_confirmed_pose():
    """stop() commands no move and no fixed pulse: the board keeps the confirmed pulses."""
    with FakeSSC32Board() as board, connected(board) as bus:
        closed = command(120.0, 93.0, -132.0, 60.0, closed=True)
        bus.move(closed)
        sent, pulses = list(board.received), dict(board.pulses_us)
        bus.stop()
        board.drained()
        assert board.received == sent and board.pulses_us == pulses
        assert pulses == {0: 1800, 1: 1530, 2: 1080, 3: 2100, 4: 1900}
        assert bus.state == ArmState.from_command(closed) and bus.fault is None


def test_misnamed_command_refused_before_sending():
    """A command naming a joint the arm lacks sends nothing to the SSC-32 either."""
    with FakeSSC32Board() as board, connected(board) as bus:
        before = list(board.received)
        with pytest.raises(InvalidCommandError, match="names unknown wrist_roll"):
            bus.move(ArmCommand({**HOME.joints, "wrist_roll": 0.0}, HOME.tool))
        assert board.received == before == [b"VER"] and bus.state is None


def test_the_first_answer_may_take_the_banner_timeout_not_the_ack_timeout():
    """A board slow to answer its first VER (0.8 s; the ack timeout 0.5 s) is connected:
    at connect it has the time the config gives a board to say what it is, as the Uno's
    banner. A loaded CI worker once starved the fake board past the 0.5 s."""
    with FakeSSC32Board(SSC32Faults(ver_delay_s=0.8)) as board:
        bus = open_bus(fast_config("ssc32", board.port, banner_timeout_s=3.0))
        assert isinstance(bus, SSC32Bus) and bus.link.ack_timeout_s == 0.5
        with bus:
            bus.connect()
            assert bus.version == "SSC32-V2.50USB"


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


def test_version_line_ending_cr_lf():
    """A board ending its version line in CR LF: the LF is no stray byte, at the
    handshake or at a resync."""
    faults = SSC32Faults(ver_reply=b"SSC32-V2.50USB\r\n", fault_at_move=2, lost_answers=1)
    with FakeSSC32Board(faults) as board, connected(board) as bus:
        for cmd in route(3):
            bus.move(cmd)
        assert board.received.count(b"VER") == 2 and bus.fault is None


def test_wire_bytes_per_move():
    """Move, status query and its answer: the period is the move's T and all of them on
    the wire, which cannot overlap the glide (the answer must say done)."""
    bus = open_bus(fast_config("ssc32", rate_hz=50.0, baud=2400))
    move = len(b"#0P2500#1P2500#2P2500#3P2500#4P2500T65535\r")
    assert bus.wire_bytes_per_move == move + len(b"Q\rQP0\rQP1\rQP2\rQP3\rQP4\r") + 6
    assert bus.move_time_ms == 20
    assert bus.period_s == pytest.approx(0.020 + 10 * bus.wire_bytes_per_move / 2400)


def test_the_rate_limiter_counts_the_confirmation_exchange():
    """At 4800 baud a move and its confirmation spend 146 ms on the wire: each move still
    glides over the 20 ms step the stream planned (T20), and moves start no closer than
    T and the wire time together."""
    with FakeSSC32Board() as board, connected(board, rate_hz=50.0, baud=4800) as bus:
        assert bus.period_s == pytest.approx(0.020 + 10 * bus.wire_bytes_per_move / 4800)
        periods: list[float] = []
        real_wait = bus._rate.wait
        bus._rate.wait = lambda period_s: periods.append(period_s) or real_wait(period_s)
        for pose in route(3):
            bus.move(pose)
        assert [t for _, t in board.moves] == [20, 20, 20]
        assert periods == [bus.period_s] * 3  # the pacing counts the exchange
        # each move asked about once its glide is due; again if the fake board, its thread
        # late on a loaded machine, still glides (seen in the suite: 5 queries for 3 moves)
        assert board.received.count(b"Q") >= 3


@pytest.mark.parametrize("baud", [2400, 9600, 115200])
def test_a_stream_takes_a_period_a_step_and_glides_each_within_the_speed_limits(baud):
    """The executor sizes each step for the move's glide (T, 20 ms) and counts a period
    for it (T and the wire: 93 ms at 9600 baud), so the reported motion time is the time
    the board takes; the steps do not depend on the baud rate."""
    import numpy as np

    config = fast_config("ssc32", rate_hz=50.0, baud=baud)
    bus = SSC32Bus(config.arm, config.servo)
    executor, timed = timed_move(config, bus, 0.3)
    chain = executor.chain
    steps = len(timed.q) - 1
    assert bus.step_s == 0.020 and steps >= 5
    assert timed.duration_s == pytest.approx(steps * bus.period_s)
    assert executor.motion.stream_hz == pytest.approx(1.0 / bus.period_s)
    limits = executor.limits
    travel = np.abs(np.diff(limits.values(chain.actuated_of(timed.q)), axis=0))
    assert np.all(travel <= limits.velocity * bus.step_s * (1 + 1e-6))
    assert travel.max() > 0.5 * limits.velocity.min() * bus.step_s  # not crawling


# ------------------------------------------------------------------ recovered, never desynced


def test_garbled_q_resynced_and_retried(caplog):
    """A junk byte instead of '.'/'+': each try logged, VER resynchronises, Q asked again.

    (Each failed try is logged as answered with the junk, or, when the junk reaches a
    loaded host after the try's wait, as no complete answer: seen in CI's script.)
    """
    with FakeSSC32Board(SSC32Faults(garbage_q=2)) as board, connected(board) as bus:
        with caplog.at_level(logging.WARNING):
            bus.move(HOME)
        assert board.received[2:] == [*STATUS, b"VER", *STATUS, b"VER", *STATUS]
        tries = [r.message for r in caplog.records if "try" in r.message]
        assert len(tries) == 2 and all(
            "answered" in t or "no complete answer" in t for t in tries
        ), tries
        assert bus.state == ArmState.from_command(HOME)


def test_lost_reply_resynced_and_retried(caplog):
    """One answer never comes: after the timeout VER resynchronises and the query is
    asked again; the move is confirmed and the next moves read their own answers."""
    faults = SSC32Faults(fault_at_move=2, lost_answers=1)
    with FakeSSC32Board(faults) as board, connected(board) as bus:
        with caplog.at_level(logging.WARNING):
            for cmd in route(4):
                bus.move(cmd)
        assert board.received.count(b"VER") == 2
        assert any("no complete answer" in r.message for r in caplog.records)
        assert bus.state == ArmState.from_command(route(4)[-1]) and bus.fault is None


def test_late_stale_reply_is_never_read_as_a_later_answer(caplog):
    """A whole answer arrives after the timeout, holding what an earlier query would have
    had ('+', the previous pulses). Were it read as the answer to the retry, the move
    would not be confirmed; it is discarded by the resync, and every move confirms.

    The answer comes 0.5 s after the 1 s timeout, and the resync's own answer, queued
    behind it, 0.5 s before the resync's timeout: margins a loaded machine keeps (at
    0.15 s and 0.2 s a delayed host read the late answer as on time)."""
    faults = SSC32Faults(fault_at_move=2, late_answers=6, late_s=1.5, stale_late=True)
    with FakeSSC32Board(faults) as board, connected(board, ack_timeout_s=1.0) as bus:
        with caplog.at_level(logging.WARNING):
            for cmd in route(4):
                bus.move(cmd)
        discarded = [r.message for r in caplog.records if "discarded 6 late" in r.message]
        assert len(discarded) == 1 and "+" in discarded[0]
        assert bus.state == ArmState.from_command(route(4)[-1]) and bus.fault is None
        assert len(board.moves) == 4


# ------------------------------------------------------------------ faults


def test_fault_late_replies():
    """Every answer later than the resync waits: NoAckError, nothing moves after it."""
    faults = SSC32Faults(fault_at_move=3, late_answers=10**6, late_s=30.0)
    with FakeSSC32Board(faults) as board:
        bus = connected(board)
        t0 = time.monotonic()
        fault = drive_until_fault(bus)
        assert time.monotonic() - t0 < 15.0  # gave up long before the 30 s answers came
        assert isinstance(fault, NoAckError) and fault.frame == b"VER\r"
        assert_fault_end_state(bus, board, fault, confirmed=2)


@pytest.mark.heavy
def test_fault_lost_replies(caplog):
    """Answers lost on every try: NoAckError after 1 + retries tries, each logged."""
    with FakeSSC32Board(SSC32Faults(fault_at_move=3, lost_answers=10**6)) as board:
        bus = connected(board)
        with caplog.at_level(logging.WARNING):
            fault = drive_until_fault(bus)
        assert isinstance(fault, NoAckError) and "no acknowledgement" in str(fault)
        assert sum("no complete answer" in r.message for r in caplog.records) == 3
        assert board.received.count(b"VER") == 3
        assert_fault_end_state(bus, board, fault, confirmed=2)


def test_fault_garbage():
    """Junk instead of every answer: GarbledReplyError after 1 + retries tries."""
    with FakeSSC32Board(SSC32Faults(fault_at_move=2, garbage_answers=10**6)) as board:
        bus = connected(board)
        fault = drive_until_fault(bus)
        assert isinstance(fault, GarbledReplyError) and fault.attempts == 3
        assert fault.reply == b"\x87" * 6
        assert_fault_end_state(bus, board, fault, confirmed=1)


def test_fault_pulse_read_back_differs():
    """QP reads 100 µs off the pulse sent: MoveNotConfirmedError naming the channels."""
    with FakeSSC32Board(SSC32Faults(fault_at_move=3, wrong_qp_us=100)) as board:
        bus = connected(board)
        fault = drive_until_fault(bus)
        assert isinstance(fault, MoveNotConfirmedError)
        sent = fault.expected_us
        assert fault.reported_us == {ch: us + 100 for ch, us in sent.items()}
        assert f"channel 0 reads {sent[0] + 100} µs, sent {sent[0]} µs" in str(fault)
        assert_fault_end_state(bus, board, fault, confirmed=2)


def test_fault_reset_mid_move():
    """The board restarts on a move (banner, limp channels): BoardResetError."""
    with FakeSSC32Board(SSC32Faults(reset_at_move=3)) as board:
        bus = connected(board)
        fault = drive_until_fault(bus)
        assert isinstance(fault, BoardResetError) and "restarted" in str(fault)
        assert "SSC32-V2.50USB" in str(fault) and board.resets == 1
        assert_fault_end_state(bus, board, fault, confirmed=2)


def test_fault_reset_mid_move_without_banner():
    """A restart whose banner is lost still shows: every channel reads 0 (limp)."""
    with FakeSSC32Board(SSC32Faults(reset_at_move=2, banner_on_reset=False)) as board:
        bus = connected(board)
        fault = drive_until_fault(bus)
        assert isinstance(fault, BoardResetError) and "reads no pulse" in str(fault)
        assert_fault_end_state(bus, board, fault, confirmed=1)


def test_fault_reset_between_moves():
    """The banner arrives unasked between moves: BoardResetError before the next move."""
    faults = SSC32Faults(stray_after_move=(2, b"SSC32-V2.50USB\r"))
    with FakeSSC32Board(faults) as board:
        bus = connected(board)
        bus.move(route(2)[0])
        bus.move(route(2)[1])
        time.sleep(0.02)
        with pytest.raises(BoardResetError) as err:
            bus.move(route(3)[2])
        assert_fault_end_state(bus, board, err.value, confirmed=2)


def test_fault_unsolicited_bytes():
    """Bytes no query asked for: UnsolicitedBytesError before the next move is sent."""
    with FakeSSC32Board(SSC32Faults(stray_after_move=(1, b"\x00" * 50))) as board:
        bus = connected(board)
        bus.move(route(1)[0])
        time.sleep(0.02)
        with pytest.raises(UnsolicitedBytesError) as err:
            bus.move(route(2)[1])
        assert err.value.received == b"\x00" * 50
        assert_fault_end_state(bus, board, err.value, confirmed=1)


def test_fault_a_byte_too_many_after_the_answer():
    """One byte more than asked, after a complete answer: caught before the next move.

    The byte follows the answer that confirms move 2. A host that has taken that answer
    keeps move 2 as confirmed; a loaded host may still be asking about move 2 when the
    byte arrives, and then keeps move 1. Either way nothing more is sent.
    """
    with FakeSSC32Board(SSC32Faults(stray_after_move=(2, b"."))) as board:
        bus = connected(board)
        fault = drive_until_fault(bus)
        assert isinstance(fault, UnsolicitedBytesError) and fault.received == b"."
        two = ArmState.from_command(route(2)[-1])
        assert_fault_end_state(bus, board, fault, confirmed=2 if fault.last_state == two else 1)


def test_a_byte_too_many_inside_the_answer_is_asked_again(caplog):
    """An extra byte inside an answer shifts the rest: the pulses read back say nothing,
    and the answer runs a byte long. Until 2026-12-07 that stopped the bus with
    ``channel 0 reads 460 µs, sent 1500 µs``, blaming the servo for the line's noise; the
    query is now asked again after a resync, and the move confirmed."""
    faults = SSC32Faults(fault_at_move=2, extra_answers=1)
    with FakeSSC32Board(faults) as board, connected(board) as bus:
        with caplog.at_level(logging.WARNING):
            for cmd in route(4):
                bus.move(cmd)
        assert faults.extra_answers == 0  # the byte was sent
        assert board.received.count(b"VER") == 2  # the handshake, and the resync
        assert any("try 1/3" in r.message for r in caplog.records), caplog.text
        assert bus.state == ArmState.from_command(route(4)[-1]) and bus.fault is None


def test_fault_a_byte_too_many_inside_every_answer():
    """Every try's answer a byte long: GarbledReplyError naming it, not a pulse."""
    with FakeSSC32Board(SSC32Faults(fault_at_move=2, extra_answers=100)) as board:
        bus = connected(board)
        fault = drive_until_fault(bus)
        assert isinstance(fault, GarbledReplyError) and not isinstance(fault, MoveNotConfirmedError)
        assert "an answer longer than the" in str(fault), fault
        assert_fault_end_state(bus, board, fault, confirmed=1)


def test_fault_never_done():
    """Q answers '+' for ack_timeout_s past the move's T: MoveNotConfirmedError."""
    with FakeSSC32Board(SSC32Faults(fault_at_move=2, moving_forever=True)) as board:
        bus = connected(board)
        fault = drive_until_fault(bus)
        assert isinstance(fault, MoveNotConfirmedError) and "still moving" in str(fault)
        assert fault.reported_us == {}
        assert_fault_end_state(bus, board, fault, confirmed=1)


def test_link_dropped_mid_route():
    """The cable pulled mid-route: LinkDroppedError with the last confirmed pose."""
    with FakeSSC32Board(SSC32Faults(drop_at_move=3)) as board:
        bus = connected(board)
        fault = drive_until_fault(bus)
        assert isinstance(fault, LinkDroppedError)
        assert fault.last_state == ArmState.from_command(route(2)[-1])
        with pytest.raises(ServoFaultedError):
            bus.move(HOME)
        bus.close()


def test_reconnect_after_fault_clears_it():
    """close + connect after a fault gives a working bus again."""
    with FakeSSC32Board(SSC32Faults(fault_at_move=2, lost_answers=10**6)) as board:
        bus = connected(board)
        drive_until_fault(bus, 3)
        bus.close()
        board.faults.lost_answers = 0
        bus.connect()
        assert bus.fault is None and bus.state is None
        bus.move(HOME)
        assert bus.state == ArmState.from_command(HOME)
        bus.close()
