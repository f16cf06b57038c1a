"""A recorded experiment killed mid-trial and resumed: its resumed pick replays from its start.

``mearm experiment --record DIR`` on the twin, a trial of two picks, killed with SIGKILL
right after the first pick of its second trial is written; ``--resume`` runs that trial
again and records its second pick only. That episode begins where the first pick left
the arm (the jaws closed on nothing, over the red bin) and the table (the red object in
its bin), but the dataset said its start was not known, and its replay started from the
reset: the arm at home, the jaws open, no object in a bin. It now continues the held
episode, and its replay's measured start is its recorded frame 0.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from badinput import run_in_process
from conftest import ROOT
from test_record_resume import KILLED, SCENE  # the experiment killed after episode 3

from mearm.dataset.format_check import check_dataset
from mearm.envs.replay import replay

pytestmark = pytest.mark.heavy


def _experiment(head: list[str], args: list[str]) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run(
        [sys.executable, *head, *args], cwd=ROOT, env=env, capture_output=True, text=True,
        timeout=240,
    )  # fmt: skip


def _frame0(root: Path, episode: int) -> np.ndarray:
    """The episode's recorded ``observation.state`` at its frame 0."""
    table = pq.read_table(root / "data/chunk-000/file-000.parquet").to_pydict()
    (row,) = [
        i
        for i, (e, f) in enumerate(zip(table["episode_index"], table["frame_index"], strict=True))
        if e == episode and f == 0
    ]
    return np.array(table["observation.state"][row])


def test_a_resumed_pick_replays_from_where_it_was_recorded(tmp_path: Path) -> None:
    """After the kill and --resume, episode 3 (trial 1's second pick) continues episode 2
    (its first, the killed run's); its replay steps that one first and begins with the arm
    where the recording's frame 0 has it, the red object already in its bin, and puts
    the blue one in its own. Before: not known, replayed from the reset (the jaws 30°
    apart from the recording's), no object in a bin before it."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(SCENE)
    root = tmp_path / "ds"
    args = [
        "--config", "sim_mujoco", "--scene", str(scene), "--trials", "2", "--seed", "3",
        "--log", str(tmp_path / "trials.jsonl"), "--record", str(root), "--record-per", "pick",
        "--record-codec", "h264", "--record-fps", "10",
    ]  # fmt: skip
    killed = _experiment(["-c", KILLED], args)
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    # the resumed run needs no process of its own
    resumed = run_in_process(["experiment", *args, "--resume"], within_s=24, cwd=ROOT)
    assert resumed.code == 0, resumed.stderr
    assert "1 pick of the trial run again was in" in resumed.stderr
    assert check_dataset(root) == []

    starts = json.loads((root / "meta/mearm_starts.json").read_text())["episodes"]
    assert [s.get("after", "not known") for s in starts] == [None, 0, None, 2]
    out = replay(root, 3)
    assert out.start_known and out.why_not_known == ""
    assert out.lead_steps > 0 and out.pick == "blue"
    assert np.allclose(out.start_state, _frame0(root, 3), atol=0.05), (
        out.start_state,
        _frame0(root, 3),
    )
    assert out.before == 1 and out.success
