"""``mearm experiment`` on a servo board it cannot reach: refused at the start, exit 2.

Each trial opens the rig itself, and a rig that did not open was logged as trial 0 that
stopped before its sort (header, fault, summary), exit 1: a finished trial that a rerun
skipped, on a board never reached. The rig is now opened once before the first trial: a
port that does not exist, or a board that never answers its handshake, is one line and
exit 2, with no log written (or an existing one byte for byte as it was), and the same
command runs its trials once the board is there. Only the board is mocked: a path that
does not exist yet, a silent pseudo-terminal, then a fake Uno behind that path.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import check_bad_input, run_in_process
from fakeboard import FakeMearmBoard, MearmFaults, empty_table_rig

from mearm.runlog import read_runlog


@pytest.fixture()
def rig(tmp_path: Path) -> Path:
    """A real rig's config: a folder camera of an empty table, servos on ``tmp_path/tty``."""
    return empty_table_rig(tmp_path, "  banner_timeout_s: 0.5\n")


def experiment(rig: Path, log: Path, trials: int = 2) -> list[object]:
    """``mearm experiment`` of ``trials`` trials on ``rig`` into ``log``, without prompts."""
    return ["experiment", "--config", rig, "--yes", "--trials", trials, "--log", log]


@pytest.mark.bad_input
@pytest.mark.heavy
def test_a_missing_port_is_refused_before_trial_0_and_the_fixed_port_runs(
    tmp_path: Path, rig: Path
) -> None:
    """Exit 2 and no log; the board plugged in (the path now there), the same command
    runs trials 0 and 1 from the start."""
    log = tmp_path / "trials.jsonl"
    port = tmp_path / "tty"
    out = check_bad_input(experiment(rig, log), within_s=5, keep=[rig])
    assert out.line.startswith(f"mearm experiment: error: {port}: cannot open"), out.line
    assert "mearm find-port" in out.line
    assert not log.exists()
    with FakeMearmBoard() as board:
        port.symlink_to(board.port)
        again = run_in_process(experiment(rig, log), within_s=10)
    assert again.code == 0, again.stderr
    trials = read_runlog(log).trials
    assert [t.header.trial for t in trials] == [0, 1]
    assert all(t.finished and t.summary is not None and t.summary.ok for t in trials)


@pytest.mark.bad_input
@pytest.mark.heavy
def test_a_silent_board_leaves_a_resumed_log_as_it_was(tmp_path: Path, rig: Path) -> None:
    """A log holding trial 0; the board then stops answering: exit 2, the log untouched
    (no trial 1 claimed), and once it answers again the run resumes at trial 1."""
    log = tmp_path / "trials.jsonl"
    port = tmp_path / "tty"
    with FakeMearmBoard() as board:
        port.symlink_to(board.port)
        first = run_in_process(experiment(rig, log, trials=1))
    assert first.code == 0, first.stderr
    with FakeMearmBoard(MearmFaults(banner=False, boot_noise=b"")) as silent:
        port.unlink()
        port.symlink_to(silent.port)
        out = check_bad_input(experiment(rig, log), within_s=5, keep=[log, rig])
        moves = [line for line in silent.received if b" M " in line]  # "SEQ M ..."
    assert out.line.startswith(f"mearm experiment: error: {port}: no banner"), out.line
    assert moves == []
    with FakeMearmBoard() as board:
        port.unlink()
        port.symlink_to(board.port)
        again = run_in_process(experiment(rig, log), within_s=10)
    assert again.code == 0, again.stderr
    assert "resuming" in again.stdout
    assert [t.header.trial for t in read_runlog(log).trials] == [0, 1]
