"""A sort recorded with --record, its action column replayed in the environment, ends the same."""

from __future__ import annotations

import pytest

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from mearm.config import load_config  # noqa: E402
from mearm.dataset.errors import DatasetError  # noqa: E402
from mearm.dataset.recorder import DatasetRecorder  # noqa: E402
from mearm.envs.replay import replay  # noqa: E402
from mearm.task.rig import run_sort  # noqa: E402
from mearm.task.scene import random_scene  # noqa: E402

pytestmark = pytest.mark.heavy


def test_a_recorded_scene_replays_to_the_same_objects_in_the_same_bins(tmp_path):
    """Seed 7, two objects, recorded per scene at the servo rate: the replay sorts both."""
    config = load_config("sim_mujoco")
    scene = random_scene(config, 2, seed=7)
    recorder = DatasetRecorder(tmp_path / "ds", config, fps=50, per="scene")
    try:
        report = run_sort(config, scene=scene, echo=None, recorder=recorder)
    finally:
        recorder.close()
    recorded = {c: n for c, n in report.outcome.sorted.items() if n}
    out = replay(tmp_path / "ds", 0, seed=7, config="sim_mujoco", objects=2)
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
