"""A sort does not append its run to an experiment's log.

``mearm sort --log FILE`` appends to a run log that exists. Given an experiment's log, it
added a sort run (trial ``null``), and ``mearm experiment`` refused to resume that log
from then on (``a sort run (trial null), not a trial of an experiment; give the
experiment its own --log``), though it was the experiment's own: the way back was to edit
the file. The sort now refuses such a log before it moves, and a sort's own log is
appended to as before.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import run_main

from mearm import sort
from mearm.config import load_config
from mearm.runlog import RunLog

ONE = ["--set", "task.scene=[{color: red, x: 8.0, y: 40.0}]", "--quiet"]


def _log(path: Path, trial: int | None) -> bytes:
    with RunLog(path, fsync=False) as log:
        log.header(load_config("sim"), trial=trial, seed=1)
        log.summary(ok=True)
    return path.read_bytes()


def test_an_experiments_log_is_refused_and_kept(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "trials.jsonl"
    before = _log(path, trial=0)
    code, out, err = run_main(capsys, sort.main, "--config", "sim", "--log", path, *ONE)
    assert code == 2 and out == "", err
    (line,) = err.strip().splitlines()
    assert "is an experiment's log (its first record is trial 0's header)" in line
    assert line.endswith("give the sort its own --log")
    assert path.read_bytes() == before


def test_a_sorts_own_log_is_appended_to(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "sorts.jsonl"
    before = _log(path, trial=None)
    code, _, err = run_main(capsys, sort.main, "--config", "sim", "--log", path, *ONE)
    assert code == 0, err
    after = path.read_bytes()
    assert after.startswith(before) and len(after) > len(before)
