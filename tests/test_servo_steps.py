"""tools/servo_steps.py: the twin's servo step responses, its CSV and its plot."""

from __future__ import annotations

import contextlib
import csv
import subprocess
import sys

import pytest
from badinput import check_bad_input, run_in_process
from conftest import ROOT

TOOL = ROOT / "tools" / "servo_steps.py"


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(TOOL), *args], capture_output=True, text=True, timeout=600
    )


@pytest.mark.heavy
def test_each_joint_reaches_its_step_and_the_plot_is_drawn(tmp_path):
    """A 10° step on every joint of the 5-DOF twin: each ends within a degree of it, having
    moved no faster than its servo can (the CSV is read back as the --before of a plot).
    The tool's real process writes the CSV; the plot is drawn in this process, as
    ``mearm servo-steps`` (another interpreter's start would check nothing more)."""
    table, picture = tmp_path / "steps.csv", tmp_path / "steps.png"
    config = str(ROOT / "configs" / "sim_5dof_mujoco.yaml")
    done = _run("--config", config, "--degrees", "10", "--csv", str(table))
    assert done.returncode == 0, done.stderr
    with table.open(newline="") as f:
        rows = list(csv.DictReader(f))
    joints = {r["joint"] for r in rows}
    assert len(joints) == 5
    for joint in joints:
        angles = [abs(float(r["angle_deg"])) for r in rows if r["joint"] == joint]
        times = [float(r["t_s"]) for r in rows if r["joint"] == joint]
        assert angles[-1] == pytest.approx(10.0, abs=1.0)
        assert times[0] == 0 and times[-1] >= 0.59
        assert angles[0] == 0.0 and angles[5] < 5.0  # at the command; a period on, not there
    plot = ["servo-steps", "--config", config, "--degrees", "5", "--before", table]
    drawn = run_in_process([*plot, "--out", picture], within_s=60)
    assert drawn.code == 0, drawn.stderr
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.heavy
@pytest.mark.parametrize(
    ("args", "says"),
    [
        (("--degrees", "0", "--csv", "s.csv"), "--degrees must be in (0, 90]"),
        (("--before", "missing.csv", "--out", "p.png"), "--before missing.csv"),
        (("--before", "empty.csv", "--out", "p.png"), "--before empty.csv: no responses in it"),
        (
            ("--before", "inf.csv", "--out", "p.png"),
            "--before inf.csv: line 3: step_deg, t_s and angle_deg must",
        ),
        (("--csv", "empty.csv/steps.csv"), "--csv empty.csv/steps.csv: cannot write:"),
        ((), "nothing to write: give --csv FILE, --out FILE.png, or both"),  # it ran, silent
        (("--before", "inf.csv", "--csv", "s.csv"), "--before is drawn in the plot"),
        (("--out", "plot.txt"), "the plot is a PNG, so its name ends in .png"),
        (("--csv", "inf.csv", "--before", "inf.csv", "--out", "p.png"), "three different"),
    ],
)
def test_bad_input_is_named(tmp_path, args, says):
    """Exit 2, one line naming what was wrong, the files left as they were: run in this
    process (the tool's real process is the test above's; 0.3 s of CPU a process here)."""
    (tmp_path / "empty.csv").touch()
    (tmp_path / "inf.csv").write_text(
        "joint,step_deg,t_s,angle_deg\nshoulder,5,0.0,0.0\nshoulder,5,0.02,inf\n"
    )
    with contextlib.chdir(tmp_path):  # the file names are relative, as a user types them
        out = check_bad_input(["servo-steps", *args], keep=[tmp_path])
    assert says in out.line
