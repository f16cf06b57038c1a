"""The serial backend and our protocol, against a fake Uno on a pseudo-terminal."""

from __future__ import annotations

import dataclasses
import logging
import time

import pytest
from fakeboard import FakeMearmBoard, MearmFaults
from hardware_helpers import HOME, HOME_PULSES, command, fast_config, route, timed_move

from mearm.backends import open_bus
from mearm.config import Config
from mearm.exceptions import (
    BannerTimeoutError,
    BoardError,
    BoardResetError,
    ChecksumError,
    HandshakeError,
    InvalidCommandError,
    JointLimitError,
    LinkDroppedError,
    LinkError,
    NoAckError,
    PulseRangeError,
    ServoFaultedError,
    ServoNotConnectedError,
)
from mearm.hardware import ArduinoBus, ArmCommand, ArmState, ServoMap
from mearm.hardware.mearm_protocol import encode_command


def pulses_of(cmd: ArmCommand) -> list[int]:
    return list(ServoMap.from_arm(Config().arm).pulses_us(cmd).values())


def connected(board: FakeMearmBoard, **servo) -> ArduinoBus:
    bus = open_bus(fast_config("serial", board.port, **servo))
    assert isinstance(bus, ArduinoBus)
    bus.connect()
    return bus


@pytest.fixture
def board():
    with FakeMearmBoard() as b:
        yield b


# ------------------------------------------------------------------ the happy path


def test_handshake_reads_banner_and_version(board):
    """Connecting waits for the banner through boot noise, then asks V."""
    with connected(board) as bus:
        assert bus.banner == b"READY mearm_servo 2.0 5*8003"
        assert bus.firmware.name == "mearm_servo"
        assert bus.firmware.servo_count == 5
        assert (bus.firmware.min_us, bus.firmware.max_us) == (500, 2500)
        assert board.received == [b"0 V*F970"]
        assert bus.state is None


def test_move_sends_byte_exact_frame_and_confirms(board):
    """Home goes out as one M frame with every channel's pulse; the ack sets the state."""
    with connected(board) as bus:
        bus.move(HOME)
        assert board.received[-1] == b"1 M 1800 1530 1080 2100 1000*86A0"
        assert board.pulses_us == HOME_PULSES
        assert bus.state == ArmState(
            {"base": 120.0, "shoulder": 93.0, "elbow": -132.0}, {"gripper_arm": 60.0}, False
        )
        bus.move(command(120.0, 93.0, -132.0, 60.0, closed=True))
        assert board.received[-1] == b"2 M 1800 1530 1080 2100 1900*758D"


def test_frames_match_the_encoder_for_a_route(board):
    """Each frame on the wire is the encoder's, sequence numbers counting up."""
    with connected(board) as bus:
        for cmd in route(4):
            bus.move(cmd)
        for i, (frame, pulses) in enumerate(zip(board.received[1:], board.moves, strict=True)):
            assert frame + b"\n" == encode_command(i + 1, "M", pulses)
        assert board.moves[-1] == [1770, 1545, 1110, 2100, 1000]


def test_unused_channels_get_no_pulse():
    """A board with more channels than the arm uses gets 0 (no pulse) on the spare ones."""
    with FakeMearmBoard(servo_count=8) as board, connected(board) as bus:
        bus.move(HOME)
        assert board.moves[-1] == [*HOME_PULSES, 0, 0, 0]


def test_query_and_stop(board):
    """Q reports the mode and pulses; S holds."""
    with connected(board) as bus:
        assert bus.query().mode == "IDLE"
        bus.move(HOME)
        status = bus.query()
        assert status.mode == "RUN" and status.pulses_us == tuple(HOME_PULSES)
        bus.stop()
        assert bus.query().mode == "HOLD"
        assert board.received[-2].split(b"*")[0].endswith(b" S")


def test_stop_holds_and_commands_no_move(board):
    """stop() sends S alone: no M, no pulse changed, the confirmed state unchanged."""
    with connected(board) as bus:
        for cmd in route(3):
            bus.move(cmd)
        moves, pulses = list(board.moves), list(board.pulses_us)
        bus.stop()
        assert board.received[-1] == encode_command(4, "S")[:-1]
        assert board.moves == moves and board.pulses_us == pulses == pulses_of(route(3)[-1])
        assert bus.state == ArmState.from_command(route(3)[-1]) and board.mode == "HOLD"


def test_watchdog_hold_notice_is_tolerated():
    """The board's '! HOLD' notice between commands is logged, not mistaken for a reply."""
    with FakeMearmBoard(hold_timeout_s=0.02) as board, connected(board) as bus:
        bus.move(HOME)
        deadline = time.monotonic() + 10.0  # the watchdog's thread is late on a loaded host
        while board.mode != "HOLD" and time.monotonic() < deadline:
            time.sleep(0.01)
        assert board.mode == "HOLD"
        bus.move(route(2)[1])
        assert board.mode == "RUN"
        assert dict(bus.state.joints) == {"base": 119.0, "shoulder": 93.5, "elbow": -131.0}


def test_reconnect_resets_board(board):
    """Each open is a DTR reset: a new banner, a new handshake, no state carried over."""
    bus = connected(board)
    bus.move(HOME)
    bus.close()
    bus.connect()
    assert board.opens == 2 and bus.state is None
    bus.move(HOME)
    bus.close()


# ------------------------------------------------------------------ refusals: nothing sent


def test_out_of_limit_angle_refused_before_sending(board):
    """shoulder = 140° (limit 135°) is refused with joint, value and limits; nothing is sent."""
    with connected(board) as bus:
        bus.move(HOME)
        before = list(board.received)
        with pytest.raises(JointLimitError) as err:
            bus.move(command(120.0, 140.0, -132.0))
        assert (err.value.joint, err.value.value_deg) == ("shoulder", 140.0)
        assert "shoulder = 140 deg" in str(err.value) and "[30, 135]" in str(err.value)
        assert board.received == before
        bus.move(HOME)  # a refusal is not a fault


def test_pulse_range_refused_before_sending(board):
    """A value within the limits whose pulse leaves [min_us, max_us] is refused. (A config
    cannot say so — it refuses such limits when it loads — so the map is narrowed here.)"""
    with connected(board) as bus:
        smap = bus.servo_map
        narrow = dataclasses.replace(smap.joints[0], min_us=900)
        bus.servo_map = dataclasses.replace(smap, joints=(narrow, *smap.joints[1:]))
        with pytest.raises(PulseRangeError) as err:
            bus.move(command(25.0, 93.0, -132.0))
        assert err.value.joint == "base" and err.value.pulse_us == 850.0
        assert "[900, 2400] µs" in str(err.value) and "[30, 180] deg" in str(err.value)
        assert board.received == [b"0 V*F970"]


@pytest.mark.parametrize(
    ("joints", "tool", "match"),
    [
        ({"base": 120.0, "shoulder": 93.0}, {"gripper_arm": 60.0}, "joints misses elbow"),
        (
            {"base": 120.0, "shoulder": 93.0, "elbow": -132.0, "wrist": 39.0},
            {"gripper_arm": 60.0},
            "joints names unknown wrist",
        ),
        ({"base": 120.0, "shoulder": 93.0, "elbow": -132.0}, {}, "misses gripper_arm"),
    ],
)
def test_misnamed_command_refused_before_sending(board, joints, tool, match):
    """A command missing a joint or naming one the arm lacks is refused before a byte
    goes out: the board sees only the handshake and the move before it."""
    with connected(board) as bus:
        bus.move(HOME)
        before = list(board.received)
        with pytest.raises(InvalidCommandError, match=match):
            bus.move(ArmCommand(joints, tool))
        assert board.received == before and bus.state == ArmState.from_command(HOME)
        bus.move(HOME)  # a refusal is not a fault


def test_not_connected():
    """move before connect names the fix."""
    bus = open_bus(fast_config("serial", "/dev/null"))
    with pytest.raises(ServoNotConnectedError, match="call connect"):
        bus.move(HOME)


def test_port_that_cannot_open():
    """A missing port is a LinkError naming the port."""
    bus = open_bus(fast_config("serial", "/dev/does-not-exist-mearm"))
    with pytest.raises(LinkError, match="/dev/does-not-exist-mearm: cannot open"):
        bus.connect()


# ------------------------------------------------------------------ handshake faults


def test_no_banner():
    """A board that never prints its banner: BannerTimeoutError with what was received."""
    with FakeMearmBoard(MearmFaults(banner=False, boot_noise=b"\x00junk\n")) as board:
        bus = open_bus(fast_config("serial", board.port))
        with pytest.raises(BannerTimeoutError) as err:
            bus.connect()
        assert err.value.received == b"\x00junk\n"
        assert "no banner within 1 s" in str(err.value)
        assert err.value.last_state is None
        assert board.received == [] and not bus.is_connected


def test_wrong_firmware_refused():
    """Another sketch answering our protocol is refused at the handshake."""
    with FakeMearmBoard(name="blink") as board:
        with pytest.raises(HandshakeError, match="not running mearm_servo"):
            connected(board)


def test_wrong_protocol_version_refused():
    with FakeMearmBoard(version="3.0") as board:
        with pytest.raises(HandshakeError, match="speaks protocol 3"):
            connected(board)


def test_too_few_servos_refused():
    """The paper arm's gripper on channel 4 needs a board with at least 5 channels."""
    with FakeMearmBoard(servo_count=4) as board:
        with pytest.raises(HandshakeError, match="channel 4"):
            connected(board)


# ------------------------------------------------------------------ faults mid-route


def drive_until_fault(bus: ArduinoBus, n: int = 6) -> Exception:
    """Send a route; return the error that stopped it."""
    with pytest.raises(Exception) as err:
        for cmd in route(n):
            bus.move(cmd)
    return err.value


def assert_stopped(bus: ArduinoBus, board: FakeMearmBoard, fault: Exception, acked: int):
    """The fault carries the last acknowledged pose, and nothing is sent after it."""
    last = route(acked)[-1]
    assert fault.last_state == ArmState.from_command(last)
    assert bus.state == ArmState.from_command(last)
    assert f"last acknowledged pose: {last}" in str(fault)
    board.drained()  # (what the host wrote before the fault may still be in the pty)
    sent = list(board.received)
    with pytest.raises(ServoFaultedError) as again:
        bus.move(HOME)
    assert again.value.fault is fault and again.value.last_state == fault.last_state
    bus.stop()
    board.drained()
    assert board.received == sent
    bus.close()


def test_no_ack():
    """A board that stops answering: NoAckError after ack_timeout_s."""
    with FakeMearmBoard(MearmFaults(silent_from_move=4)) as board:
        bus = connected(board)
        fault = drive_until_fault(bus)
        assert isinstance(fault, NoAckError)
        assert fault.frame == encode_command(4, "M", pulses_of(route(4)[3]))
        assert "no acknowledgement" in str(fault) and fault.garbage == b""
        assert_stopped(bus, board, fault, acked=3)


def test_garbage_before_each_reply_is_skipped(caplog):
    """Junk bytes in front of every reply are logged and skipped; the route completes."""
    with FakeMearmBoard(MearmFaults(garbage_line=b"\xf0\x0f noise")) as board:
        with caplog.at_level(logging.WARNING), connected(board) as bus:
            for cmd in route(3):
                bus.move(cmd)
        assert bus.state == ArmState.from_command(route(3)[-1])
        assert sum("ignored garbage" in r.message for r in caplog.records) >= 3


def test_garbage_only():
    """A board answering only junk (wrong baud rate?): NoAckError carrying the junk."""
    with FakeMearmBoard(MearmFaults(garbage_from_move=3)) as board:
        bus = connected(board)
        fault = drive_until_fault(bus)
        assert isinstance(fault, NoAckError)
        assert b"garbage" in fault.garbage and "check servo.baud" in str(fault)
        assert_stopped(bus, board, fault, acked=2)


def test_bad_reply_checksum_retried_then_ok(caplog):
    """Two corrupted acks: each try logged, the third succeeds with the same seq."""
    with FakeMearmBoard(MearmFaults(corrupt_replies=2)) as board:
        with caplog.at_level(logging.WARNING):
            bus = open_bus(fast_config("serial", board.port))
            bus.connect()
        tries = [r.message for r in caplog.records if "try" in r.message]
        assert len(tries) == 2 and "try 1/3" in tries[0] and "try 2/3" in tries[1]
        assert board.received == [b"0 V*F970"] * 3
        bus.move(HOME)
        bus.close()


def test_bad_checksum_at_board_retried_then_ok(caplog):
    """A frame corrupted on its way (board answers ERR - 1) is resent; no double move."""
    with FakeMearmBoard() as board, connected(board) as bus:
        board.faults.corrupt_incoming = 1
        with caplog.at_level(logging.WARNING):
            bus.move(HOME)
        assert len(board.moves) == 1 and board.received[-1] == board.received[-2]
        said = "the board could not read the line (checksum)"
        assert any(said in r.message for r in caplog.records)


def test_bad_checksum_every_try_raises(caplog):
    """Corruption on every try: ChecksumError after 1 + retries tries, each logged."""
    with FakeMearmBoard() as board:
        bus = connected(board)
        bus.move(route(1)[0])
        board.faults.corrupt_replies = 100
        with caplog.at_level(logging.WARNING), pytest.raises(ChecksumError) as err:
            bus.move(route(2)[1])
        fault = err.value
        assert fault.attempts == 3 and "all 3 tries" in str(fault)
        assert sum("try" in r.message and "failed" in r.message for r in caplog.records) == 3
        assert_stopped(bus, board, fault, acked=1)


def test_numbered_board_error():
    """ERR 5 from the board: BoardError with its number and meaning."""
    with FakeMearmBoard(MearmFaults(error_at_move=(3, 5))) as board:
        bus = connected(board)
        fault = drive_until_fault(bus)
        assert isinstance(fault, BoardError)
        assert fault.code == 5 and fault.reason == "pulse out of range"
        assert "board error 5: pulse out of range (injected)" in str(fault)
        assert_stopped(bus, board, fault, acked=2)


def test_link_dropped_mid_route():
    """The cable pulled while a move waits for its ack: LinkDroppedError."""
    with FakeMearmBoard(MearmFaults(drop_at_move=4)) as board:
        bus = connected(board)
        fault = drive_until_fault(bus)
        assert isinstance(fault, LinkDroppedError) and "link lost" in str(fault)
        assert_stopped(bus, board, fault, acked=3)


def test_board_reset_mid_route():
    """A brown-out reboots the board: its banner instead of an ack is BoardResetError."""
    with FakeMearmBoard(MearmFaults(reset_at_move=3)) as board:
        bus = connected(board)
        fault = drive_until_fault(bus)
        assert isinstance(fault, BoardResetError) and "brown-out" in str(fault)
        assert_stopped(bus, board, fault, acked=2)


def test_reconnect_after_fault_clears_it():
    """close + connect after a fault gives a working bus again."""
    with FakeMearmBoard(MearmFaults(silent_from_move=2)) as board:
        bus = connected(board)
        drive_until_fault(bus, 3)
        bus.close()
        board.faults.silent_from_move = None
        bus.connect()
        assert bus.fault is None and bus.state is None
        bus.move(HOME)
        bus.close()


# ------------------------------------------------------------------ pacing


def test_pacing_never_faster_than_the_baud_rate():
    """At 9600 baud a 48-byte move + ack takes 50 ms: the period grows past 1/50 s."""
    slow = open_bus(fast_config("serial", rate_hz=50.0, baud=9600))
    fast = open_bus(fast_config("serial", rate_hz=50.0, baud=115200))
    assert slow.wire_bytes_per_move == len(b"255 M 2500 2500 2500 2500 2500*0000\n") + 12
    assert slow.period_s == pytest.approx(10 * slow.wire_bytes_per_move / 9600)
    assert slow.period_s > 1 / 50
    assert fast.period_s == pytest.approx(1 / 50)


def test_a_stream_at_a_low_baud_steps_as_far_as_the_period_allows():
    """The board sets each pulse at once and the servo turns at its own speed: the
    executor sizes each step for the whole period (50 ms at 9600 baud, not the 20 ms
    of servo.rate_hz) and counts a period for it, so the arm keeps its planned speed and
    the reported motion time is the time the link takes."""
    durations = {}
    for baud in (9600, 115200):
        config = fast_config("serial", rate_hz=50.0, baud=baud)
        bus = ArduinoBus(config.arm, config.servo)
        executor, timed = timed_move(config, bus, 0.2)
        assert bus.step_s == bus.period_s and timed.period_s == bus.period_s
        assert executor.motion.stream_hz == pytest.approx(1.0 / bus.period_s)
        durations[baud] = timed.duration_s
        assert len(timed.q) - 1 >= 3
    # the same speed limits, the time law rounded to whole periods
    assert durations[9600] == pytest.approx(durations[115200], abs=2 * 0.0438)


def test_a_slow_write_is_not_a_lost_cable(monkeypatch):
    """A process descheduled longer than ack_timeout_s mid-write still delivers the move.

    pyserial raises "Write timeout" after a complete write when its timeout has run
    out; with the acknowledgement timeout as the write timeout, a loaded machine took
    that for a lost cable.
    """
    import os
    import types

    import serial.serialposix

    def slow_write(fd: int, data: bytes) -> int:
        time.sleep(0.8)  # longer than fast_config's ack_timeout_s of 0.5 s
        return os.write(fd, data)

    slow_os = types.SimpleNamespace(**{**vars(os), "write": slow_write})
    with FakeMearmBoard() as board, connected(board) as bus:
        monkeypatch.setattr(serial.serialposix, "os", slow_os)  # pyserial's os only
        bus.move(route(1)[0])
        monkeypatch.undo()
        assert len(board.moves) == 1
