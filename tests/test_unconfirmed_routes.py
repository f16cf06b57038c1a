"""A route a fault cut before its outcome was checked: logged unconfirmed, no failure.

A link fault (the board refusing a move) during a pick's carry stops the sort before the
pick is checked over the bin. The screen said ``unconfirmed`` and ``failed picks 0``; the
run log said ``"success": false`` with nothing more and counted it in ``failures``, and
``mearm analyze`` took it for a failed grip: Table 9 at 0 % and the "every pick below
this error succeeded" bound set by it. Now the route says ``"confirmed": false`` and no
success rate counts it. The board is the pseudo-terminal fake (no physical board here).
"""

from __future__ import annotations

from badinput import run_in_process
from fakeboard import FakeMearmBoard, MearmFaults

from mearm.analysis.success import pick_outcomes, success_table
from mearm.runlog import read_runlog

#: The fake board refuses the 10th move (error 4): on the paper's layout, during the
#: first object's carry, after its pick route and before the pick is checked.
FAULT = MearmFaults(error_at_move=(10, 4))


def test_a_pick_cut_by_a_fault_is_logged_unconfirmed_and_counted_in_no_rate(tmp_path):
    log = tmp_path / "run.jsonl"
    with FakeMearmBoard(FAULT) as board:
        out = run_in_process(
            ["sort", "--config", "sim", "--set", "servo.backend=serial", "--set",
             f"servo.port={board.port}", "--set", "servo.ack_timeout_s=2.0", "--log", log],
            within_s=60,
        )  # fmt: skip
    assert out.code == 1 and "stopped:" in out.stdout + out.stderr, out.stderr
    assert "unconfirmed" in out.stdout, out.stdout
    trial = read_runlog(log).trials[0]
    cut = [r for r in trial.routes if not r.confirmed]
    assert [(r.step, r.success) for r in cut] == [("pick", False)]
    assert trial.summary is not None and trial.summary.failures == 0
    table = success_table(trial.routes)
    assert table.pick_total.n == len([r for r in trial.routes if r.step == "pick"]) - 1
    errors, success = pick_outcomes(trial.routes)
    assert success.all() and errors.size == table.pick_total.n
