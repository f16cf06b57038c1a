"""One writer per run log: a second sort or experiment on a log being written is refused.

The first writer is a real ``mearm experiment`` process; the second, ``mearm sort`` or
``mearm experiment`` run in the test's own process (another process than the first's:
the lock is the first's), must end with exit 2 and one line naming the first (its pid
and command) through the bad-input check, and leave the log to the first, which ends
with a log ``mearm analyze --strict`` accepts.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from badinput import ROOT, check_bad_input, run_in_process
from conftest import interrupted

from mearm.runlog import LogLock, RunLog, RunLogLockedError
from mearm.runlog.lock import lock_holder

SCENE = "- {color: red, x: -10.99, y: 49.70}\n"


@pytest.mark.heavy  # an interpreter starts and sorts until stopped
@pytest.mark.bad_input
def test_a_second_writer_is_refused_naming_the_first(tmp_path: Path) -> None:
    """Two processes on one log: the second (sort, then experiment) gets exit 2."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(SCENE)
    log = tmp_path / "trials.jsonl"
    first = subprocess.Popen(
        [sys.executable, "-m", "mearm", "experiment", "--trials", "10000", "--scene", scene,
         "--log", log],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 120  # a hang is the failure, not a slow start
        while first.poll() is None and time.monotonic() < deadline:
            if log.exists() and lock_holder(log)[0] == first.pid:
                break
            time.sleep(0.02)
        if first.poll() is not None:
            pytest.fail(f"the first writer ended ({first.returncode}): {first.stderr.read()!r}")
        assert lock_holder(log)[0] == first.pid, "the first writer never took the lock"
        for second in (
            ["sort", "--scene", scene, "--log", log, "--quiet"],
            ["experiment", "--trials", "10001", "--scene", scene, "--log", log],
        ):
            out = check_bad_input(second, within_s=10, keep=[scene])
            assert f"{log}: is being written by process {first.pid} (" in out.line, out
            assert "mearm experiment --trials 10000" in out.line, out
            assert "one run writes a log at a time" in out.line, out
        # the first writes on, refused nothing: a whole trial of its own, for analyze below
        while first.poll() is None and time.monotonic() < deadline:
            if b'"type":"summary"' in log.read_bytes():
                break
            time.sleep(0.02)
        assert first.poll() is None, "the first writer ended while the second was refused"
    finally:
        _, err = interrupted(first)
    assert first.returncode == 130, err.decode(errors="replace")[-3000:]
    out = run_in_process(["analyze", log, "--strict"], within_s=30)
    assert out.code == 0, out.stderr


def test_the_lock_goes_with_the_writer(tmp_path: Path) -> None:
    """Closed, the log can be written again; in this process a second writer is refused."""
    log = tmp_path / "run.jsonl"
    with RunLog(log, fsync=False):
        with pytest.raises(RunLogLockedError) as caught:
            RunLog(log, fsync=False)
        assert caught.value.pid == os.getpid()
        with pytest.raises(RunLogLockedError):
            LogLock(log)
    with LogLock(log) as held:
        RunLog(log, fsync=False, lock=held).close()
    RunLog(log, fsync=False).close()
