"""The behaviour-cloning baseline: trained end to end on a tiny set, it beats random."""

from __future__ import annotations

import importlib.util
import re

import numpy as np
import pytest

# Found, not imported: importing torch takes seconds, which only the worker that runs
# these tests should pay, not every worker's collection (mearm.learn imports it lazily).
if importlib.util.find_spec("torch") is None:
    pytest.skip("could not import 'torch': No module named 'torch'", allow_module_level=True)

from mearm.envs.policies import RandomPolicy, load_policy  # noqa: E402
from mearm.learn.bc import main as bc_main  # noqa: E402
from mearm.learn.bc import train  # noqa: E402
from mearm.learn.collect import Demos, collect  # noqa: E402

pytestmark = pytest.mark.heavy

OPTIONS = {"config": "sim_mujoco"}


@pytest.fixture(scope="module")
def demos(tmp_path_factory) -> tuple[Demos, Demos]:
    """Expert episodes: seeds 0–3 to train on, seed 1000 held out."""
    return (
        collect("mearm/PickPlace-v0", OPTIONS, range(4)),
        collect("mearm/PickPlace-v0", OPTIONS, [1000]),
    )


def test_collected_demonstrations_are_the_experts_successful_episodes(demos):
    """Each step has the state, the objects and the action; every seed succeeded."""
    train_set, _ = demos
    assert sorted(set(train_set.episode.tolist())) == [0, 1, 2, 3]
    first = train_set.episode == 0
    assert train_set.step[first].tolist() == list(range(int(first.sum())))
    k = len(train_set.action)
    assert train_set.agent_pos.shape == train_set.action.shape == (k, 5)
    assert train_set.environment_state.shape == (k, 4)
    assert set(np.unique(train_set.action[:, -1])) == {0.0, 1.0}  # the gripper opens and closes


def test_the_trained_policy_imitates_the_expert_better_than_random(demos, tmp_path):
    """On a held-out episode, the baseline's actions are nearer the expert's than random's.

    Trained end to end (collect → train → save → load as eval-policy loads it).
    """
    train_set, held_out = demos
    fit = train(train_set, _spec().joints, steps=400, batch=128, hidden=64)
    assert np.isfinite(fit.loss)
    from mearm.learn.baseline import save_baseline

    path = tmp_path / "bc.pt"
    save_baseline(
        path, fit.net, fit.mean, fit.std, fit.scaling, fit.joints, {"env_id": "mearm/PickPlace-v0"}
    )
    policy = load_policy(str(path), _space())
    rand = RandomPolicy(_space())
    rand.reset(0)
    policy.reset(1000)
    errors = {"bc": [], "random": []}
    for pos, state, expert in zip(held_out.agent_pos, held_out.environment_state,
                                  held_out.action, strict=True):  # fmt: skip
        obs = {"agent_pos": pos, "environment_state": state}
        errors["bc"].append(np.abs(policy.act(obs, {}) - expert)[:-1].mean())
        errors["random"].append(np.abs(rand.act(obs, {}) - expert)[:-1].mean())
    assert np.mean(errors["bc"]) < 0.25 * np.mean(errors["random"])
    # eval-policy refuses it on another environment before running (each of its episodes
    # failed on the observations' shapes, and the command exited 0)
    from mearm.envs.errors import PolicyError
    from mearm.tools.eval_policy import main as eval_main

    with pytest.raises(PolicyError, match="trained on mearm/PickPlace-v0, not mearm/Sort-v0"):
        eval_main(["--env", "mearm/Sort-v0", "--policy", str(path), "--episodes", "1"])


def test_a_file_that_is_not_a_baseline_is_refused(tmp_path):
    """A .pt that mearm did not save: PolicyError naming the file."""
    from mearm.envs.errors import PolicyError

    bad = tmp_path / "x.pt"
    bad.write_bytes(b"not a model")
    with pytest.raises(PolicyError, match="not a baseline saved by mearm.learn"):
        load_policy(str(bad), _space())
    with pytest.raises(PolicyError, match="no such file"):
        load_policy(str(tmp_path / "missing.pt"), _space())


def test_the_command_refuses_an_output_that_is_not_pt(tmp_path):
    """--out must end in .pt: eval-policy knows a baseline by it."""
    from mearm.errors import MearmError

    with pytest.raises(MearmError, match="--out must end in .pt"):
        bc_main(["--episodes", "1", "--out", str(tmp_path / "bc.bin")])


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--env", "mearm/PickPlace-v1"], "--env must be one of mearm/PickPlace-v0"),
        (["--demos", "."], "--demos .: exists and is not a file"),
        (["--config", "sim_mujuco"], "did you mean 'sim_mujoco'"),
        (["--out", "{folder}.pt"], "not a regular file (a folder)"),
    ],
)
def test_the_command_refuses_bad_input_before_any_work(tmp_path, args, words):
    """Each was an "unexpected error" (exit 1) or found only after the demonstrations."""
    from mearm.errors import MearmError

    (tmp_path / "folder.pt").mkdir()
    argv = ["--out", str(tmp_path / "bc.pt"), *args]
    with pytest.raises(MearmError, match=re.escape(words.format(folder=tmp_path / "folder"))):
        bc_main(["--episodes", "1", *(a.format(folder=tmp_path / "folder") for a in argv)])


def _spec():
    from mearm.config import load_config
    from mearm.envs.actions import ActionSpec

    return ActionSpec.of(load_config("sim_mujoco"))


def _space():
    from gymnasium import spaces

    spec = _spec()
    return spaces.Box(spec.low.astype(np.float32), spec.high.astype(np.float32))


def test_every_name_in_all_exists():
    """``mearm.learn.__all__`` lists only names the package has."""
    import mearm.learn

    for name in mearm.learn.__all__:
        assert hasattr(mearm.learn, name), name
