"""Repeated trials (SPEC §5) and their analysis, on the simulated rig."""

import json
import subprocess
import sys

import cv2
import numpy as np
import pytest
from conftest import ROOT, run_cli

from mearm.experiment import trial_config, trial_seed
from mearm.runlog import read_runlog


@pytest.fixture(scope="module")
def three_trials(tmp_path_factory):
    log = tmp_path_factory.mktemp("exp") / "trials.jsonl"
    r = run_cli(
        "-m", "mearm.experiment", "--config", "configs/sim.yaml",
        "--trials", "3", "--seed", "0", "--log", str(log),
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "3 trials written" in r.stdout
    return log


def test_three_trials_each_sort_a_new_4_4_4_layout(three_trials):
    """Each trial: its own header and seed, 12 objects (4 per colour), 24 routes, all sorted."""
    contents = read_runlog(three_trials)
    assert contents.problem is None and len(contents.trials) == 3
    layouts = []
    for k, trial in enumerate(contents.trials):
        assert trial.header.trial == k and trial.summary.ok
        scene = trial.header.model_extra["scene"]
        assert sorted(o["color"] for o in scene) == ["blue"] * 4 + ["green"] * 4 + ["red"] * 4
        layouts.append(tuple((o["x"], o["y"]) for o in scene))
        assert len(trial.routes) == 24
        assert trial.summary.sorted == {"red": 4, "green": 4, "blue": 4}
    assert len(set(layouts)) == 3
    assert len({t.header.seed for t in contents.trials}) == 3


def test_analysis_of_the_trials_writes_tables_and_plots(three_trials, tmp_path):
    out = tmp_path / "report"
    r = run_cli("-m", "mearm.analyze", str(three_trials), "--out", str(out), timeout=120)
    assert r.returncode == 0, r.stderr
    assert "Table 8" in r.stdout and "Table 9" in r.stdout
    for name in ("histogram.png", "success_vs_error.png", "ee_path_3d.png", "joint_angles.png"):
        assert (out / name).stat().st_size > 10_000, name
    assert "histogram.png" in (out / "report.md").read_text()
    r = run_cli("-m", "mearm.analyze", str(three_trials), "--json")
    data = json.loads(r.stdout)
    assert data  # machine-readable figures


def test_trial_seeds_are_distinct_and_reseed_the_noise(config):
    seeds = {trial_seed(0, k) for k in range(100)} | {trial_seed(1, k) for k in range(100)}
    assert len(seeds) == 200
    cfg = trial_config(config, 1234)
    assert cfg.servo.error_model.seed == 1234 and cfg.camera.seed == 1234
    assert cfg.arm == config.arm and np.isclose(cfg.controller.kp, config.controller.kp)


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--trials", "0", "--log", "x.jsonl"], "--trials must be ≥ 1"),
        (["--trials", "3"], "the following arguments are required: --log"),
        (["--config", "configs/lab.yaml", "--scene", "s.yaml", "--log", "x.jsonl"], "not found"),
    ],
)
def test_bad_input_exits_2(args, needle, tmp_path):
    r = run_cli("-m", "mearm.experiment", *args)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], r.stderr


def test_real_rig_waits_for_the_user_each_trial(tmp_path, config):
    """With a camera that is not simulated, every trial waits for Enter before it starts."""
    from mearm.sim import SimCamera, World

    frames = tmp_path / "frames"
    frames.mkdir()
    empty = SimCamera(config, World(bins_cm={c.name: c.bin_cm for c in config.task.classes})).read()
    cv2.imwrite(str(frames / "table.png"), empty)  # an empty table: each trial ends at once
    cfg = tmp_path / "rig.yaml"
    cfg.write_text(f"camera:\n  kind: folder\n  path: {frames}\n  loop: true\n")
    log = tmp_path / "trials.jsonl"
    r = subprocess.run(
        [sys.executable, "-m", "mearm.experiment", "--config", str(cfg), "--trials", "2",
         "--log", str(log)],
        input="\n\n", capture_output=True, text=True, timeout=60, cwd=ROOT,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert r.stdout.count("lay out the objects, then press Enter") == 2
    assert len(read_runlog(log).trials) == 2
