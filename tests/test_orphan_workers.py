"""A pool's workers end when the command that started them is killed (``kill -9``).

A ``concurrent.futures`` worker waits on its call queue, whose other end its forked
siblings keep open, so it never saw its parent die: after ``kill -9`` of ``mearm
experiment --jobs 2`` both workers lived on, with parent 1, until killed by hand.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest
from conftest import ROOT

pytestmark = [pytest.mark.heavy, pytest.mark.slow]


def test_experiment_workers_end_when_the_command_is_killed(tmp_path: Path) -> None:
    log = tmp_path / "trials.jsonl"
    cmd = [sys.executable, "-m", "mearm", "experiment", "--config", "sim", "--trials", "400",
           "--jobs", "2", "--log", str(log), "--yes"]  # fmt: skip
    with (tmp_path / "out.txt").open("w") as out:  # files: orphans may hold pipes
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=out, stderr=subprocess.STDOUT,
                                start_new_session=True)  # fmt: skip
    workers: list[psutil.Process] = []
    try:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and '"type":"summary"' not in _text(log):
            assert proc.poll() is None, (tmp_path / "out.txt").read_text()
            time.sleep(0.05)
        workers = psutil.Process(proc.pid).children()
        assert len(workers) == 2, workers
        proc.kill()
        proc.wait()
        # a hang (the orphans at work, waiting for trials forever) is the failure
        _, alive = psutil.wait_procs(workers, timeout=120)
        assert alive == [], f"{len(alive)} workers outlived the command"
    finally:
        for pid in [w.pid for w in workers] + [proc.pid] * (proc.poll() is None):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        proc.wait()


def _text(path: Path) -> str:
    return path.read_text() if path.exists() else ""
