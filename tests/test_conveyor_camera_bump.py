"""A knocked camera stops a belt's sort too: its looks check the bins as the table's do.

The conveyor sorter's looks checked each frame for black and frozen, not for a moved
view: ``mearm sort --config sim_conveyor --set belt.arrivals.count=8 --set
belt.arrivals.seed=44150 --set "twin.faults=[{kind: camera_bump, at_s: 14.18, shift_cm:
[2.4, -2.4, 0]}]"`` (found by a fresh-seed sweep of the twin) sorted on after the bump,
its jaws closing 3.4 cm off every object (``FAILED: the camera still sees it on the
belt``), and ended ``sorted 2 of 5``; with the camera 2 cm off across the belt the jaws
caught each object by its edge and lost it on the way, two tracks a failed place for
each. The belt's objects move, so they cannot show a moved view; the bins stand still
(:func:`~mearm.task.table_tracking.check_bins`): the sort now stops on the camera, the arm
parked, exit 1.
"""

from __future__ import annotations

import pytest
from conftest import ROOT

from mearm.runlog import read_runlog
from mearm.sort import main as sort_main

CONFIG = ROOT / "configs" / "sim_conveyor.yaml"
PARKED = "Fix its mount and recalibrate (tools/calibrate_camera.py); arm parked at home"


def _sort(tmp_path, capsys, *sets: str):
    log = tmp_path / "run.jsonl"
    argv = ["--config", str(CONFIG), "--log", str(log), "--quiet"]
    argv += ["--set", "belt.arrivals.count=2", "--set", "belt.arrivals.seed=44150"]
    for s in sets:
        argv += ["--set", s]
    code = sort_main(argv)
    (trial,) = read_runlog(log, strict=True).trials
    return code, capsys.readouterr().err, trial


@pytest.mark.heavy
def test_a_camera_bumped_after_a_catch_stops_the_belts_sort(tmp_path, capsys):
    """Bumped 2 cm across the belt once the red is in its bin (simulated): the next look
    sees the bins moved, and the sort stops there, before any pick aimed by the moved view."""
    bump = "twin.faults=[{kind: camera_bump, at_s: 9.0, shift_cm: [0, 2, 0]}]"
    code, err, trial = _sort(tmp_path, capsys, bump)
    assert code == 1, err
    assert len(trial.faults) == 1, [(r.object_id, r.step, r.why_failed) for r in trial.routes]
    (fault,) = trial.faults
    assert fault.reason.startswith("camera (twin): the view moved: the bins of "), fault.reason
    assert fault.reason.endswith(PARKED), fault.reason
    assert "mearm sort: stopped: camera (twin): the view moved: the bins of " in err
    assert [(r.object_id, r.step, r.success) for r in trial.routes] == [
        ("red1", "pick", True),
        ("red1", "place", True),
    ]
    assert trial.summary is not None and not trial.summary.ok


@pytest.mark.heavy
def test_an_unbumped_belt_still_sorts(tmp_path, capsys):
    """No bump: the arm over the belt and the bins hides no bin's feet alike, and the belt's
    two objects are sorted (simulated)."""
    code, err, trial = _sort(tmp_path, capsys)
    assert code == 0, err
    assert not trial.faults
    assert "view moved" not in err
    assert trial.summary is not None and trial.summary.ok
