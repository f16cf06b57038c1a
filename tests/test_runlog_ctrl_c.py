"""Ctrl-C while a record is written: the file and the writer's trial agree.

A summary written to the file but not yet to the trial's state let a fault record follow
it ("fault record after the summary of trial 3", an experiment stopped by Ctrl-C).
"""

from __future__ import annotations

import signal

import pytest

from mearm.config import load_config
from mearm.runlog import RunLog, read_runlog
from mearm.runlog.errors import RunLogError


@pytest.fixture
def ctrl_c_raises():
    """Ctrl-C raises KeyboardInterrupt, as in a terminal: a suite started in the background
    (``cmd &`` without job control) inherits SIGINT ignored, and nothing would be raised."""
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, before)


@pytest.mark.usefixtures("ctrl_c_raises")
def test_ctrl_c_while_the_summary_is_written_takes_effect_after_it(tmp_path) -> None:
    log = tmp_path / "run.jsonl"
    with RunLog(log, fsync=False) as w:
        w.header(load_config("configs/sim.yaml"), trial=1)
        append = w._append

        def append_then_ctrl_c(record):
            append(record)
            if record.type == "summary":
                signal.raise_signal(signal.SIGINT)  # between the file and the trial's state

        w._append = append_then_ctrl_c
        with pytest.raises(KeyboardInterrupt):
            w.summary(trial=1, ok=True, objects={}, left={})
        with pytest.raises(RunLogError, match="already has its summary"):
            w.fault("after the sort: interrupted (Ctrl-C)", trial=1)
    trials = read_runlog(log).trials
    assert len(trials) == 1 and trials[0].summary is not None and not trials[0].faults
