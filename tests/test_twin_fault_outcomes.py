"""What a sort and a sweep say when the twin's injected faults strike (simulated).

The scene is the two objects of ``tests/test_twin_faults.py``: the red one is picked from
0.02 s to about 1.4 s of simulated time and brought over the red bin, whose place is
confirmed at about 1.6 s. The outcome must be the twin's: an object it has in its bin is
sorted whatever stopped the sort.
"""

from __future__ import annotations

import pytest
from conftest import ROOT

from mearm.runlog import read_runlog
from mearm.sort import main as sort_main
from mearm.tools import twin_scenes

TWO = "task.scene=[{color: red, x: -5, y: 45}, {color: green, x: 6, y: 50}]"
CONFIG = ROOT / "configs" / "sim_mujoco.yaml"


def _sort_with(fault: str, tmp_path, capsys):
    """Sort the two objects with one fault: (exit code, stdout, stderr, the log's trial)."""
    log = tmp_path / "run.jsonl"
    code = sort_main(
        ["--config", str(CONFIG), "--set", TWO, "--set", f"twin.faults=[{fault}]",
         "--log", str(log)]
    )  # fmt: skip
    out, err = capsys.readouterr()
    (trial,) = read_runlog(log, strict=True).trials
    assert trial.summary is not None, "the log ends with its summary"
    return code, out, err, trial


@pytest.mark.heavy
def test_an_object_the_twin_has_in_its_bin_is_sorted_though_a_fault_stopped_the_place(
    tmp_path, capsys
):
    """The shoulder goes limp at 1.5 s, the red object in the jaws over its bin: the jaws
    sink into the bin and the joint stalls before the place is confirmed. The twin has
    the red object in its bin: the sort counts it sorted (it said 0 of 2, 2 stopped by a
    fault), as ``mearm twin-scenes`` counts it."""
    code, out, _err, trial = _sort_with(
        "{kind: limp_servo, joint: shoulder, at_s: 1.5}", tmp_path, capsys
    )
    assert code == 1  # the sort stopped on the fault
    assert "sorted 1 of 2 objects (simulated; 1 stopped by a fault)" in out.splitlines()
    summary = trial.summary
    assert summary is not None and not summary.ok
    assert summary.sorted == {"red": 1, "green": 0, "blue": 0}
    assert summary.left == {"fault": 1}


@pytest.mark.heavy
def test_a_stall_after_a_limp_servo_names_the_servo_not_what_the_arm_sank_onto(tmp_path, capsys):
    """The elbow goes limp at 1.5 s: the arm sags, its jaws come down on the table and the
    shoulder, held back, stalls. The stop names the limp elbow (it said the jaw "presses
    on table", a contact, as if the arm had pressed on something of its own motion)."""
    code, _out, err, trial = _sort_with(
        "{kind: limp_servo, joint: elbow, at_s: 1.5}", tmp_path, capsys
    )
    assert code == 1
    (fault,) = trial.faults
    assert "stalled: at rest short of its command" in fault.reason
    assert "in the twin the elbow servo went limp at t = 1.500 s (twin.faults)" in fault.reason
    assert "presses on" not in fault.reason
    assert "mearm sort: stopped: joint" in err and "presses on" not in err


@pytest.mark.heavy
def test_a_fault_that_struck_unnoticed_is_kept_in_the_run_log(tmp_path, capsys):
    """The elbow goes limp at 4.0 s, on the way home after the last place, where it holds
    up little: the sort never notices and sorts both. The run ran its course (exit 0,
    ``ok``), and its log keeps the fault (it was only a warning on stderr); a fault that
    stopped the run is kept too."""
    code, out, _err, trial = _sort_with(
        "{kind: limp_servo, joint: elbow, at_s: 4.0}", tmp_path, capsys
    )
    assert code == 0
    assert out.splitlines()[-1] == "sorted 2 of 2 objects (simulated)"
    assert trial.summary is not None and trial.summary.ok and not trial.faults
    struck = {"kind": "limp_servo", "at_s": 4.0, "joint": "elbow"}
    assert trial.summary.twin_faults == [struck]
    assert trial.twin_faults == (struck,) and trial.finished

    code, *_, trial = _sort_with(
        "{kind: limp_servo, joint: shoulder, at_s: 1.5}, {kind: camera_black, at_s: 99}",
        tmp_path / "stopped", capsys,
    )  # fmt: skip
    assert code == 1 and trial.faults
    assert trial.twin_faults == ({"kind": "limp_servo", "at_s": 1.5, "joint": "shoulder"},)


def test_twin_scenes_exits_1_when_a_scene_stopped_on_a_fault(monkeypatch, capsys):
    """A sweep whose scene a fault stopped did not do its job: exit 1 and a last line on
    stderr naming the seeds, whatever ``--require`` (until 2026-12-06 it exited 0 with
    every scene stopped, ``--require`` defaulting to 0, "report only")."""
    stall = "joint shoulder stalled: at rest short of its command; nothing more sent"

    def swept(config, objects, seeds, jobs):  # seed 1 stopped after 1 of 2
        for seed in seeds:
            if seed == 1:
                yield 2, 2, 1, 1, {"fault": 1}, stall, []
            else:
                yield 2, 2, 2, 2, {}, None, []

    monkeypatch.setattr(twin_scenes, "sweep", swept)
    argv = ["--config", "sim_mujoco", "--scenes", "2", "--objects", "2", "--jobs", "1"]
    assert twin_scenes.main(argv) == 1
    out, err = capsys.readouterr()
    assert f"seed   1: sorted  1 of  2 (1 stopped by a fault); {stall}" in out.splitlines()
    assert err.splitlines() == ["mearm twin-scenes: 1 of 2 scenes stopped on a fault (seed 1)"]
    # a share asked for and not met is said too, last
    assert twin_scenes.main([*argv, "--require", "0.9"]) == 1
    assert capsys.readouterr().err.splitlines() == [
        "mearm twin-scenes: 1 of 2 scenes stopped on a fault (seed 1)",
        "mearm twin-scenes: sorted 75.0 % is below --require 0.9 (90.0 %)",
    ]
    # no fault: 0 (report only, --require 0)
    assert twin_scenes.main([*argv, "--first-seed", "2"]) == 0
    assert capsys.readouterr().err == ""


def test_twin_scenes_names_the_first_ten_seeds_a_fault_stopped():
    """Many stopped scenes: the first ten seeds named, the rest counted."""
    line = twin_scenes._stopped_line(list(range(100, 112)), 50)
    assert line == (
        "12 of 50 scenes stopped on a fault (seeds 100, 101, 102, 103, 104, 105, 106, 107, "
        "108, 109 and 2 more)"
    )


@pytest.mark.heavy
def test_twin_scenes_in_the_twin_exits_1_on_a_limp_servo(capsys):
    """The real sweep, one scene of 2 in this process, its shoulder limp at 0.5 s."""
    code = twin_scenes.main(
        ["--config", str(CONFIG), "--scenes", "1", "--objects", "2", "--jobs", "1",
         "--set", "twin.faults=[{kind: limp_servo, joint: shoulder, at_s: 0.5}]"]
    )  # fmt: skip
    out, err = capsys.readouterr()
    assert code == 1, out
    assert "stopped by a fault" in out.splitlines()[0]
    assert err.splitlines()[-1] == "mearm twin-scenes: 1 of 1 scene stopped on a fault (seed 0)"


@pytest.mark.heavy
def test_analyze_says_which_twin_faults_struck(tmp_path, capsys):
    """A fault that struck and never mattered is in ``mearm analyze``'s text too, not only
    in the log: the user reading the tables learns the run had one injected."""
    from mearm.analyze import main as analyze_main

    log = tmp_path / "run.jsonl"
    assert sort_main(
        ["--config", str(CONFIG), "--set", TWO, "--log", str(log), "--quiet",
         "--set", "twin.faults=[{kind: limp_servo, joint: elbow, at_s: 4.0}]"]
    ) == 0  # fmt: skip
    capsys.readouterr()
    assert analyze_main([str(log), "--out", str(tmp_path / "analysis")]) == 0
    out = capsys.readouterr().out
    assert "twin faults that struck: 1 in 1 trial (twin.faults, injected; simulated)" in out
