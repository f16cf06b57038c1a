"""A recorded episode keeps the table it sorted, and the replay lays it and runs its noise.

An experiment's trial draws as many objects of each class as the config's table holds (4
on ``sim_mujoco``; 1 here, by ``--set task.scene``), class by class; a ``--scene`` sort
lays its file. Neither is a ``random_scene(config, N, seed)``, which the replay drew from
``--objects N --seed S``: their episodes could not be replayed. Each now keeps its table
(``meta/mearm_episodes.json``), in the serial run and in the worker processes
(``--jobs``), and the replay lays it. The replay also runs the servos as the sort did:
``mearm sort`` keeps the config's own servo seed (with ``twin.kit.per_trial``, the servo
kit it draws), where the replay reseeded it with the scene's seed.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from badinput import Outcome, run_in_process
from conftest import ROOT, run_main

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from mearm.config import SceneObject, load_config  # noqa: E402
from mearm.dataset.errors import DatasetError  # noqa: E402
from mearm.dataset.reading import RecordedScene, read_tags  # noqa: E402
from mearm.envs.errors import EnvOptionError  # noqa: E402
from mearm.envs.replay import main as replay_main  # noqa: E402
from mearm.envs.replay import plan_replay, replay  # noqa: E402
from mearm.experiment import Recording, plan_trial, run_trial, trial_seed  # noqa: E402
from mearm.runlog import read_runlog  # noqa: E402
from mearm.task.scene import load_scene  # noqa: E402

pytestmark = pytest.mark.heavy

#: The experiment's base seed.
SEED = 5
#: The experiment's table: one object of each class, so each trial draws one of each
#: (``trial_counts``); the 4 of each of sim_mujoco's own table record 4 times the frames
#: and show nothing more of the table kept.
TABLE = (
    "task.scene=[{color: red, x: -4, y: 45}, {color: green, x: 4, y: 45}, "
    "{color: blue, x: 0, y: 40}]"
)
#: A --scene file: two objects, one turned (its yaw is kept too).
SCENE = "- {color: red, x: -10.99, y: 49.70}\n- {color: blue, x: 5.0, y: 45.0, yaw_deg: 30}\n"
#: Recorded as the replay reproduces a sort: per scene, at the servo stream's rate.
RECORD = ["--record-per", "scene", "--record-fps", "50", "--record-codec", "h264"]


def _mearm(*args: object) -> Outcome:
    """``mearm ARGS`` in this process, in the checkout (a command's start is no point here)."""
    return run_in_process(args, within_s=30, cwd=ROOT)


def _placed(objects) -> list[tuple[str, float, float]]:
    """Each object's class and place, in one order (the twin's and the log's differ)."""
    return sorted((o["color"], o["x"], o["y"]) if isinstance(o, dict) else (o.color, o.x, o.y)
                  for o in objects)  # fmt: skip


@pytest.fixture(scope="module")
def experiment(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """``mearm experiment --config sim_mujoco --set TABLE --trials 2 --record`` (no
    workers): the dataset and the run log."""
    here = tmp_path_factory.mktemp("experiment")
    ds, log = here / "ds", here / "trials.jsonl"
    out = _mearm(
        "experiment", "--config", "sim_mujoco", "--set", TABLE, "--trials", "2",
        "--seed", SEED, "--log", log, "--record", ds, *RECORD, "--yes",
    )  # fmt: skip
    assert out.code == 0, out.stderr
    return ds, log


def test_an_experiment_trial_replays_on_its_own_table(experiment):
    """Trial 1's episode, no --objects or --seed: the replay lays the trial's table (the
    run log's classes and places, 1 of each class) and ends as the trial did, every object
    in its class's bin. Before, the replay refused it ("keeps no scene")."""
    ds, log = experiment
    trial = read_runlog(log).trials[1]
    out = replay(ds, 1)
    assert _placed(out.table) == _placed(trial.header.scene)
    assert len(out.table) == 3
    replayed: dict[str, int] = {}
    for cls in out.bins.values():
        replayed[cls] = replayed.get(cls, 0) + 1
    assert trial.summary is not None and replayed == trial.summary.sorted
    assert out.success and out.refused == 0
    assert all(oid.startswith(cls) for oid, cls in out.bins.items())


def test_a_trial_keeps_its_seed_for_its_noise(experiment):
    """Each trial's episode keeps its own table and its trial's seed, which the replay's
    config runs (trial_config: its servo and camera seeds)."""
    ds, _ = experiment
    scenes = read_tags(ds, 2)[1]
    config = load_config("sim_mujoco", (TABLE,))
    for k, scene in enumerate(scenes):
        plan = plan_trial(config, SEED, k)
        assert scene is not None and scene.noise_seed == trial_seed(SEED, k)
        assert scene.table == tuple(plan.layout or ()) and scene.config == "sim_mujoco"
        assert scene.overrides == (TABLE,)
    replayed = plan_replay(ds, 1)
    assert replayed.config.servo.error_model.seed == trial_seed(SEED, 1)
    assert replayed.config.camera.seed == trial_seed(SEED, 1)


def test_a_worker_process_keeps_the_trial_table_too(experiment):
    """A trial run where ``--jobs`` runs it (:func:`run_trial`, in a worker process) keeps
    the same scene as the one-process run wrote for it (at fewer frames: cheaper to
    encode, the same scene)."""
    ds, _ = experiment
    tags = json.loads((ds / "meta" / "mearm_episodes.json").read_text())["episodes"]
    recording = Recording(5, "scene", "h264", ("sim_mujoco", (TABLE,)))
    result = run_trial(load_config("sim_mujoco", (TABLE,)), SEED, None, 1, recording)
    (episode,) = result.episodes
    assert episode.scene is not None and [*episode.tag, episode.scene.to_json()] == tags[1]


def test_a_table_is_not_drawn_by_a_seed(experiment, capsys):
    """--seed or --objects with a recorded table: exit 2, one line (they would be unused)."""
    ds, _ = experiment
    with pytest.raises(DatasetError, match="laid as they were .*: leave --objects out"):
        plan_replay(ds, 1, objects=3)
    code, _, err = run_main(
        capsys, replay_main, ds, "--episode", "1", "--seed", trial_seed(SEED, 1)
    )
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "recorded on a table of 3 objects" in lines[0], lines


@pytest.fixture(scope="module")
def scene_sort(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """``mearm sort --scene FILE --record``: the dataset and the scene file."""
    here = tmp_path_factory.mktemp("scene")
    scene, ds = here / "scene.yaml", here / "ds"
    scene.write_text(SCENE)
    out = _mearm(
        "sort", "--config", "sim_mujoco", "--scene", scene, "--record", ds, *RECORD, "--quiet"
    )
    assert out.code == 0, out.stderr
    return ds, scene


def test_a_scene_sort_replays_on_its_table(scene_sort, capsys, monkeypatch):
    """The replay command, no --objects or --seed, from another folder: the file's table
    (its yaw too), both objects in their bins, exit 0."""
    ds, scene = scene_sort
    (kept,) = read_tags(ds, 1)[1]
    assert kept is not None and kept.table == tuple(load_scene(scene))
    assert kept.noise_seed is None and kept.seed is None
    monkeypatch.chdir(ds.parent)
    code, out, err = run_main(capsys, replay_main, ds)
    assert code == 0, err
    assert "2 of 2 objects in their bins" in out
    assert "blue1 in blue, red1 in red" in out


@pytest.fixture(scope="module")
def kit_sort(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``mearm sort --config sim_mujoco_kits --random 2 --seed 7 --record``: its servo kit
    drawn with the config's own servo seed (0), never calibrated by the camera."""
    ds = tmp_path_factory.mktemp("kit") / "ds"
    out = _mearm(
        "sort", "--config", "sim_mujoco_kits", "--set", "servo.calibrate_at_start=never",
        "--random", "2", "--seed", "7", "--record", ds, *RECORD, "--quiet",
    )  # fmt: skip
    assert out.code == 0 and "sorted 2 of 2 objects" in out.stdout, out.stderr
    return ds


def test_a_random_sort_replays_with_its_own_servo_kit(kit_sort):
    """The replay's twin is the sort's kit (the config's seed), not the one of --seed 7,
    and the replay ends as the sort did. Before, it drew the kit of seed 7 (1 of 2 in
    their bins)."""
    import gymnasium as gym

    import mearm.envs  # noqa: F401
    from mearm.experiment import trial_config
    from mearm.sim.twin.twin_bus import TwinArm

    plan = plan_replay(kit_sort, 0)
    sorted_with = load_config("sim_mujoco_kits", ("servo.calibrate_at_start=never",))
    assert plan.config == sorted_with
    env = gym.make("mearm/Sort-v0", config=plan.config, objects=2, obs_type="state", reseed=False)
    try:
        env.reset(seed=7)
        kit = env.unwrapped.twin.kit
    finally:
        env.close()
    assert kit == TwinArm(sorted_with).kit != TwinArm(trial_config(sorted_with, 7)).kit
    out = replay(kit_sort, 0)
    assert out.success and out.in_bins == 2 and out.refused == 0


# ----------------------------------------------------------------- the option and the record


def test_the_environment_lays_a_given_table():
    """``scene=`` (dicts or SceneObjects): every reset lays it, whatever the seed."""
    import gymnasium as gym

    import mearm.envs  # noqa: F401

    table = [{"color": "green", "x": -4.0, "y": 45.0}, SceneObject(color="red", x=6.0, y=42.0)]
    env = gym.make("mearm/Sort-v0", config="sim_mujoco", scene=table, obs_type="state")
    try:
        for seed in (1, 2):
            obs, info = env.reset(seed=seed)
            assert [(o.color, o.x, o.y) for o in env.unwrapped.scene] == [
                ("green", -4.0, 45.0), ("red", 6.0, 42.0)
            ]  # fmt: skip
            assert info["objects"] == 2 and obs["environment_state"].shape == (8,)
    finally:
        env.close()


#: A table of one object the environment lays.
ONE = [{"color": "red", "x": -4.0, "y": 45.0}]


@pytest.mark.parametrize(
    ("options", "says"),
    [
        ({"scene": "scene.yaml"}, "scene must be a list of objects"),
        ({"scene": [{"color": "red", "x": 1.0}]}, r"\[0.y\]: Field required"),
        ({"scene": [{**ONE[0], "color": "pink"}]}, "no class 'pink'"),
        ({"scene": ONE, "objects": 2}, "objects is the scene's length, 1"),
        ({"scene": [{**ONE[0], "x": 0.0, "y": 1.0}]}, "stands on the arm's base plate"),
        ({"scene": ONE, "task": "pick_place"}, "pick_place draws"),
        ({"reseed": "no"}, "reseed must be True or False"),
    ],
)
def test_a_table_the_environment_cannot_lay_is_refused_at_make(options, says):
    """Refused at ``gym.make`` by name, not at ``reset()`` by the scene or the twin."""
    from mearm.envs.twin_env import TwinEnv

    with pytest.raises(EnvOptionError, match=says):
        TwinEnv("sim_mujoco", **options)


def test_an_older_scene_record_reads_as_before_and_a_table_round_trips(tmp_path):
    """``{"seed", "objects", ...}`` reads as a drawn scene; a table, and a noise seed, are
    read back as written; a record with both, or a table that is no table, is damaged."""
    drawn = {"seed": 7, "objects": 2, "config": "sim_mujoco", "set": []}
    laid = RecordedScene.laid(
        (SceneObject(color="red", x=-1.5, y=44.25, yaw_deg=30.0),), None, ("a.b=1",), 12
    )
    meta = tmp_path / "meta"
    meta.mkdir()
    tags = meta / "mearm_episodes.json"
    reseeded = RecordedScene(9, 3, None, (), None, 5)
    entries = [[None, None, drawn], [3, 0, laid.to_json()], [5, 0, reseeded.to_json()]]
    tags.write_text(json.dumps({"episodes": entries}))
    assert read_tags(tmp_path, 3)[1] == [RecordedScene(7, 2, "sim_mujoco", ()), laid, reseeded]
    for bad in ({**laid.to_json(), "seed": 7}, {**laid.to_json(), "table": []},
                {**laid.to_json(), "table": [{"color": "red", "x": 1}]}):  # fmt: skip
        tags.write_text(json.dumps({"episodes": [[None, None, bad]]}))
        with pytest.raises(DatasetError, match="entry 0 is"):
            read_tags(tmp_path, 1)
