"""A reader that goes away (``mearm detect | head -1``): a quiet exit, or a sort that goes on.

Python raises ``BrokenPipeError`` on a write to a pipe whose reader has closed; a shell's
tools die of SIGPIPE there, quietly (exit 141). A short command does so; a sort, whose
arm is mid-job, finishes it with its lines going nowhere (the run log keeps them).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

from mearm.cli import EXIT_OUTPUT_CLOSED
from mearm.runlog import read_runlog


def _popen(args: list[str], cwd: Path, *, reader_gone: bool = False) -> subprocess.Popen[bytes]:
    """``mearm ARGS`` with its output in pipes; ``reader_gone``: its stdout's reader has
    left before it starts (closing the pipe after the start raced the command: on a
    loaded machine a quick one wrote its whole output into the pipe first, exit 0)."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}  # each line written as it is printed
    stdout: int = subprocess.PIPE
    if reader_gone:
        read_end, stdout = os.pipe()
        os.close(read_end)
    try:
        return subprocess.Popen(
            [sys.executable, "-m", "mearm", *args],
            cwd=cwd,
            env=env,
            stdout=stdout,
            stderr=subprocess.PIPE,
        )
    finally:
        if reader_gone:
            os.close(stdout)  # the child holds its own copy


def test_a_short_command_whose_reader_left_exits_141_quietly(tmp_path: Path) -> None:
    """No "unexpected error" line and no crash log: the reader's leaving is no fault."""
    state = Path(os.environ["MEARM_STATE_DIR"])
    before = (state / "crash.log").read_bytes() if (state / "crash.log").exists() else b""
    proc = _popen(["detect", "--config", "sim", "--camera"], tmp_path, reader_gone=True)
    assert proc.stderr is not None
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == EXIT_OUTPUT_CLOSED, err
    assert err == ""
    after = (state / "crash.log").read_bytes() if (state / "crash.log").exists() else b""
    assert after == before


def test_the_dispatchers_own_help_whose_reader_left_exits_141_quietly(tmp_path: Path) -> None:
    """``mearm --help | true``: the list of subcommands, not a traceback, meets the pipe."""
    proc = _popen(["--help"], tmp_path, reader_gone=True)
    assert proc.stderr is not None
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == EXIT_OUTPUT_CLOSED, err
    assert err == ""


@pytest.mark.heavy
def test_a_sort_whose_reader_left_finishes_and_logs_every_route(tmp_path: Path) -> None:
    """``mearm sort | head -1``: all 12 objects sorted, exit 0, the run log whole."""
    log = tmp_path / "run.jsonl"
    proc = _popen(["sort", "--config", "sim", "--log", str(log)], ROOT)
    assert proc.stdout is not None and proc.stderr is not None
    assert proc.stdout.readline().startswith(b"run log: ")
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 0, err
    assert all(ln.startswith("mearm sort: note: ") for ln in err.splitlines()), err
    contents = read_runlog(log)
    assert contents.complete and len(contents.routes) == 24 and not contents.faults
    summary = contents.trials[-1].summary
    assert summary is not None and summary.sorted == {"red": 4, "green": 4, "blue": 4}


def test_a_sort_whose_reader_left_before_it_began_finishes_too(tmp_path: Path) -> None:
    """``mearm sort --log L | true``: the reader gone before the first line ("run log: L",
    flushed before the run) ended the sort there, nothing sorted, the log empty, 141."""
    log = tmp_path / "run.jsonl"
    proc = _popen(["sort", "--config", "sim", "--log", str(log)], ROOT, reader_gone=True)
    assert proc.stderr is not None
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 0, err
    contents = read_runlog(log)
    assert contents.complete and len(contents.routes) == 24 and not contents.faults


def test_a_closed_standard_output_is_exit_1_with_one_line() -> None:
    """``mearm fk … >&-``: the answer, fk's whole job, went nowhere, and it exited 0."""
    done = subprocess.run(
        f"{sys.executable} -m mearm fk --config sim --joints 90,90,-90 >&-",
        shell=True, cwd=ROOT, capture_output=False, stderr=subprocess.PIPE, text=True,
        timeout=120,
    )  # fmt: skip
    assert done.returncode == 1
    assert done.stderr.splitlines() == [
        "mearm fk: error: cannot write standard output: it is closed"
    ]
