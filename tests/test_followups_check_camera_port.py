"""``mearm check-camera`` on a servo board it cannot reach: exit 2, one line, nothing moved.

The rig opens (its camera, and its bus connected and handshaken) before anything moves,
as for ``mearm sort`` (tests/test_missing_port.py) and ``mearm calibrate-servos --camera``
(tests/test_missing_port_calibrate_servos.py): a port that does not exist, or a board that
never answers its handshake, is bad input, not a "check stopped" fault of the run (exit
1). A fault once the rig is open still stops the check (exit 1). Only the board is
mocked: a path no machine has, or a pseudo-terminal fake Uno.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import ROOT, check_bad_input, run_in_process
from fakeboard import FakeMearmBoard, MearmFaults

#: The simulated rig, its servos on a serial board.
ON_A_BOARD = [
    "check-camera", "--config", str(ROOT / "configs" / "sim.yaml"),
    "--set", "servo.backend=serial",
]  # fmt: skip


@pytest.mark.bad_input
def test_a_port_that_does_not_exist_is_exit_2_in_one_line(tmp_path: Path) -> None:
    """One line naming the port and find-port, not "check stopped"; OUT not written."""
    port = tmp_path / "ttyNOPE"
    result = check_bad_input(
        [*ON_A_BOARD, "--set", f"servo.port={port}"], within_s=5, keep=[tmp_path]
    )
    assert result.line.startswith(f"mearm check-camera: error: {port}: cannot open"), result.line
    assert "mearm find-port" in result.line
    assert "check stopped" not in result.line
    assert result.stdout == ""


@pytest.mark.bad_input
def test_a_long_port_path_keeps_the_find_port_hint(tmp_path: Path) -> None:
    """A 250-character path that does not exist: the line still ends with the hint."""
    port = tmp_path / ("p" * (250 - len(str(tmp_path)) - 1))
    assert len(str(port)) == 250
    result = check_bad_input([*ON_A_BOARD, "--set", f"servo.port={port}"], within_s=5)
    assert result.line.startswith("mearm check-camera: error: "), result.line
    assert "(mearm find-port lists the ports; Linux: the user must be in the dialout group)" in (
        result.line
    )
    assert result.line.endswith("last acknowledged pose: none (no move acknowledged yet)")


@pytest.mark.bad_input
@pytest.mark.heavy
def test_a_board_that_never_answers_is_exit_2_before_anything_moves() -> None:
    """A silent pty: no banner within servo.banner_timeout_s; not one move sent."""
    with FakeMearmBoard(MearmFaults(banner=False, boot_noise=b"")) as board:
        argv = [*ON_A_BOARD, "--set", f"servo.port={board.port}",
                "--set", "servo.banner_timeout_s=0.5"]  # fmt: skip
        result = check_bad_input(argv, within_s=5)
        moves = [line for line in board.received if b" M " in line]
    assert result.line.startswith(f"mearm check-camera: error: {board.port}: no banner"), (
        result.line
    )
    assert board.opens >= 1 and moves == []


@pytest.mark.heavy
def test_a_board_that_stops_answering_once_open_stops_the_check() -> None:
    """Opened and handshaken, then silent from the first move: a fault of the run (exit 1)."""
    faults = MearmFaults(silent_from_move=1)
    with FakeMearmBoard(faults) as board:
        argv = [*ON_A_BOARD, "--set", f"servo.port={board.port}"]
        result = run_in_process(argv, within_s=30)
        moves = [line for line in board.received if b" M " in line]
    assert result.code == 1, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mearm check-camera: check stopped: "), lines
    assert moves  # the rig opened and the first move was sent
