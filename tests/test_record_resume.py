"""A recorded experiment killed with SIGKILL mid-trial, then resumed: no episode lost or twice.

The kill is real (``kill -9`` of the recording process, the encoder process left to notice
on its own) and lands at a fixed point: right after the dataset's third episode is
written, the first pick of the second trial, while that trial goes on. The resumed
dataset is then the one the same experiment records uninterrupted (in worker processes,
``--jobs 2``): the same frames, tags and video bytes.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from badinput import run_in_process
from conftest import ROOT

from mearm.dataset.format_check import check_dataset
from mearm.experiment import trial_seed
from mearm.runlog import read_runlog

pytestmark = pytest.mark.heavy

#: Two objects a trial: the kill after episode 3 falls in trial 1, one pick to go.
SCENE = "- {color: red, x: -10.99, y: 49.70}\n- {color: blue, x: 5.0, y: 45.0}\n"
KILL_AFTER = 3

#: The experiment, killed by SIGKILL once the dataset holds KILL_AFTER episodes.
KILLED = f"""
import os, signal, sys
from mearm.dataset import recorder
real = recorder.DatasetRecorder._commit
def commit(self, ep):
    real(self, ep)
    if len(self._episodes) == {KILL_AFTER}:
        os.kill(os.getpid(), signal.SIGKILL)
recorder.DatasetRecorder._commit = commit
from mearm.experiment import main
sys.exit(main(sys.argv[1:]))
"""


def _experiment(code: str | None, args: list[str]) -> subprocess.Popen[bytes]:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    head = ["-c", code] if code else ["-m", "mearm.experiment"]
    return subprocess.Popen(
        [sys.executable, *head, *args], cwd=ROOT, env=env, start_new_session=True,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )  # fmt: skip


def _gone(group: int, within_s: float) -> bool:
    """Whether every process of the group (the encoder, too) has ended within the time."""
    deadline = time.monotonic() + within_s
    while time.monotonic() < deadline:
        try:
            os.killpg(group, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.05)
    return False


def test_sigkill_mid_trial_then_resume_records_each_pick_once(tmp_path: Path) -> None:
    """Killed after trial 1's first episode: the dataset keeps its 3 episodes, the encoder
    ends by itself, and --resume records trial 1's other pick: 4 episodes, each
    (trial, pick) once and in order, the dataset passes the check, and it is the dataset
    of the same experiment run without a kill, by 2 worker processes."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(SCENE)
    root, log = tmp_path / "ds", tmp_path / "trials.jsonl"
    args = [
        "--config", "configs/sim.yaml", "--scene", str(scene), "--trials", "2", "--seed", "3",
        "--log", str(log), "--record", str(root), "--record-codec", "h264", "--record-fps", "5",
    ]  # fmt: skip
    killed = _experiment(KILLED, args)
    _, err = killed.communicate(timeout=240)
    assert killed.returncode == -signal.SIGKILL, err.decode()
    assert _gone(killed.pid, within_s=120), "the encoder process outlived the recording one"
    assert [(t.number, t.complete) for t in read_runlog(log).trials] == [(0, True), (1, False)]
    assert check_dataset(root) == []
    assert json.loads((root / "meta/info.json").read_text())["total_episodes"] == KILL_AFTER

    # the resumed run needs no process of its own
    resumed = run_in_process(["experiment", *args, "--resume"], within_s=24, cwd=ROOT)
    assert resumed.code == 0, resumed.stderr
    assert f"wrote {root}/ (1 episode, " in resumed.stdout
    assert "; it holds 4 episodes, " in resumed.stdout  # not only what the resume added

    seeds = [trial_seed(3, k) for k in range(2)]
    tags = json.loads((root / "meta/mearm_episodes.json").read_text())["episodes"]
    assert [tag[:2] for tag in tags] == [[s, p] for s in seeds for p in range(2)]
    # each keeps its trial's table, the --scene here (tests/test_replay_tables.py)
    assert all(len(tag[2]["table"]) == 2 for tag in tags)
    episodes = pq.read_table(root / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    assert [e["episode_index"] for e in episodes] == list(range(4))
    assert check_dataset(root) == []
    latest = read_runlog(log).latest().trials
    assert [(t.number, t.complete) for t in latest] == [(0, True), (1, True)]
    # where each starts, for a replay: each trial's first at the reset, its second after
    # it; the resumed pick's too, after the killed run's (tests/test_resume_starts_*.py)
    assert _afters(root) == [None, 0, None, 2]

    # the same experiment uninterrupted, its trials in 2 worker processes: the same dataset
    whole = tmp_path / "whole"
    head, tail = args[: args.index("--log")], args[args.index("--record-codec") :]
    jobs = [*head, "--log", str(tmp_path / "whole.jsonl"), "--record", str(whole), *tail]
    run = _experiment(None, [*jobs, "--jobs", "2"])
    _, err = run.communicate(timeout=240)
    assert run.returncode == 0, err.decode()
    for rel in (DATA, TAGS, STARTS, VIDEO):
        assert _contents(whole / rel) == _contents(root / rel), rel


DATA = "data/chunk-000/file-000.parquet"
TAGS = "meta/mearm_episodes.json"
STARTS = "meta/mearm_starts.json"
VIDEO = "videos/observation.images.table/chunk-000/file-000.mp4"


def _afters(root: Path) -> list[object]:
    """The episode each episode of the dataset continues (``meta/mearm_starts.json``)."""
    starts = json.loads((root / "meta/mearm_starts.json").read_text())["episodes"]
    return [start.get("after", "not known") for start in starts]


def _contents(path: Path) -> object:
    """A file's contents: a parquet file's rows, another's bytes."""
    return pq.read_table(path).to_pylist() if path.suffix == ".parquet" else path.read_bytes()
