"""``mearm calibrate-servos --camera`` on a servo board it cannot reach: exit 2, one line.

The rig opens (and its bus connects, with the camera) before anything moves, as it does
for ``mearm sort`` (tests/test_missing_port.py): a port that does not exist, or a board
that never answers its handshake, is bad input, not a "servo fault" of the run (exit 1).
Only the board is mocked: a path no machine has, or a pseudo-terminal that stays silent.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import ROOT, check_bad_input
from fakeboard import FakeMearmBoard, MearmFaults

#: The twin's perspective camera on the kinematic simulator, its servos on a serial board.
ON_A_BOARD = [
    "calibrate-servos", "--camera",
    "--config", str(ROOT / "configs" / "sim_mujoco_perspective.yaml"),
    "--set", "simulator=kinematic", "--set", "servo.backend=serial",
]  # fmt: skip


@pytest.mark.bad_input
def test_a_port_that_does_not_exist_is_exit_2_in_one_line(tmp_path: Path) -> None:
    """One line naming the port and find-port, no "servo fault", nothing written."""
    port = tmp_path / "ttyNOPE"
    out = tmp_path / "kit.servos.yaml"
    result = check_bad_input(
        [*ON_A_BOARD, "--set", f"servo.port={port}", "--output", out],
        within_s=5, keep=[tmp_path],
    )  # fmt: skip
    assert result.line.startswith(f"mearm calibrate-servos: error: {port}: cannot open"), (
        result.line
    )
    assert "mearm find-port" in result.line
    assert "servo fault" not in result.line
    assert "connected" not in result.stdout  # the procedure never started
    assert not out.exists()


@pytest.mark.bad_input
@pytest.mark.heavy
def test_a_board_that_never_answers_is_exit_2_before_anything_moves(tmp_path: Path) -> None:
    """A silent pty: no banner within servo.banner_timeout_s; not one move sent."""
    out = tmp_path / "kit.servos.yaml"
    with FakeMearmBoard(MearmFaults(banner=False, boot_noise=b"")) as board:
        argv = [*ON_A_BOARD, "--set", f"servo.port={board.port}",
                "--set", "servo.banner_timeout_s=0.5", "--output", out]  # fmt: skip
        result = check_bad_input(argv, within_s=5, keep=[tmp_path])
        moves = [line for line in board.received if b" M " in line]  # "SEQ M ..."
    assert result.line.startswith(f"mearm calibrate-servos: error: {board.port}: no banner"), (
        result.line
    )
    assert "servo fault" not in result.line
    assert board.opens >= 1 and moves == []
    assert not out.exists()
