"""A sort recorded with --record, its action column replayed in the environment, ends the same."""

from __future__ import annotations

import contextlib
from pathlib import Path

import pytest
import yaml
from badinput import run_in_process
from conftest import ROOT, run_main

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from mearm.config import load_config  # noqa: E402
from mearm.dataset.errors import DatasetError  # noqa: E402
from mearm.dataset.recorder import DatasetRecorder  # noqa: E402
from mearm.envs.replay import main as replay_main  # noqa: E402
from mearm.envs.replay import plan_replay, replay  # noqa: E402
from mearm.task.rig import run_sort  # noqa: E402
from mearm.task.scene import random_scene  # noqa: E402

pytestmark = pytest.mark.heavy


@pytest.fixture(scope="module")
def sorted_here(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, int]]:
    """Seed 7, two objects, recorded per scene at the servo rate by the library (no
    scene kept: the recorder is given none; H.264, quicker to encode than AV1, and the
    replay reads the actions only): the dataset, and how many of each class the sort put
    in its bin."""
    config = load_config("sim_mujoco")
    ds = tmp_path_factory.mktemp("sorted_here") / "ds"
    recorder = DatasetRecorder(ds, config, fps=50, per="scene", codec="h264")
    try:
        report = run_sort(config, scene=random_scene(config, 2, seed=7), echo=None,
                          recorder=recorder)  # fmt: skip
    finally:
        recorder.close()
    return ds, {c: n for c, n in report.outcome.sorted.items() if n}


def test_a_recorded_scene_replays_to_the_same_objects_in_the_same_bins(sorted_here):
    """Seed 7, two objects, recorded per scene at the servo rate: the replay sorts both."""
    ds, recorded = sorted_here
    out = replay(ds, 0, seed=7, config="sim_mujoco", objects=2)
    replayed: dict[str, int] = {}
    for cls in out.bins.values():
        replayed[cls] = replayed.get(cls, 0) + 1
    assert sum(recorded.values()) == 2 and replayed == recorded
    assert out.success and out.refused == 0
    assert all(oid.startswith(cls) for oid, cls in out.bins.items())


def test_a_missing_episode_or_dataset_is_named(tmp_path):
    """No dataset there, or no such episode: DatasetError saying which."""
    with pytest.raises(DatasetError, match="not a LeRobot dataset"):
        replay(tmp_path, 0, seed=0)


def test_the_replay_command_exits_2_on_a_folder_that_is_no_dataset(tmp_path):
    """`python -m mearm.envs.replay` on an empty folder: exit 2, one line naming it."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    proc = subprocess.run(
        [sys.executable, "-m", "mearm.envs.replay", str(tmp_path), "--objects", "2", "--seed", "0"],
        capture_output=True, text=True, cwd=root, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "not a LeRobot dataset" in lines[0]


def _servo_file(folder):
    """A servo calibration file of the twin's arm: its base servo's own calibration
    (a sort with it runs as one without)."""
    from mearm.config.servo_file import (
        ActuatorFit,
        ServoCalibrationFile,
        save_servo_calibration,
        servo_of,
    )

    arm = load_config("sim_mujoco").arm
    base = servo_of(arm, "base")
    fit = ActuatorFit("base", "deg", base, (), 0.0, replaces=base)
    cal = ServoCalibrationFile(arm.name, "test", "", "2026-01-01T00:00:00+00:00", (fit,))
    folder.mkdir()
    return save_servo_calibration(folder / "base.servos.yaml", cal)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory):
    """``mearm sort --random 2 --seed 7 --record`` per scene at the servo rate (the CLI),
    its --config a path relative to the checkout and a servo calibration file by --set,
    relative to the checkout too (the replays run elsewhere)."""
    import os

    here = tmp_path_factory.mktemp("replay")
    ds = here / "rec"
    servo_file = os.path.relpath(_servo_file(here / "sort"), ROOT)
    with contextlib.chdir(ROOT):
        out = run_in_process(
            ["sort", "--config", "configs/sim_mujoco.yaml",
             "--set", f"servo.calibration_file={servo_file}",
             "--random", "2", "--seed", "7", "--record", ds, "--record-per", "scene",
             "--record-fps", "50", "--record-codec", "h264", "--quiet"],
            within_s=30,
        )  # fmt: skip
    assert out.code == 0, out.stderr
    return ds


def _replay_cli(ds, capsys, monkeypatch, *args: str) -> tuple[int, str, str]:
    """The replay command in this process, in the dataset's folder (not the sort's)."""
    monkeypatch.chdir(ds.parent)
    return run_main(capsys, replay_main, ds, *args)


def test_the_replay_takes_the_recorded_scene(recorded, capsys, monkeypatch):
    """No --seed or --objects: the dataset's own (it kept --random 2 --seed 7), and its
    config and --set servo calibration file from another folder than the sort's (kept by
    their absolute paths: the replay said the file "is not a file")."""
    code, out, err = _replay_cli(recorded, capsys, monkeypatch)
    assert code == 0, err
    assert "2 of 2 objects in their bins" in out


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--seed", "8"], "episode 0 was recorded with --random 2 --seed 7, not --seed 8"),
        (["--objects", "3"], "episode 0 was recorded with --random 2 --seed 7, not --objects 3"),
        (
            ["--config", "sim_5dof_mujoco"],
            "recorded with the arm 'mearm_paper', --config sim_5dof_mujoco has the arm",
        ),
        (["--episode", "1"], "has no episode 1 (it holds episodes 0..0)"),
    ],
)
def test_the_replay_refuses_inputs_the_recording_disagrees_with(
    recorded, capsys, monkeypatch, args, says
):
    """Exit 2, one line: not "0 of 2 in their bins" (exit 1) or a ValueError from a step."""
    code, out, err = _replay_cli(recorded, capsys, monkeypatch, *args)
    assert code == 2, out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and says in lines[0], lines


def test_an_episode_without_a_scene_needs_seed_and_objects(sorted_here):
    """Recorded without --random N --seed S: the replay asks for them, by name."""
    ds, _ = sorted_here
    with pytest.raises(DatasetError, match="episode 0 keeps no scene .*: give --seed"):
        replay(ds, 0, objects=2)


def _kept_scene(ds):
    import json

    return json.loads((ds / "meta" / "mearm_episodes.json").read_text())["episodes"][0][2]


def test_a_file_path_given_by_set_is_kept_absolute(recorded):
    """The --set value that names a file names it by its absolute path; the file is the
    one the sort used."""
    from pathlib import Path

    (kept,) = _kept_scene(recorded)["set"]
    key, _, value = kept.partition("=")
    path = Path(yaml.safe_load(value))
    assert key == "servo.calibration_file" and path.is_absolute()
    assert path.resolve() == (recorded.parent / "sort" / "base.servos.yaml").resolve()


def test_an_older_dataset_with_a_relative_set_path_reads_as_before(recorded, tmp_path, monkeypatch):
    """Recorded before paths were kept absolute: its --set path is relative to the folder
    the replay runs in, as it was (found from the sort's folder, refused elsewhere)."""
    import json
    import os
    import shutil
    from pathlib import Path

    from mearm.errors import ConfigError

    ds = tmp_path / "old"
    shutil.copytree(recorded, ds)
    root = Path(__file__).resolve().parent.parent
    tags = json.loads((ds / "meta" / "mearm_episodes.json").read_text())
    servo_file = recorded.parent / "sort" / "base.servos.yaml"
    tags["episodes"][0][2]["set"] = [f"servo.calibration_file={os.path.relpath(servo_file, root)}"]
    (ds / "meta" / "mearm_episodes.json").write_text(json.dumps(tags))
    monkeypatch.chdir(root)
    plan = plan_replay(ds, 0)
    assert Path(str(plan.config.servo.calibration_file)).resolve() == servo_file.resolve()
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match="is not a file"):
        plan_replay(ds, 0)
