"""One process a serial port: a second mearm command on a port another holds is refused.

The safety audit's case: a second ``mearm sort`` on the port of a running one opened it
(on a real Uno that resets the board through DTR), sent its home as one 35–43° jump per
joint and then streamed its plan interleaved with the first's. The serial backends now
hold an exclusive ``flock`` on their port; a second command on it says in one line who
holds it (exit 2, as every port that cannot be opened) and the board receives nothing
from it, not even the open's flush that the fake Uno takes for its DTR reset.
"""

from __future__ import annotations

import contextlib
import os
import re
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial
from conftest import mearm_here, one_stderr_line
from fakeboard import FakeMearmBoard
from test_maker_calibrate import ROOT, PtyCommand, serial_args

from mearm.config import load_config
from mearm.hardware import ArduinoBus
from mearm.hardware import serial_bus as serial_bus_module
from mearm.hardware.errors import PortInUseError
from mearm.maker.find_port import SerialPort, probe_port

SIM = str(ROOT / "configs" / "sim.yaml")


@contextlib.contextmanager
def held(board: FakeMearmBoard) -> Iterator[serial.Serial]:
    """The board's port held as the serial backends hold it (pyserial's exclusive lock),
    once the board has seen the holder's open (it counts opens in its own thread)."""
    with serial.Serial(board.port, 115200, exclusive=True) as holder:
        deadline = time.monotonic() + 10.0
        while board.opens < 1 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert board.opens == 1
        yield holder


def _board_config():
    return load_config(SIM, overrides=["servo.backend=serial", "servo.banner_timeout_s=5"])


def test_a_bus_on_a_port_held_elsewhere_sends_nothing_and_names_the_holder():
    """The holder (pyserial's exclusive lock, as the backends take it) is named from
    /proc/locks and the port is not even opened: the board sees no open and no line."""
    config = _board_config()
    with FakeMearmBoard() as board:
        with held(board):
            opens = board.opens
            bus = ArduinoBus(config.arm, config.servo, port=board.port)
            with pytest.raises(PortInUseError) as err:
                bus.connect()
            assert err.value.pid == os.getpid()
            assert "in use by this process" in str(err.value)
            assert "nothing was sent" in str(err.value)
            assert not bus.is_connected
            assert board.received == [] and board.opens == opens
        bus.connect()  # the holder gone: the port is the bus's
        try:
            assert bus.is_connected and board.received
        finally:
            bus.close()


def test_the_lock_itself_refuses_where_proc_locks_says_nothing(monkeypatch):
    """Without /proc/locks (another system, another pid namespace) the exclusive lock
    refuses the port: pyserial takes it right after open(2), before it sets the line or
    DTR or flushes the input (which the fake Uno takes for its reset): nothing reaches the
    board."""
    monkeypatch.setattr(serial_bus_module, "port_holder", lambda port: None)
    config = _board_config()
    with FakeMearmBoard() as board:
        with held(board):
            opens = board.opens
            bus = ArduinoBus(config.arm, config.servo, port=board.port)
            with pytest.raises(PortInUseError) as err:
                bus.connect()
            assert err.value.pid is None
            assert f"{board.port}: the serial port is in use by another process" in str(err.value)
            assert board.received == [] and board.opens == opens


def test_find_port_leaves_a_held_port_alone():
    """find-port's probe reports a held port in use, with its holder, and does not open
    it: the board a running command drives is not reset."""
    with FakeMearmBoard() as board:
        with held(board):
            opens = board.opens
            report = probe_port(SerialPort(board.port), 115200, 1.0)
            assert report.status == "busy", report
            assert f"held by process {os.getpid()}" in report.detail
            assert board.received == [] and board.opens == opens
        report = probe_port(SerialPort(board.port), 115200, 3.0)
        assert report.status == "mearm", report


def test_flash_refuses_a_port_a_mearm_command_holds():
    """avrdude takes no lock: flash looks before it builds and before it uploads."""
    from mearm.maker.flash import _check_port_is_there  # noqa: PLC0415

    with FakeMearmBoard() as board:
        with held(board):
            with pytest.raises(PortInUseError):
                _check_port_is_there(board.port)
        _check_port_is_there(board.port)


def _jog_holding(board: FakeMearmBoard) -> PtyCommand:
    """``mearm jog`` on the board, at home and waiting for keys: it holds the port."""
    jog = PtyCommand("jog", *serial_args(board.port))
    jog.expect(r"TCP x")
    return jog


@pytest.mark.slow
@pytest.mark.heavy
def test_a_second_command_on_a_running_jogs_port_is_refused_and_sends_nothing(tmp_path: Path):
    """While ``mearm jog`` drives the board, ``mearm sort``, ``mearm jog``, ``mearm
    calibrate-servos`` and ``mearm find-port`` on its port each say in one line that
    the jog's process holds it; the board gets not one line (nor an open) from them,
    and the jog goes on driving it."""
    with FakeMearmBoard() as board:
        jog = _jog_holding(board)
        try:
            pid = jog.proc.pid
            opens, received = board.opens, len(board.received)
            on_board = ["--config", SIM, "--set", "servo.backend=serial"]
            # sort and find-port in this process (the refusal is the point, not a start);
            # jog and calibrate-servos need a terminal, their own processes
            sort = mearm_here(
                "sort", *on_board, "--set", f"servo.port={board.port}",
                "--log", tmp_path / "second.jsonl", cwd=tmp_path,
            )  # fmt: skip
            line = one_stderr_line(sort, 2)
            assert line.startswith(f"mearm sort: error: {board.port}: the serial port is in "
                                   f"use by process {pid} ("), line  # fmt: skip
            assert f"kill {pid}" in line and "nothing was sent" in line
            for command in ("jog", "calibrate-servos"):
                out = ["--output", str(tmp_path / "s.yaml")] if command != "jog" else []
                second = PtyCommand(command, *serial_args(board.port), *out)
                try:
                    assert second.wait() == 2, second.text[-2000:]
                finally:
                    second.close()
                said = second.text.strip().splitlines()
                assert f"mearm {command}: error: {board.port}: the serial port is in use by " \
                    f"process {pid}" in said[-1], second.text[-2000:]  # fmt: skip
                assert "Traceback" not in second.text
            find = mearm_here("find-port", "--config", SIM, "--only", "--port", board.port,
                             "--timeout", "1", cwd=tmp_path)  # fmt: skip
            assert find.returncode == 1, find.stderr
            assert re.search(rf"{re.escape(board.port)} +in use: held by process {pid} ",
                             find.stdout), find.stdout  # fmt: skip
            assert "in use by another process" in one_stderr_line(find, 1)
            assert board.opens == opens and len(board.received) == received
            assert not (tmp_path / "s.yaml").exists()
            jog.send("2+")  # the jog still drives the board
            jog.expect(r"TCP x")
            jog.send("Q")
            assert jog.wait() == 0, jog.text[-2000:]
            assert len(board.received) > received
        finally:
            jog.close()
