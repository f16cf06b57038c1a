"""A grip that lets go on the way to the bin counts as a failed pick: the retries bound it.

``mearm sort --config sim_mearm_v1_mujoco --random 6 --seed 44197 --set
task.classes.blue.height_cm=0.8`` (found by a fresh-seed sweep of the twin): the jaws
closed on blue1, a 0.8 cm disc 5 cm in front of the blue bin, and lost it on the lift, so
it lay where it had. The look from over the blue bin, the arm between the camera and the
spot, did not see it there, so the pick was logged ``ok``; the place found the jaws
empty (``FAILED: … lost on the way and is on the table at (1.0, 17.7) cm``), and the
next round went for it again. Only a missed pick counted against ``task.pick_retries``:
the sort picked it 305 times more, 646 s of simulated motion, until ``max_rounds`` ended
it as ``table never cleared``. A failed place now counts as a failed attempt, as a
missed pick does: after ``task.pick_retries`` retries the object is left (``pick
failed``), the place that left it named.
"""

from __future__ import annotations

import pytest
from conftest import ROOT, run_main

from mearm import sort
from mearm.runlog import read_runlog

CONFIG = ROOT / "configs" / "sim_mearm_v1_mujoco.yaml"
LOST = "over the bin the jaws held nothing of its class: it was lost on the way and "


@pytest.mark.heavy
def test_a_grip_lost_on_every_lift_is_retried_as_a_missed_one(tmp_path, capsys) -> None:
    log = tmp_path / "run.jsonl"
    code, out, err = run_main(
        capsys, sort.main, "--config", CONFIG, "--log", log,
        "--set", "task.classes.blue.height_cm=0.8",
        "--set", "task.scene=[{color: blue, x: 1.0, y: 17.8}]",
    )  # fmt: skip
    lines = out.splitlines()
    picks = [ln for ln in lines if ln.startswith("pick  blue1")]
    places = [ln for ln in lines if ln.startswith("place blue1")]
    assert len(places) == 3, out  # the first attempt and task.pick_retries (2) more
    assert len(picks) == 3, out
    assert all(" FAILED " in ln and LOST in ln for ln in places), places
    (skip,) = (ln for ln in lines if ln.startswith("skip  blue1"))
    assert "3 picks failed to bring it to its bin (after its place failed: " + LOST in skip
    assert out.strip().endswith("sorted 0 of 1 objects (simulated; 1 pick failed)"), out
    assert code == 1, err
    (trial,) = read_runlog(log, strict=True).trials
    assert [(r.step, r.attempt) for r in trial.routes] == [
        ("pick", 1), ("place", 1), ("pick", 2), ("place", 1), ("pick", 3), ("place", 1),
    ]  # fmt: skip
    (left,) = trial.skips
    assert left.reason.startswith("3 picks failed to bring it to its bin"), left.reason
    assert trial.summary is not None and trial.summary.left == {"pick_failed": 1}
