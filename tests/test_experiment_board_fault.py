"""``mearm experiment`` on a servo board that faults mid-trial: no trial after it moves.

A trial stopped by a fault of its servos (no acknowledgement, a board reset, a lost
link) was logged as a trial stopped early, and the next trial began: it opened the port
again (a real Uno resets on that), and sent home as one command, from the pose the fault
left the arm in, a jaw perhaps still holding an object over the table; with ``--yes``
nobody was asked first. The experiment now stops there, exit 1 and one line naming the
fault, the log holding the faulted trial finished, so the same command runs the rest
once the rig is fixed. Only the board is mocked (the pty fake Uno).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import run_in_process
from fakeboard import FakeMearmBoard, MearmFaults, empty_table_rig

from mearm.runlog import read_runlog


@pytest.fixture()
def rig(tmp_path: Path) -> Path:
    """A real rig's config: a folder camera of an empty table, servos on ``tmp_path/tty``."""
    return empty_table_rig(
        tmp_path, "  banner_timeout_s: 5.0\n  ack_timeout_s: 2.0\n  rate_hz: 1000\n"
    )


@pytest.mark.parametrize(
    ("faults", "named"),
    [
        (MearmFaults(silent_from_move=1), "no acknowledgement of"),
        (MearmFaults(reset_at_move=1), "the board restarted"),
    ],
    ids=["stops-answering", "resets"],
)
def test_a_board_fault_stops_the_experiment_and_nothing_more_moves(
    tmp_path: Path, rig: Path, faults: MearmFaults, named: str
) -> None:
    log = tmp_path / "trials.jsonl"
    with FakeMearmBoard(faults) as board:
        (tmp_path / "tty").symlink_to(board.port)
        out = run_in_process(
            ["experiment", "--config", rig, "--yes", "--trials", 3, "--log", log], within_s=20
        )
        board.drained()
        received = list(board.received)
    moves = [line for line in received if b" M " in line]
    assert len(moves) == 1, received  # the move that met the fault; no trial after it
    assert received[-1] == moves[0], received  # nothing at all after it (no V, no S)
    assert out.code == 1, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in out.stderr, out.stderr
    assert lines[0].startswith("mearm experiment: stopped: trial 0: "), lines[0]
    assert named in lines[0] and "nothing more sent to the servos" in lines[0], lines[0]
    assert "1 of 3 trials complete" in lines[0] and "the same command runs the rest" in lines[0]
    contents = read_runlog(log)
    assert contents.problem is None
    (trial,) = contents.trials
    assert trial.finished and trial.summary is not None and not trial.summary.ok
    assert named in trial.faults[0].reason
