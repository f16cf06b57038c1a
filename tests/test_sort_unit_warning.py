"""``mearm sort`` and ``mearm experiment`` say the config check's unit warning.

An arm whose angles look like radians passes the sort's config check (the 5-DOF arm's
wrist roll turned 3.1416°, not 180°, moves only its jaws), so nothing stopped the sort and
nothing said why its jaws sat askew. The check's warning is now one line on stderr, before
the arm moves and also with ``--quiet``, and the sort runs on.
"""

from __future__ import annotations

from badinput import run_in_process

ROLL = "arm.joints.wrist_roll.dh.theta_deg=3.1416"
SAID = "wrist_roll.dh.theta_deg = 3.1416: angles are in degrees; these look like radians"


def test_the_sort_warns_of_an_arm_in_radians_and_goes_on():
    r = run_in_process(
        ["sort", "--config", "sim_5dof", "--set", ROLL, "--random", "2", "--quiet"], within_s=60
    )
    warnings = [line for line in r.stderr.splitlines() if "warning" in line]
    assert len(warnings) == 1 and warnings[0].startswith("mearm sort: warning: "), r.stderr
    assert SAID in warnings[0]
    assert r.stdout.rstrip().splitlines()[-1].startswith("sorted "), r.stdout


#: One object per class (the config's own table is three of each): the trials draw as many
#: of each class as it holds, and the warning's count does not depend on the table's size.
ONE_PER_CLASS = (
    "task.scene=[{color: red, x: -8, y: 18}, {color: green, x: -3, y: 14},"
    " {color: blue, x: 0, y: 17}]"
)


def test_the_experiment_warns_of_it_once(tmp_path):
    """Two trials, one warning line."""
    r = run_in_process(
        ["experiment", "--config", "sim_5dof", "--set", ROLL, "--set", ONE_PER_CLASS,
         "--trials", "2", "--log", tmp_path / "run.jsonl"],
        within_s=120,
    )  # fmt: skip
    warnings = [line for line in r.stderr.splitlines() if "warning" in line]
    assert len(warnings) == 1 and SAID in warnings[0], r.stderr
    assert warnings[0].startswith("mearm experiment: warning: ")
