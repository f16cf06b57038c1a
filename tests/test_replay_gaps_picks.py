"""An episode per pick after a sort's first replays from where its pick began.

The sorter does not go home between objects: pick k > 0 begins where pick k - 1 left the
arm (over the last bin) and the table (that object in its bin). The replay started every
episode where the environment's reset leaves the arm (at home, every object on the
table): episode 1 of a sort of three ended with only its own object in a bin, and the
replay command exited 1 for every pick but the last ("not all in their bins"). Each
episode now keeps the one of its sort it continues (``meta/mearm_starts.json``), and
the replay steps the sort's episodes before it first.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import run_main

pytest.importorskip("pyarrow")
pytest.importorskip("av")

import pyarrow.parquet as pq  # noqa: E402

from mearm.config import load_config  # noqa: E402
from mearm.dataset.errors import DatasetError  # noqa: E402
from mearm.dataset.recorder import DatasetRecorder  # noqa: E402
from mearm.envs.replay import episode_actions, plan_replay, replay  # noqa: E402
from mearm.envs.replay import main as replay_main  # noqa: E402
from mearm.task.rig import run_sort  # noqa: E402
from mearm.task.scene import random_scene  # noqa: E402

pytestmark = pytest.mark.heavy

#: The scene: three objects of seed 7, one of each class.
SEED, OBJECTS = 7, 3


@pytest.fixture(scope="module")
def picks(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[str]]:
    """A sort of three objects recorded per pick at the servo rate: the dataset and each
    episode's class, in order (the sort sorted all three)."""
    config = load_config("sim_mujoco")
    ds = tmp_path_factory.mktemp("picks") / "ds"
    recorder = DatasetRecorder(ds, config, fps=50, per="pick", codec="h264")
    try:
        report = run_sort(
            config, scene=random_scene(config, OBJECTS, seed=SEED), echo=None, recorder=recorder
        )
    finally:
        recorder.close()
    assert sum(report.outcome.sorted.values()) == OBJECTS
    tasks = pq.read_table(ds / "meta/episodes/chunk-000/file-000.parquet")["tasks"].to_pylist()
    classes = [task.split()[2] for (task,) in tasks]  # "put the red object in the red bin"
    assert sorted(classes) == ["blue", "green", "red"]
    return ds, classes


def _first_state(ds: Path, episode: int) -> np.ndarray:
    """The episode's recorded ``observation.state`` at its frame 0."""
    table = pq.read_table(ds / "data/chunk-000/file-000.parquet").to_pydict()
    (row,) = [
        i
        for i, (e, f) in enumerate(zip(table["episode_index"], table["frame_index"], strict=True))
        if e == episode and f == 0
    ]
    return np.array(table["observation.state"][row])


def test_every_pick_replays_to_the_sorts_outcome_from_where_it_began(picks):
    """Episode k ends with the objects of picks 0..k in their bins (the sort's), its own
    the one more, and its actions begin where the recording's did: the arm's measured
    state at their start is the recorded frame 0's. Before, episode 1 ended with only its
    own object in a bin, the arm started at home."""
    ds, classes = picks
    for k in range(OBJECTS):
        out = replay(ds, k, seed=SEED, objects=OBJECTS, config="sim_mujoco")
        in_bins = {cls for oid, cls in out.bins.items() if oid.startswith(cls)}
        assert in_bins == set(classes[: k + 1]), (k, out.bins)
        assert out.success and out.pick == classes[k] and out.before == k and out.refused == 0
        np.testing.assert_allclose(out.start_state, _first_state(ds, k), atol=0.05)


def test_each_pick_keeps_the_one_it_continues(picks):
    """The sort's first starts at the reset; each later one after the one before it, with
    no time between (the sort only looked at the table): the lead is their actions."""
    ds, _ = picks
    starts = json.loads((ds / "meta" / "mearm_starts.json").read_text())["episodes"]
    assert starts == [{"after": None}, {"after": 0, "gap_frames": 0}, {"after": 1, "gap_frames": 0}]
    plan = plan_replay(ds, 2, seed=SEED, objects=OBJECTS, config="sim_mujoco")
    first, second = (episode_actions(ds, k)[0] for k in (0, 1))
    np.testing.assert_array_equal(plan.lead, np.concatenate([first[1:], second[1:]]))
    assert plan.start_known and plan_replay(ds, 0, seed=SEED, objects=OBJECTS).lead.shape[0] == 0


def test_the_time_between_picks_holds_the_next_ones_first_action(picks, tmp_path):
    """A gap of G frames (the sort went home to look again): the next episode's first
    action is held G steps before its own are stepped."""
    ds, _ = picks
    gapped = tmp_path / "ds"
    shutil.copytree(ds, gapped)
    path = gapped / "meta" / "mearm_starts.json"
    starts = json.loads(path.read_text())
    starts["episodes"][1]["gap_frames"] = 3
    path.write_text(json.dumps(starts))
    first, second = (episode_actions(ds, k)[0] for k in (0, 1))
    lead = plan_replay(gapped, 2, seed=SEED, objects=OBJECTS).lead
    held = np.repeat(second[:1], 3, axis=0)
    np.testing.assert_array_equal(lead, np.concatenate([first[1:], held, second[1:]]))


def _replay_cli(
    ds: Path, capsys: pytest.CaptureFixture[str], *args: object
) -> tuple[int, str, str]:
    """The replay command in this process: exit status, stdout, stderr."""
    return run_main(capsys, replay_main, ds, *args)


def test_the_replay_command_says_a_middle_pick_did_its_job(picks, capsys):
    """Exit 0 for the middle pick, its object the one more in its bin; before, exit 1
    ("2 of 3 objects", or 1 of 3 from home)."""
    ds, classes = picks
    code, out, err = _replay_cli(ds, capsys, "--episode", 1, "--seed", SEED, "--objects", OBJECTS)
    assert code == 0, out + err
    lead = episode_actions(ds, 0)[0].shape[0] - 1
    assert f"after {lead} of its sort's before it (0 refused)" in out
    assert f"2 of 3 objects in their bins, 1 before this pick of a {classes[1]} object" in out


def test_an_older_dataset_replays_a_pick_from_the_reset_and_says_so(picks, tmp_path, capsys):
    """No ``meta/mearm_starts.json`` (an older mearm's): the start is not known, the pick
    is replayed from the reset as before, and a note on stderr says so."""
    ds, _ = picks
    old = tmp_path / "old"
    shutil.copytree(ds, old)
    (old / "meta" / "mearm_starts.json").unlink()
    plan = plan_replay(old, 1, seed=SEED, objects=OBJECTS)
    assert not plan.start_known and plan.lead.shape[0] == 0
    _, out, err = _replay_cli(old, capsys, "--episode", 1, "--seed", SEED, "--objects", OBJECTS)
    assert "start the dataset does not keep" in err
    assert "0 before this pick" in out


@pytest.mark.parametrize(
    "entry",
    [
        {"after": 1, "gap_frames": 0},
        {"after": None, "gap_frames": 2},
        {"after": -1},
        {"servos": "/etc/x.servos.yaml"},
        {"servos": "../x.servos.yaml"},
        [],
    ],
)
def test_a_damaged_start_is_named(picks, tmp_path, entry):
    """An entry that continues no earlier episode, a gap with no episode before, a servo
    file outside the dataset: DatasetError naming the file (exit 2), no step taken."""
    ds, _ = picks
    bad = tmp_path / "bad"
    shutil.copytree(ds, bad)
    path = bad / "meta" / "mearm_starts.json"
    starts = json.loads(path.read_text())
    starts["episodes"][1] = entry
    path.write_text(json.dumps(starts))
    with pytest.raises(DatasetError, match=r"mearm_starts.json: entry 1 is .*the dataset is dam"):
        plan_replay(bad, 0, seed=SEED, objects=OBJECTS)
