"""Follow-ups of the walk of docs/sorting.md (belt, scenes).

- ``mearm conveyor-sweep`` labelled nothing simulated and printed no last line; an
  object not sorted ended on a table row, exit 1, nothing on stderr; a fault in a sort
  ended as bad input (exit 2, ``error:``).
- A belt over the arm's base was refused as too fast (``at most 0 cm/s``).
- The still table's sorter counted an object never seen before a stop as ``never seen by
  the camera``, not under the stop (the belt's sorter had the same miscount).
- A table with nothing to sort (a scene file ``[]``, ``task.scene: []``, a belt with no
  arrivals) ended ``sorted 0 of 0 objects``, exit 0.
"""

from __future__ import annotations

import pytest
from badinput import run_in_process
from conftest import run_cli

from mearm.config import load_config
from mearm.errors import ConfigError
from mearm.task.rig import open_rig
from mearm.task.sorter import SortAborted, Sorter

#: Two arrivals, 3 to 4 s apart, the first at 0.5 s: a sweep of a second or two per speed.
FEW = [
    "belt.arrivals.count=2",
    "belt.arrivals.first_s=0.5",
    "belt.arrivals.min_gap_s=3",
    "belt.arrivals.max_gap_s=4",
]


def _sets(*items: str) -> list[str]:
    return [a for s in items for a in ("--set", s)]


# ------------------------------------------------------------------- conveyor-sweep


def test_a_sweep_labels_its_figures_simulated_and_ends_on_its_count():
    r = run_in_process(["conveyor-sweep", "--speeds", "1,2", *_sets(*FEW)], within_s=30)
    assert r.code == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].startswith("| belt speed [cm/s] (simulated) |")
    assert lines[-1] == "sorted 4 of 4 objects at 2 speeds (simulated)"
    assert r.stderr == ""


def test_a_sweep_that_left_objects_says_so_on_stderr():
    """A belt 5 m away, out of the camera's view: nothing sorted, exit 1, one line why.

    In a real process, as a shell sees it: the suite's one ``python -m mearm
    conveyor-sweep`` (the others run it in this process).
    """
    r = run_cli(
        "-m", "mearm", "conveyor-sweep", "--speeds", "1", *_sets(*FEW, "belt.start_cm=[500,500]")
    )
    assert r.returncode == 1, r.stderr
    assert r.stdout.splitlines()[-1] == (
        "sorted 0 of 2 objects at 1 speed (simulated; short at 1 cm/s)"
    )
    assert r.stderr.splitlines() == [
        "mearm conveyor-sweep: not every object sorted: 0 of 2 at 1 cm/s"
    ]


@pytest.mark.heavy
def test_a_sweep_stopped_by_a_fault_is_a_failed_run_not_bad_input():
    """The twin's shoulder servo goes limp: the first speed's sort stops (exit 1, not 2)."""
    limp = "twin.faults=[{kind: limp_servo, at_s: 1.0, joint: shoulder}]"
    r = run_in_process(
        ["conveyor-sweep", "--config", "sim_conveyor", "--speeds", "1,2", *_sets(*FEW, limp)],
        within_s=30,
    )
    assert r.code == 1, r.stderr
    assert r.stdout.splitlines()[-1] == "stopped at 1 cm/s after 0 of 2 speeds"
    *said, line = r.stderr.splitlines()  # the injected fault said as it struck, then why
    assert said == [
        "mearm conveyor-sweep: warning: twin: fault limp_servo joint=shoulder at t = 1.000 s"
    ]
    assert line.startswith("mearm conveyor-sweep: stopped at 1 cm/s: joint shoulder stalled")


def test_a_speed_given_twice_is_refused_before_any_sort():
    """``--speeds 1,2,1`` sorted at 1 cm/s twice and counted its objects twice in the total."""
    r = run_in_process(["conveyor-sweep", "--speeds", "1,2,1"], within_s=30)
    assert r.code == 2 and r.stdout == "", r.stdout
    assert r.line == "mearm conveyor-sweep: error: --speeds: 1 cm/s given twice; give each once"


def test_a_speed_out_of_range_is_named_as_typed():
    """The refusal names --speeds and the value, then the config key it sets."""
    r = run_in_process(["conveyor-sweep", "--speeds", "1,-1"], within_s=30)
    assert r.code == 2 and r.stdout == "", r.stdout
    assert r.line.startswith("mearm conveyor-sweep: error: --speeds -1: belt.speed_cm_s: ")


# ----------------------------------------------------------------- belt over the base


@pytest.mark.parametrize("start", ["[0,0]", "[0,3]"])
def test_a_belt_over_the_base_is_refused_as_such_not_as_too_fast(start):
    with pytest.raises(ConfigError) as caught:
        load_config("sim_conveyor_kinematic", [f"belt.start_cm={start}"])
    message = str(caught.value)
    assert "belt.start_cm: the belt crosses the arm's base" in message, message
    assert "must pass at least 7.86 cm from the base axis" in message, message
    assert "cm/s" not in message, message


def test_a_belt_just_clear_of_the_base_passes_that_check():
    """Its middle line 7.9 cm out (base plate 4.86 cm + half of 6 cm): the speed bound decides."""
    with pytest.raises(ConfigError, match="faster than the arm can follow"):
        load_config("sim_conveyor_kinematic", ["belt.start_cm=[0,7.9]", "belt.speed_cm_s=100"])
    assert load_config("sim_conveyor_kinematic", ["belt.start_cm=[0,7.9]"]).belt is not None


# ---------------------------------------------------- a still table stopped at once


class StoppedCamera:
    """The rig's camera, whose first read is a Ctrl-C: the sort stops before it looks."""

    def __init__(self, camera):
        self.camera = camera

    def read(self):
        raise KeyboardInterrupt

    def __getattr__(self, name):
        return getattr(self.camera, name)


def test_a_still_table_stopped_before_its_first_look_counts_its_objects_as_stopped():
    config = load_config("sim")
    with open_rig(config) as rig:
        sorter = Sorter(
            config, StoppedCamera(rig.camera), rig.bus, model=rig.model, echo=None,
            in_bins=rig.in_bins, placed=rig.placed,
        )  # fmt: skip
        with pytest.raises(SortAborted) as caught:
            sorter.run()
    outcome = caught.value.outcome
    assert outcome.n_objects == 12 and outcome.n_sorted == 0
    assert outcome.left == {"interrupted": 12}
    assert sum(outcome.unseen.values()) == 12  # the camera did not see them: still recorded
    assert sorter.report.line() == "sorted 0 of 12 objects (simulated; 12 interrupted)"


# ------------------------------------------------------------- nothing to sort


@pytest.mark.parametrize(
    ("argv", "line"),
    [
        (["--scene", "{scene}"], "mearm sort: error: {scene}: no objects: nothing to sort"),
        (["--set", "task.scene=[]"], "mearm sort: error: task.scene: no objects: nothing to sort"),
        (
            ["--config", "sim_conveyor_kinematic", "--set", "belt.arrivals.count=0"],
            "mearm sort: error: belt.arrivals.count: 0: the belt brings nothing to sort",
        ),
    ],
    ids=["scene_file", "task_scene", "belt"],
)
def test_a_table_with_nothing_to_sort_is_bad_input(tmp_path, argv, line):
    scene = tmp_path / "scene.yaml"
    scene.write_text("[]\n")
    log = tmp_path / "run.jsonl"
    argv = [a.format(scene=scene) for a in argv]
    r = run_in_process(["sort", "--quiet", "--log", str(log), *argv], within_s=30)
    assert r.code == 2, r.stdout + r.stderr
    (got,) = r.stderr.splitlines()
    assert got.startswith(line.format(scene=scene)), got
    assert r.stdout == "" and not log.exists()
    # the config's own table empty (a real rig's config on the simulated camera): the
    # sort's ways to lay one out are named; a scene file the user gave is theirs to fill
    assert ("--random N or --scene FILE" in got) == ("task.scene" in argv[-1]), got


def test_a_sweep_of_a_belt_that_brings_nothing_is_bad_input():
    r = run_in_process(["conveyor-sweep", "--speeds", "1", "--set", "belt.arrivals.count=0"])
    assert r.code == 2 and r.stdout == ""
    assert r.stderr.splitlines() == [
        "mearm conveyor-sweep: error: belt.arrivals.count: 0: the belt brings nothing to sort "
        "(it must bring 1 to 500 objects)"
    ]


# ------------------------------------------------------------------- the belt's surface


@pytest.mark.parametrize("surface_cm", ["3", "10"])
def test_the_kinematic_simulator_grips_an_object_on_a_raised_belt(surface_cm):
    """Its grip compared the jaws' height with the table's objects', not the belt's: over a
    belt 1.5 cm or more high every pick failed (the planner aimed right)."""
    argv = ["sort", "--config", "sim_conveyor_kinematic", "--quiet"]
    r = run_in_process([*argv, *_sets(*FEW, f"belt.surface_cm={surface_cm}")], within_s=60)
    assert (r.code, r.stdout.splitlines()[-1]) == (0, "sorted 2 of 2 objects (simulated)")


def test_an_object_whose_pick_failed_on_the_belt_is_counted_once():
    """A failed pick's object rides on and is seen again: that sighting began a new track
    and a new object (``sorted 0 of 4`` for 3 arrivals, an object the belt never brought);
    it is the same object, left as its pick failed."""
    argv = ["sort", "--config", "sim_conveyor_kinematic", "--quiet"]
    sets = _sets("belt.arrivals.count=3", "servo.error_model.offset_deg.base=6")
    r = run_in_process([*argv, *sets], within_s=120)
    assert r.code == 1
    assert r.stdout.splitlines()[-1] == "sorted 0 of 3 objects (simulated; 3 pick failed)"
