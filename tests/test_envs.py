"""The twin's Gymnasium environments: API, determinism, limits, refusals, the expert."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import mearm.envs
from mearm.config import load_config
from mearm.dataset.recorder import state_names
from mearm.envs import EnvOptionError, TwinEnv
from mearm.envs.actions import ActionSpec
from mearm.errors import ConfigError

pytestmark = pytest.mark.heavy


@pytest.fixture(scope="module")
def twin_config():
    return load_config("sim_mujoco")


def _make(env_id: str, twin_config, **options) -> gym.Env:
    return gym.make(env_id, config=twin_config, **options)


def test_every_name_in_all_exists():
    """``mearm.envs.__all__`` lists only names the package has."""
    for name in mearm.envs.__all__:
        assert hasattr(mearm.envs, name), name


def test_importing_registers_both_environments():
    """Importing mearm.envs registers PickPlace-v0 and Sort-v0 with a step limit."""
    for env_id in ("mearm/PickPlace-v0", "mearm/Sort-v0"):
        spec = gym.spec(env_id)
        assert spec.max_episode_steps == mearm.envs.MAX_EPISODE_STEPS[env_id]


@pytest.mark.parametrize(
    ("env_id", "options"),
    [("mearm/PickPlace-v0", {}), ("mearm/Sort-v0", {"objects": 2, "image_size": (48, 64)})],
)
@pytest.mark.filterwarnings("ignore:.*symmetric and normalized space")  # absolute joint targets
def test_check_env_passes(env_id, options, twin_config):
    """Gymnasium's own checker accepts each environment, pixels included."""
    env = _make(env_id, twin_config, **options)
    try:
        check_env(env.unwrapped, skip_render_check=True)
    finally:
        env.close()


def test_observation_has_lerobot_keys_and_the_recordings_units(twin_config):
    """pixels/table is uint8 H×W×3, agent_pos the recording's state vector, fps the rate."""
    env = _make("mearm/PickPlace-v0", twin_config, render_mode="rgb_array")
    obs, info = env.reset(seed=4)
    try:
        assert obs["pixels"]["table"].dtype == np.uint8
        assert obs["pixels"]["table"].shape == (96, 128, 3)
        spec = ActionSpec.of(twin_config)
        assert spec.names == tuple(state_names(twin_config))
        assert (
            spec.names[:3] == ("base", "shoulder", "elbow") and spec.names[-1] == "gripper_closed"
        )
        home = list(twin_config.arm.home().values())
        np.testing.assert_allclose(obs["agent_pos"][:3], home, atol=1.0)
        assert env.metadata["render_fps"] == twin_config.servo.rate_hz
        assert info["task"].startswith("put the ") and info["objects"] == 1
        frame = env.render()
        assert frame.shape == (240, 320, 3) and frame.dtype == np.uint8
    finally:
        env.close()


def test_same_seed_same_observations(twin_config):
    """Two resets with one seed, then the same actions, observe the same values."""
    env = _make("mearm/Sort-v0", twin_config, objects=3, image_size=(48, 64))
    action = env.action_space.sample()
    try:
        runs = []
        for _ in range(2):
            obs, _ = env.reset(seed=11)
            seen = [obs]
            for _ in range(5):
                seen.append(env.step(action)[0])
            runs.append(seen)
        for a, b in zip(*runs, strict=True):
            np.testing.assert_array_equal(a["agent_pos"], b["agent_pos"])
            np.testing.assert_array_equal(a["environment_state"], b["environment_state"])
            np.testing.assert_array_equal(a["pixels"]["table"], b["pixels"]["table"])
        other, _ = env.reset(seed=12)
        assert not np.array_equal(other["environment_state"], runs[0][0]["environment_state"])
    finally:
        env.close()


def test_actions_outside_the_limits_are_clipped_and_named(twin_config):
    """An action past a joint's limit is held at the limit and info names the joint."""
    env = _make("mearm/PickPlace-v0", twin_config, obs_type="state")
    env.reset(seed=1)
    try:
        action = np.array(env.unwrapped.spec_actions.vector(env.unwrapped.twin.commanded))
        action[0] = 1000.0
        _, _, _, _, info = env.step(action)
        assert info["clipped"] == ["base"]
        sent = env.unwrapped.twin.commanded.joints["base"]
        assert sent == twin_config.arm.joints[0].limits.max
    finally:
        env.close()


def test_a_target_into_the_table_is_refused_and_the_arm_holds(twin_config):
    """A target the straight way to which hits the table or a bin is refused, as a route is."""
    env = _make("mearm/PickPlace-v0", twin_config, obs_type="state")
    env.reset(seed=1)
    inner = env.unwrapped
    try:
        before = inner.twin.commanded
        rng = np.random.default_rng(0)
        for _ in range(200):  # a target within the limits whose way meets the table or a bin
            action = rng.uniform(inner.action_space.low, inner.action_space.high)
            if inner._refusal(inner.spec_actions.command(action)) is not None:
                break
        else:
            pytest.fail("no refused target among 200 random ones")
        _, _, _, _, info = env.step(action.astype(np.float32))
        assert info["refused"].startswith(("collision:", "a passive joint"))
        assert inner.twin.commanded == before
    finally:
        env.close()


def test_the_expert_puts_the_object_in_its_bin(twin_config):
    """The sorter stepped as a policy: success, reward 1 in all, the episode terminates."""
    env = _make("mearm/PickPlace-v0", twin_config, obs_type="state", expert=True)
    obs, info = env.reset(seed=5)
    total, steps = 0.0, 0
    try:
        terminated = truncated = False
        while not (terminated or truncated):
            obs, reward, terminated, truncated, info = env.step(info["expert_action"])
            total += reward
            steps += 1
            assert not info["refused"], info["refused"]
        assert terminated and info["is_success"] and total == 1.0
        assert steps < mearm.envs.MAX_EPISODE_STEPS["mearm/PickPlace-v0"]
    finally:
        env.close()


def test_a_reset_mid_episode_ends_the_experts_sort(twin_config):
    """A reset while the expert's sort runs stops its thread and starts a new one."""
    env = _make("mearm/PickPlace-v0", twin_config, obs_type="state", expert=True)
    _, info = env.reset(seed=2)
    for _ in range(5):
        *_, info = env.step(info["expert_action"])
    old = env.unwrapped.expert
    _, info = env.reset(seed=3)
    try:
        assert not old._thread.is_alive()
        assert env.unwrapped.expert is not old and info["expert_done"] == ""
    finally:
        env.close()
    assert env.unwrapped.expert is None


def test_async_vector_env_with_two_environments_runs(twin_config):
    """Environments in their own processes reset with seeds and step together (two show
    it as four did: each process is a fresh interpreter, at a second of CPU apiece)."""
    envs = gym.vector.AsyncVectorEnv(
        [lambda: gym.make("mearm.envs:mearm/PickPlace-v0", config="sim_mujoco", obs_type="state")]
        * 2,
        context="spawn",
    )
    try:
        obs, _ = envs.reset(seed=[0, 1])
        assert obs["agent_pos"].shape == (2, 5)
        for _ in range(3):
            obs, reward, *_ = envs.step(envs.action_space.sample())
        assert reward.shape == (2,) and np.all(np.isfinite(obs["agent_pos"]))
        assert len({tuple(row) for row in obs["environment_state"]}) == 2
    finally:
        envs.close()


@pytest.mark.parametrize(
    ("options", "words"),
    [
        ({"config": "sim"}, "simulator is 'kinematic'"),
        ({"fps": 7}, "fps must divide servo.rate_hz"),
        ({"objects": 0}, "objects must be at least 1"),
        ({"task": "stack"}, "task must be"),
        ({"image_size": (4, 4)}, "image_size must be within"),
        ({"obs_type": "rgb"}, "obs_type must be"),
    ],
)
def test_bad_options_are_refused_by_name(options, words):
    """Each bad option raises EnvOptionError naming it."""
    with pytest.raises(EnvOptionError, match=words):
        TwinEnv(**options)


@pytest.mark.parametrize(
    ("overrides", "words"),
    [
        (["task.nope=3"], "overrides: task.nope: unknown key"),
        (["task.nope"], "overrides: 'task.nope': expected dotted.key=value"),
    ],
)
def test_a_bad_override_is_named_as_the_environments_overrides(overrides, words):
    """An override given as ``overrides=`` is named so, not as the command line's --set."""
    with pytest.raises(ConfigError, match=words) as caught:
        TwinEnv(config="sim_mujoco", overrides=overrides)
    assert "--set" not in str(caught.value)
