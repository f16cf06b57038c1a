"""Edges of ``mearm sort``'s report: what ``--quiet`` prints, and one motion figure.

- ``--quiet`` prints only the summary (its help, docs/getting-started.md): the route
  statistics, the motion time, what was left and why, and the last line, ``sorted N of M
  objects``; no line per route and no per-class table (it printed the table);
- the run log's summary ``motion_s`` is the figure of the printed ``motion`` line, also
  when Ctrl-C stops the sort (the log summed its routes' streaming, the screen the whole
  run's motion: 0.28 s against 2.9 s after three routes and the parking).

Each sort runs in this process on the simulated rig; the Ctrl-C is a real SIGINT, sent
once the run log holds a given number of routes.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
from collections.abc import Iterator
from pathlib import Path

import pytest
from badinput import ROOT, Outcome, run_in_process

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.runlog import read_runlog
from mearm.runlog.writer import RunLog
from mearm.task.report import Outcome as Counts
from mearm.task.report import Reporter
from mearm.task.timing import MotionTime

CLASSES = [c.name for c in load_config(ROOT / "configs" / "sim.yaml").task.classes]


@pytest.fixture
def sigint_raises() -> Iterator[None]:
    """SIGINT raises KeyboardInterrupt here, as in a terminal (a suite started in the
    background of a shell without job control inherits it ignored)."""
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, before)


def _sort(monkeypatch: pytest.MonkeyPatch, *args: object, ctrl_c_after: int | None) -> Outcome:
    """``mearm sort ARGS`` on the simulated rig; with ``ctrl_c_after``, a SIGINT as soon
    as that many routes are in the run log."""
    if ctrl_c_after is not None:
        write_route = RunLog.route
        written = []

        def route_then_ctrl_c(self: RunLog, **fields: object) -> object:
            record = write_route(self, **fields)
            written.append(record)
            if len(written) == ctrl_c_after:
                os.kill(os.getpid(), signal.SIGINT)
            return record

        monkeypatch.setattr(RunLog, "route", route_then_ctrl_c)
    with contextlib.chdir(ROOT):
        return run_in_process(["sort", "--config", "sim", *map(str, args)], within_s=60)


def _is_table_line(line: str) -> bool:
    words = line.split()
    return words[:1] == ["class"] or (
        len(words) == 4 and words[0] in CLASSES and all(w.isdigit() for w in words[1:])
    )


@pytest.mark.heavy  # two whole sorts
@pytest.mark.usefixtures("sigint_raises")
@pytest.mark.parametrize("ctrl_c_after", [None, 3], ids=["whole-run", "ctrl-c"])
def test_quiet_prints_the_summary_without_the_class_table(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, ctrl_c_after: int | None
) -> None:
    loud = _sort(monkeypatch, "--log", tmp_path / "loud.jsonl", ctrl_c_after=ctrl_c_after)
    quiet = _sort(
        monkeypatch, "--quiet", "--log", tmp_path / "quiet.jsonl", ctrl_c_after=ctrl_c_after
    )
    assert quiet.code == loud.code == (0 if ctrl_c_after is None else 130), quiet.stderr
    said, *lines = quiet.stdout.splitlines()
    assert said == f"run log: {tmp_path / 'quiet.jsonl'}"  # where the routes went
    assert not [ln for ln in lines if _is_table_line(ln)], quiet.stdout
    assert not [ln for ln in lines if ln.startswith(("pick ", "place "))], quiet.stdout
    # the summary as the whole run prints it, from the line after its table
    full = loud.stdout.splitlines()
    table = [i for i, ln in enumerate(full) if _is_table_line(ln)]
    assert len(table) == 1 + len(CLASSES)
    assert lines == full[table[-1] + 1 :]
    assert lines[0].startswith("routes ") and lines[1].startswith("motion ")
    expected = "sorted 12 of 12 objects" if ctrl_c_after is None else "sorted 1 of 12 objects"
    assert lines[-1].startswith(expected)


@pytest.mark.heavy  # a whole sort
@pytest.mark.usefixtures("sigint_raises")
@pytest.mark.parametrize("ctrl_c_after", [None, 3, 8], ids=["whole-run", "ctrl-c-3", "ctrl-c-8"])
def test_the_logged_motion_is_the_printed_motion(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, ctrl_c_after: int | None
) -> None:
    log = tmp_path / "run.jsonl"
    out = _sort(monkeypatch, "--log", log, ctrl_c_after=ctrl_c_after)
    assert out.code == (0 if ctrl_c_after is None else 130), out.stderr
    (printed,) = re.findall(r"^motion ([0-9.]+) s ", out.stdout, re.MULTILINE)
    contents = read_runlog(log)
    assert contents.problem is None
    (trial,) = contents.trials
    assert len(trial.routes) == (24 if ctrl_c_after is None else ctrl_c_after)
    assert trial.summary is not None and trial.summary.ok == (ctrl_c_after is None)
    assert f"{trial.summary.motion_s:.1f}" == printed
    # more than the routes' own streaming: tool settings, home moves, the parking
    assert trial.summary.motion_s > sum(r.motion_s for r in trial.routes)


def test_a_run_that_moved_without_a_route_prints_and_logs_its_motion(tmp_path: Path) -> None:
    """Stopped before its first route (a Ctrl-C while the servos were calibrated at the
    start, say) the arm has moved all the same: the motion line says how much, as the
    log does (it printed none, and the log said 0)."""
    config = load_config(ROOT / "configs" / "sim.yaml")
    printed: list[str] = []
    with RunLog(tmp_path / "run.jsonl") as log:
        log.header(config)
        reporter = Reporter(config, ArmModel(config.arm).chain, log, printed.append, None)
        motion = MotionTime(stream_hz=50.0, arm_s=1.25, tool_s=0.5, tool_moves=1)
        reporter.summary(ok=False, outcome=Counts(seen={"red": 1}), motion=motion)
    assert motion.line() in printed and motion.line().startswith("motion 1.8 s")
    (trial,) = read_runlog(tmp_path / "run.jsonl").trials
    assert trial.summary is not None and trial.summary.motion_s == pytest.approx(1.75)
