"""A resumed experiment records its trials as the dataset holds them: per pick or per scene.

An experiment's episode is known by its trial's seed and its pick's number, and a trial
run again records only the picks the dataset lacks. Per scene, a trial's one episode is
tagged pick 0 and holds every pick. A trial killed mid-way and resumed with the other
``--record-per`` was recorded twice (the whole scene, then its picks 1.. again, or the
picks, then the rest as a "whole-scene" episode), or, in worker processes, the rest was
lost (the scene's episode dropped as held); a trial whose scene episode was written
before the kill was recorded again from its pick 1. The kills here are real (SIGKILL of
the recording process, right after the dataset's Nth episode is written), as in
tests/test_record_resume.py.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from badinput import Outcome, run_in_process
from conftest import ROOT

from mearm.dataset.format_check import check_dataset
from mearm.dataset.lerobot_format import SCRATCH_DIR
from mearm.experiment import trial_seed
from mearm.runlog import read_runlog

pytestmark = pytest.mark.heavy

#: Three objects a trial: a kill after episode 4 (per pick) falls in trial 1, after its
#: first pick; after episode 2 (per scene), once trial 1's episode is written.
SCENE = (
    "- {color: red, x: -10.99, y: 49.70}\n- {color: blue, x: 5.0, y: 45.0}\n"
    "- {color: green, x: 0.0, y: 40.0}\n"
)

#: The experiment, killed by SIGKILL once the dataset holds KILL_AFTER episodes.
KILLED = """
import os, signal, sys
from mearm.dataset import recorder
real = recorder.DatasetRecorder._commit
def commit(self, ep):
    real(self, ep)
    if len(self._episodes) == int(os.environ["KILL_AFTER"]):
        os.kill(os.getpid(), signal.SIGKILL)
recorder.DatasetRecorder._commit = commit
from mearm.experiment import main
sys.exit(main(sys.argv[1:]))
"""


def _args(tmp_path: Path, per: str, *, seed: int = 3) -> list[str]:
    scene = tmp_path / "scene.yaml"
    scene.write_text(SCENE)
    return [
        "experiment", "--config", "configs/sim.yaml", "--scene", str(scene), "--trials", "2",
        "--seed", str(seed), "--log", str(tmp_path / f"trials-{seed}.jsonl"),
        "--record", str(tmp_path / "ds"), "--record-codec", "h264", "--record-fps", "5",
        "--record-per", per,
    ]  # fmt: skip


def _killed(args: list[str], after: int) -> None:
    """``mearm ARGS`` killed with SIGKILL once the dataset holds ``after`` episodes."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "KILL_AFTER": str(after)}
    env["MUJOCO_GL"] = os.environ.get("MUJOCO_GL", "egl")
    run = subprocess.run(
        [sys.executable, "-c", KILLED, *args[1:]],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=240, check=False,
    )  # fmt: skip
    assert run.returncode == -signal.SIGKILL, run.stderr
    log = Path(args[args.index("--log") + 1])
    assert [(t.number, t.complete) for t in read_runlog(log).trials] == [(0, True), (1, False)]


def _mearm(*args: object) -> Outcome:
    """``mearm ARGS`` in this process, in the checkout: a resumed run needs no process of
    its own (the kill does: :func:`_killed`)."""
    return run_in_process(args, within_s=30, cwd=ROOT)


def _tags(root: Path) -> list[list[int]]:
    """Each episode's ``[trial seed, pick]``."""
    return [e[:2] for e in json.loads((root / "meta/mearm_episodes.json").read_text())["episodes"]]


def _files(root: Path) -> dict[str, bytes]:
    """The dataset's files and their bytes; not the killed run's scratch videos, which any
    recorder that opens the dataset removes."""
    files = (p for p in sorted(root.rglob("*")) if p.is_file())
    return {str(p.relative_to(root)): p.read_bytes() for p in files if SCRATCH_DIR not in p.parts}


@pytest.mark.parametrize(("was", "now", "after"), [("pick", "scene", 4), ("scene", "pick", 2)])
def test_a_resume_with_the_other_record_per_is_refused(
    tmp_path: Path, was: str, now: str, after: int
) -> None:
    """Killed mid-trial, resumed with the other --record-per: exit 2, one line naming both
    and what to pass; the dataset and the log as they were. Before: accepted, trial 1's
    picks recorded twice. The same command with the dataset's --record-per resumes it."""
    args = _args(tmp_path, was)
    _killed(args, after)
    root, log = tmp_path / "ds", Path(args[args.index("--log") + 1])
    dataset, logged = _files(root), log.read_bytes()

    other = _mearm(*args[:-1], now, "--resume")
    assert other.code == 2 and len(other.stderr.strip().splitlines()) == 1, other.stderr
    assert "Traceback" not in other.stderr + other.stdout
    line = other.line
    assert f"--record-per {was}" in line and f"--record-per {now}" in line, line
    assert f"resume with --record-per {was}" in line, line
    assert _files(root) == dataset and log.read_bytes() == logged

    same = _mearm(*args, "--resume")
    assert same.code == 0, same.stderr
    seeds = [trial_seed(3, k) for k in range(2)]
    picks = range(3) if was == "pick" else range(1)
    assert _tags(root) == [[s, p] for s in seeds for p in picks]
    assert check_dataset(root, videos=False) == []


def test_a_trial_whose_scene_is_held_is_not_recorded_again(tmp_path: Path) -> None:
    """Per scene, killed once trial 1's episode is written (its summary not yet logged):
    the resumed run runs trial 1 again and records none of it. Before: a second scene
    episode of its picks 1 and 2, tagged pick 1."""
    args = _args(tmp_path, "scene")
    _killed(args, 2)
    root = tmp_path / "ds"
    run = _mearm(*args, "--resume")
    assert run.code == 0, run.stderr
    assert "3 picks of the trial run again were in" in run.stderr
    assert _tags(root) == [[trial_seed(3, k), 0] for k in range(2)]
    assert [t.number for t in read_runlog(args[args.index("--log") + 1]).latest().trials] == [0, 1]


def test_a_new_experiment_may_append_per_the_other(tmp_path: Path) -> None:
    """Another experiment (another --seed, its own log) appends its trials per scene to a
    dataset recorded per pick: none of its trials is there to be cut otherwise."""
    first = _args(tmp_path, "pick")
    first[first.index("--trials") + 1] = "1"
    assert _mearm(*first).code == 0
    second = _args(tmp_path, "scene", seed=4)
    second[second.index("--trials") + 1] = "1"
    run = _mearm(*second, "--resume")
    assert run.code == 0, run.stderr
    assert _tags(tmp_path / "ds") == [[trial_seed(3, 0), p] for p in range(3)] + [
        [trial_seed(4, 0), 0]
    ]
