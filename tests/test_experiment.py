"""Repeated trials (paper §5) and their analysis; resuming a log; the per-trial prompt."""

import contextlib
import io
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import Outcome, run_in_process
from built_once import built_once
from conftest import ROOT
from test_sweeps import ONE_PER_CLASS

from mearm.config import load_config
from mearm.experiment import plan_trial, trial_config, trial_seed
from mearm.runlog import read_runlog


@pytest.fixture(scope="module")
def three_trials(tmp_path_factory):
    """Three trials' log, one object of each class a trial (run once per test run, in this
    process; read only)."""

    def run(d):
        r = run_in_process(
            ["experiment", "--config", ROOT / "configs" / "sim.yaml", *ONE_PER_CLASS,
             "--trials", "3", "--seed", "0", "--log", d / "trials.jsonl"],
            within_s=30,
        )  # fmt: skip
        assert r.code == 0, r.stderr
        assert "3 trials written" in r.stdout

    return built_once(tmp_path_factory, "three-trials-one-per-class", run) / "trials.jsonl"


@pytest.mark.heavy
def test_three_trials_each_sort_a_new_layout_of_the_configs_counts(three_trials):
    """Each trial: its own header and seed, a new layout of the config's table's counts (one
    of each colour), two routes an object, all sorted."""
    contents = read_runlog(three_trials)
    assert contents.problem is None and len(contents.trials) == 3
    layouts = []
    for k, trial in enumerate(contents.trials):
        assert trial.header.trial == k and trial.summary.ok
        scene = trial.header.model_extra["scene"]
        assert sorted(o["color"] for o in scene) == ["blue", "green", "red"]
        layouts.append(tuple((o["x"], o["y"]) for o in scene))
        assert len(trial.routes) == 6
        assert trial.summary.sorted == {"red": 1, "green": 1, "blue": 1}
    assert len(set(layouts)) == 3
    assert len({t.header.seed for t in contents.trials}) == 3


def test_the_papers_trials_each_lay_a_new_4_4_4_layout():
    """sim.yaml's own table (the paper's): each trial lays 12 objects, 4 per colour, a new
    layout each (what the trials above sort, with the paper's counts)."""
    config = load_config(ROOT / "configs" / "sim.yaml")
    layouts = []
    for k in range(3):
        layout = plan_trial(config, 0, k).layout
        assert layout is not None
        assert sorted(o.color for o in layout) == ["blue"] * 4 + ["green"] * 4 + ["red"] * 4
        layouts.append(tuple((o.x, o.y) for o in layout))
    assert len(set(layouts)) == 3


@pytest.mark.heavy
def test_analysis_of_the_trials_writes_tables_and_plots(three_trials, tmp_path):
    out = tmp_path / "report"
    """In this process (tests/test_analyze_cli.py and the wheel's test run it as a command)."""
    r = run_in_process(["analyze", three_trials, "--out", out], within_s=30)
    assert r.code == 0, r.stderr
    assert "Table 8" in r.stdout and "Table 9" in r.stdout
    for name in ("histogram.png", "success_vs_error.png", "ee_path_3d.png", "joint_angles.png"):
        assert (out / name).stat().st_size > 10_000, name
    assert "histogram.png" in (out / "report.md").read_text()
    r = run_in_process(["analyze", three_trials, "--json"], within_s=30)
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
@pytest.mark.heavy
def test_bad_input_exits_2(args, needle, tmp_path):
    """Refused in this process (the tests without a terminal below run a real one)."""
    with contextlib.chdir(ROOT):
        r = experiment(*args)
    assert r.code == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], r.stderr


# --------------------------------------------------------------------------- resuming

#: Two objects in every trial: quick trials for the resume tests.
SCENE = "- {color: red, x: -10.99, y: 49.70}\n- {color: blue, x: 5.0, y: 45.0}\n"


def experiment(*args: object, stdin: str = "") -> Outcome:
    """``mearm experiment ARGS`` in this process, standard input not a terminal."""
    saved = sys.stdin
    sys.stdin = io.StringIO(stdin)
    try:
        return run_in_process(["experiment", *map(str, args)], within_s=120)
    finally:
        sys.stdin = saved


@pytest.fixture()
def scene(tmp_path: Path) -> Path:
    path = tmp_path / "scene.yaml"
    path.write_text(SCENE)
    return path


def numbers(log: Path) -> list[tuple[int | None, bool]]:
    """(trial number, complete) of every trial in the log, in file order."""
    return [(t.number, t.complete) for t in read_runlog(log).trials]


@pytest.mark.heavy
def test_a_second_run_continues_after_the_last_complete_trial(tmp_path, scene):
    """The same --log with more --trials appends the missing trials; nothing before changes."""
    log = tmp_path / "trials.jsonl"
    assert experiment("--trials", 2, "--scene", scene, "--log", log).code == 0
    before = log.read_bytes()
    out = experiment("--trials", 4, "--scene", scene, "--log", log)
    assert out.code == 0, out.stderr
    assert "resuming" in out.stdout and "running trials 2..3" in out.stdout
    assert "2 trials written" in out.stdout
    assert log.read_bytes().startswith(before)
    assert numbers(log) == [(0, True), (1, True), (2, True), (3, True)]
    seeds = [t.header.seed for t in read_runlog(log).trials]
    assert seeds == [trial_seed(0, k) for k in range(4)]


def test_a_finished_experiment_says_so_and_writes_nothing(tmp_path, scene):
    log = tmp_path / "trials.jsonl"
    assert experiment("--trials", 2, "--scene", scene, "--log", log).code == 0
    before = log.read_bytes()
    for trials in (2, 1):
        out = experiment("--trials", trials, "--scene", scene, "--log", log)
        assert out.code == 0 and "already holds 2 complete trials" in out.stdout
    assert log.read_bytes() == before


def test_a_cut_off_trial_is_run_again_and_analysed_once(tmp_path, scene, capsys):
    """A trial without its summary (killed) is rerun with the same number and seed; the
    log keeps both attempts and analyze counts the complete one."""
    log = tmp_path / "trials.jsonl"
    assert experiment("--trials", 2, "--scene", scene, "--log", log).code == 0
    lines = log.read_bytes().splitlines(keepends=True)
    assert b'"type":"summary"' in lines[-1]
    log.write_bytes(b"".join(lines[:-1]))  # trial 1 cut off before its summary
    cut = log.read_bytes()
    out = experiment("--trials", 2, "--scene", scene, "--log", log)
    assert out.code == 0, out.stderr
    assert "trial 1 again, it was cut off" in out.stdout
    assert log.read_bytes().startswith(cut)
    assert numbers(log) == [(0, True), (1, False), (1, True)]
    contents = read_runlog(log)
    first, again = contents.trials[1:]
    assert first.header.seed == again.header.seed
    assert first.header.model_extra["scene"] == again.header.model_extra["scene"]
    assert [t.line for t in contents.latest().trials] == [1, again.line]
    from mearm.analyze import main as analyze

    assert analyze([str(log), "--json"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["analysis"]["trials"] == 2
    assert "left out 1 cut-off attempt(s) of trial(s) 1" in captured.err


def test_a_torn_last_line_is_set_aside_and_the_run_goes_on(tmp_path, scene):
    log = tmp_path / "trials.jsonl"
    assert experiment("--trials", 2, "--scene", scene, "--log", log).code == 0
    data = log.read_bytes()
    torn_at = len(data) - 30  # inside trial 1's summary line
    log.write_bytes(data[:torn_at])
    out = experiment("--trials", 2, "--scene", scene, "--log", log)
    assert out.code == 0, out.stderr
    (side,) = tmp_path.glob("trials.jsonl.torn-*")
    assert side.read_bytes() == data[data.rindex(b"\n", 0, torn_at) + 1 : torn_at]
    assert f"wrote {side} (the torn last line of {log}" in out.stdout
    contents = read_runlog(log)
    assert contents.complete and [(t.number, t.complete) for t in contents.latest().trials] == [
        (0, True),
        (1, True),
    ]


def test_a_whole_last_record_missing_its_newline_is_kept(tmp_path, scene):
    log = tmp_path / "trials.jsonl"
    assert experiment("--trials", 1, "--scene", scene, "--log", log).code == 0
    whole = log.read_bytes()
    log.write_bytes(whole[:-1])
    assert experiment("--trials", 2, "--scene", scene, "--log", log).code == 0
    assert log.read_bytes().startswith(whole) and not list(tmp_path.glob("*.torn-*"))
    assert numbers(log) == [(0, True), (1, True)]


@pytest.mark.heavy
def test_a_killed_experiment_resumes_and_loses_nothing(tmp_path):
    """SIGKILL in the middle of a run, then the same command: every trial once, complete,
    and every byte written before the kill still there."""
    log, trials = tmp_path / "trials.jsonl", 10
    # trials of one object of each class (a third of the time of the paper's 12): 10 leave
    # the kill below the room (about 1 s of trials after the third's start) that 5 did
    args = ["--trials", str(trials), *ONE_PER_CLASS, "--log", str(log)]
    cmd = [sys.executable, "-m", "mearm", "experiment", *args]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        if log.exists() and log.read_bytes().count(b'"type":"header"') >= 3:
            break
        time.sleep(0.01)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    written = log.read_bytes()
    assert 0 < written.count(b'"type":"summary"') < trials, "the run was not killed mid-way"
    out = experiment(*args)
    assert out.code == 0, out.stderr
    whole_lines = written[: written.rindex(b"\n") + 1]
    assert log.read_bytes().startswith(whole_lines)
    assert [(t.number, t.complete) for t in read_runlog(log).latest().trials] == [
        (k, True) for k in range(trials)
    ]


# --------------------------------------------------------------------------- the prompt


@pytest.fixture()
def rig(tmp_path: Path, config) -> Path:
    """A rig whose camera is not simulated (a folder of one empty-table frame)."""
    from mearm.sim import SimCamera, World

    frames = tmp_path / "frames"
    frames.mkdir()
    empty = SimCamera(config, World(bins={c.name: c for c in config.task.classes})).read()
    cv2.imwrite(str(frames / "table.png"), empty)  # an empty table: each trial ends at once
    cfg = tmp_path / "rig.yaml"
    # nothing on the simulated table either: no object the camera cannot see is left
    cfg.write_text(f"camera:\n  kind: folder\n  path: {frames}\n  loop: true\ntask:\n  scene: []\n")
    return cfg


def run_on_pty(args: list[str], keys: bytes) -> subprocess.CompletedProcess[str]:
    """Run ``python -m mearm.experiment ARGS`` with a pseudo-terminal as standard input."""
    master, slave = os.openpty()
    try:
        proc = subprocess.Popen(
            [sys.executable, "-m", "mearm.experiment", *args],
            stdin=slave, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
        )  # fmt: skip
        os.close(slave)
        os.write(master, keys)
        out, err = proc.communicate(timeout=60)
    finally:
        os.close(master)
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


@pytest.mark.heavy
def test_real_rig_waits_for_enter_on_the_terminal_each_trial(tmp_path, rig):
    """With a camera that is not simulated, every trial waits for Enter before it starts."""
    log = tmp_path / "trials.jsonl"
    r = run_on_pty(["--config", str(rig), "--trials", "2", "--log", str(log)], b"\n\n")
    assert r.returncode == 0, r.stderr
    assert r.stdout.count("lay out the objects, then press Enter") == 2
    assert len(read_runlog(log).trials) == 2


@pytest.mark.heavy
def test_end_of_input_at_a_prompt_stops_cleanly(tmp_path, rig):
    """Ctrl-D at the second prompt: exit 2, one line, trial 0 in the log, nothing after."""
    log = tmp_path / "trials.jsonl"
    r = run_on_pty(["--config", str(rig), "--trials", "3", "--log", str(log)], b"\n\x04")
    assert r.returncode == 2
    (line,) = r.stderr.strip().splitlines()
    assert "input ended at the prompt of trial 1" in line and "resumes at trial 1" in line
    assert numbers(log) == [(0, True)]


@pytest.mark.parametrize("stdin", ["closed", "devnull"])
@pytest.mark.heavy
def test_without_a_terminal_the_rig_refuses_before_anything(tmp_path, rig, stdin):
    """No terminal: exit 2 with one line naming --yes; no log, no motion."""
    log = tmp_path / "trials.jsonl"
    r = subprocess.run(
        [sys.executable, "-m", "mearm.experiment", "--config", str(rig), "--log", str(log)],
        stdin=subprocess.DEVNULL if stdin == "devnull" else None,
        preexec_fn=(lambda: os.close(0)) if stdin == "closed" else None,
        capture_output=True, text=True, timeout=60, cwd=ROOT,
    )  # fmt: skip
    assert r.returncode == 2
    (line,) = r.stderr.strip().splitlines()
    assert "needs a terminal to confirm each layout" in line and "--yes" in line
    assert not log.exists()


def test_yes_runs_every_trial_without_asking(tmp_path, rig):
    log = tmp_path / "trials.jsonl"
    out = experiment("--config", rig, "--trials", 2, "--yes", "--log", log)
    assert out.code == 0, out.stderr
    assert "press Enter" not in out.stdout
    assert numbers(log) == [(0, True), (1, True)]
