"""A trial its recording stopped (a full disk) is run again by ``--resume``, as after Ctrl-C.

Found walking docs/datasets.md: a recorded ``mearm experiment`` whose disk filled stopped
with exit 1 and "the dataset keeps the 1 episode written before". Its trial's fault and
summary made it a finished trial, so ``--resume`` (once there was room) went on to the
next trial. The trial's picks after the failure were never recorded, and the totals
counted its objects as "stopped by a fault" for good. The log here is a real run's,
with trial 0 ending as a recording failure ends it: a fault worded by
:class:`~mearm.dataset.errors.DatasetWriteError` and a summary that is not ok.
"""

from __future__ import annotations

import errno
import io
import json
import sys
from pathlib import Path

import pytest
from badinput import Outcome, run_in_process
from conftest import ROOT

from mearm.dataset.errors import DatasetWriteError
from mearm.runlog import read_runlog

SCENE = "- {color: red, x: -10.99, y: 49.70}\n- {color: blue, x: 5.0, y: 45.0}\n"


def _experiment(*args: object) -> Outcome:
    saved = sys.stdin
    sys.stdin = io.StringIO("")
    try:
        argv = ["experiment", "--config", ROOT / "configs" / "sim.yaml", *args]
        return run_in_process([str(a) for a in argv], within_s=60)
    finally:
        sys.stdin = saved


def _stopped_by_its_recording(log: Path, tmp_path: Path) -> None:
    """Rewrite trial 0 of ``log`` as a recording that failed after its first pick ends it."""
    failure = DatasetWriteError(
        tmp_path / "ds" / "data" / "chunk-000" / "file-000.parquet",
        errno.ENOSPC,
        "No space left on device",
        kept=1,
    )
    out = []
    for line in log.read_text().splitlines():
        record = json.loads(line)
        if record["type"] == "summary" and record["trial"] == 0:
            fault = {"type": "fault", "trial": 0, "last_joints": None}
            fault["reason"] = f"{failure}; arm parked at home"
            out.append(json.dumps(fault))
            record.update(sorted={"red": 1, "blue": 0}, left={"fault": 1}, ok=False)
        out.append(json.dumps(record))
    log.write_text("\n".join(out) + "\n")


@pytest.fixture()
def two_trials(tmp_path: Path) -> tuple[Path, Path]:
    scene = tmp_path / "scene.yaml"
    scene.write_text(SCENE)
    log = tmp_path / "trials.jsonl"
    done = _experiment("--trials", 2, "--scene", scene, "--log", log)
    assert done.code == 0, done.stderr
    _stopped_by_its_recording(log, tmp_path)
    return log, scene


def test_resume_runs_the_trial_its_recording_stopped_again(
    two_trials: tuple[Path, Path], tmp_path: Path
) -> None:
    log, scene = two_trials
    lines = log.read_text().splitlines()
    second = next(t.line for t in read_runlog(log).trials if t.number == 1)
    log.write_text("".join(line + "\n" for line in lines[: second - 1]))  # trial 0 only
    before = log.read_bytes()  # the stopped attempt's records stay in the log
    out = _experiment("--trials", 2, "--scene", scene, "--log", log)
    assert out.code == 0, out.stderr
    assert "trial 0 again, it was stopped by its recording" in out.stdout, out.stdout
    assert "sorted 4 of 4 objects over 2 trials" in out.stdout, out.stdout
    assert log.read_bytes().startswith(before)
    trials = read_runlog(log).trials
    assert [t.number for t in trials] == [0, 0, 1]
    assert trials[0].recording_stopped and not trials[0].finished
    assert trials[1].finished and trials[1].summary.ok

    analysed = run_in_process(["analyze", str(log), "--json"], within_s=30)
    assert analysed.code == 0, analysed.stderr
    assert "left out 1 recording-stopped attempt(s) of trial(s) 0" in analysed.stderr
    assert json.loads(analysed.stdout)["analysis"]["trials"] == 2


def test_an_older_log_that_went_on_keeps_the_stopped_trial(
    two_trials: tuple[Path, Path],
) -> None:
    """A log resumed by a mearm that went on to trial 1 resumes as it is: trial 0 stands."""
    log, scene = two_trials
    before = log.read_bytes()
    out = _experiment("--trials", 2, "--scene", scene, "--log", log)
    assert out.code == 1, out.stderr
    assert "already holds 2 complete trials" in out.stdout, out.stdout
    assert "1 stopped early" in out.stdout, out.stdout
    assert log.read_bytes() == before
