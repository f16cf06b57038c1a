"""docs/learning.md walked again as a new user: options named, refusals that say why.

The walk found: ``gym.make`` with a keyword that is no option raised Python's TypeError
naming neither the option nor the options; ``objects=1.0`` passed for pick-and-place
while the sort refuses 3.0; ``mearm/Sort-v0`` with ``task="pick_place"`` built the other
task under the Sort id; a config with a belt crashed at ``reset()``; ``--require`` failed
with exit 1 and no word why; ``--out`` could replace a ``module:callable`` policy's
source; ``--policy mypol.py:act`` hinted at the same spec again; a policy's error with a
newline split the stderr summary in two.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import gymnasium as gym
import pytest
from badinput import run_in_process

import mearm.envs  # noqa: F401  (registers the environments)
from mearm.envs.errors import EnvOptionError, PolicyError
from mearm.envs.policies import load_policy


def test_a_keyword_that_is_no_option_is_named_with_the_options():
    with pytest.raises(EnvOptionError) as caught:
        gym.make("mearm/Sort-v0", config="sim_mujoco", foo=1)
    assert str(caught.value).startswith("'foo' is not an option of the environments; they take")
    assert "objects, scene, reseed, fps" in str(caught.value)


def test_pick_place_takes_objects_1_only_as_a_whole_number():
    with pytest.raises(EnvOptionError, match=r"objects must be 1, got 1\.0"):
        gym.make("mearm/PickPlace-v0", objects=1.0)


def test_the_task_is_the_ids():
    with pytest.raises(EnvOptionError, match=r"mearm/Sort-v0 is the sort task, got task='pick"):
        gym.make("mearm/Sort-v0", task="pick_place")
    env = gym.make("mearm/PickPlace-v0", task="pick_place", obs_type="state")
    try:
        assert env.unwrapped.task_kind == "pick_place"  # type: ignore[attr-defined]
    finally:
        env.close()


def test_a_config_with_a_belt_is_refused_when_made_not_at_reset():
    with pytest.raises(EnvOptionError, match="sim_conveyor has a belt"):
        gym.make("mearm/Sort-v0", config="sim_conveyor", objects=2, obs_type="state")


def test_a_policy_named_by_its_file_is_told_the_module():
    space = gym.spaces.Box(-1.0, 1.0, (5,))
    with pytest.raises(PolicyError) as caught:
        load_policy("mypol.py:act", space)
    assert "name the module, not its file: --policy mypol:act" in str(caught.value)


POLICY = """
import numpy as np

def act(observation):
    return np.array([120.0, 93.0, -132.0, 60.0, 0.0], dtype=np.float32)

def bad(observation):
    raise ValueError("line one\\nline two")
"""


@pytest.mark.heavy
def test_eval_policy_says_why_it_failed_in_one_line_and_keeps_its_policy(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "mypol.py").write_text(textwrap.dedent(POLICY))
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    short = ["--episodes", "1", "--jobs", "1", "--env-option", "max_episode_steps=3"]

    r = run_in_process(
        ["eval-policy", "--policy", "random", "--require", "0.5", *short], within_s=120
    )
    assert r.code == 1
    assert r.line == "mearm eval-policy: success 0.0 % is below --require 0.5 (50 %)"

    before = (tmp_path / "mypol.py").read_bytes()
    argv = ["eval-policy", "--policy", "mypol:act", "--out", "mypol.py", "--force", *short]
    r = run_in_process(argv, within_s=120)
    assert r.code == 2 and "is the source of --policy mypol:act" in r.line, r.stderr
    assert (tmp_path / "mypol.py").read_bytes() == before

    r = run_in_process(["eval-policy", "--policy", "mypol:bad", *short], within_s=120)
    assert r.code == 1
    assert (
        r.stderr.strip()
        .splitlines()[-1]
        .endswith("(the first: the policy raised ValueError: line one line two)")
    ), r.stderr
