"""docs/learning.md walked a third time: inputs eval-policy and bc must refuse before any work."""

from __future__ import annotations

import pytest

from mearm.config.base import MAX_SEED
from mearm.envs.errors import EnvOptionError
from mearm.errors import MearmError
from mearm.learn.bc import main as bc_main
from mearm.tools.eval_policy import env_options
from mearm.tools.eval_policy import main as eval_main


def test_seeds_past_the_last_are_refused_before_any_episode(capsys, tmp_path):
    """Seed 2³²−1 ran, then seed 2³² stopped the run (exit 2): no --out, the work lost."""
    out = tmp_path / "scores.json"
    with pytest.raises(MearmError, match=r"--first-seed 4294967295 and --episodes 2 run to seed"):
        eval_main(
            ["--first-seed", str(MAX_SEED), "--episodes", "2", "--jobs", "1",
             "--env-option", "obs_type=state", "--out", str(out)]
        )  # fmt: skip
    assert capsys.readouterr().out == ""  # no episode's line: none ran
    assert not out.exists()


def test_the_last_seed_itself_is_taken():
    """The check refuses only what runs past the last seed (its one episode is not run here)."""
    from mearm.envs.evaluate import check_seed_range  # noqa: PLC0415

    check_seed_range(MAX_SEED, 1)
    with pytest.raises(MearmError, match=f"at most {MAX_SEED - 1}"):
        check_seed_range(MAX_SEED, 2)


def test_bc_refuses_seeds_past_the_last_before_collecting(capsys, tmp_path):
    """bc collected the episodes in range, then stopped on the first out of it (exit 2)."""
    demos = tmp_path / "demos.npz"
    with pytest.raises(MearmError, match=r"--first-seed 4294967295 and --episodes 2 run to seed"):
        bc_main(
            ["--first-seed", str(MAX_SEED), "--episodes", "2", "--jobs", "1", "--steps", "1",
             "--demos", str(demos), "--out", str(tmp_path / "bc.pt")]
        )  # fmt: skip
    assert capsys.readouterr().out == ""
    assert not demos.exists()


def test_config_as_an_env_option_is_refused_naming_the_flag():
    """``--env-option config=X`` replaced ``--config`` silently: the totals named the other."""
    with pytest.raises(EnvOptionError, match=r"^--env-option config: give --config instead$"):
        env_options(["config=sim_mujoco_kits"])


def test_the_options_the_page_lists_are_the_ones_taken():
    """docs/learning.md lists what ``--env-option`` takes: each is taken, config is not."""
    with pytest.raises(EnvOptionError) as err:
        env_options(["bogus=1"])
    taken = str(err.value).split("they take ")[1].split(", ")
    assert taken == [
        "objects", "scene", "reseed", "fps", "obs_type", "image_size", "overrides",
        "max_episode_steps",
    ]  # fmt: skip
    assert env_options(["scene=[{color: red, x: -4.0, y: 45.0}]", "reseed=false"]) == {
        "scene": [{"color": "red", "x": -4.0, "y": 45.0}],
        "reseed": False,
    }


def test_a_baseline_is_refused_at_another_fps_than_it_was_trained_at(tmp_path, capsys):
    """Its clock counts steps and each action is held one step: at fps=25 it ran on a clock
    that meant twice the time (0 of the 6 seeds, where at 50 it took one of them)."""
    pytest.importorskip("torch")
    policy = tmp_path / "bc.pt"
    assert bc_main(["--episodes", "1", "--jobs", "1", "--steps", "1", "--out", str(policy)]) == 0
    capsys.readouterr()
    common = ["--policy", str(policy), "--episodes", "1", "--jobs", "1",
              "--env-option", "obs_type=state", "--env-option", "max_episode_steps=2"]  # fmt: skip
    with pytest.raises(MearmError, match=r"trained at 50 steps per second .* steps at 25"):
        eval_main([*common, "--env-option", "fps=25"])
    assert capsys.readouterr().out == ""  # refused before any episode
    assert eval_main([*common, "--env-option", "fps=50"]) == 0  # ran (and scored 0 %)
    assert "episode   1/1 seed 0: failure" in capsys.readouterr().out


def test_a_loaded_config_not_of_the_twin_is_refused_in_a_short_line():
    """The message held the Config's repr, thousands of characters on one line (as
    ``python -m mearm.envs.replay rec --config sim`` printed it)."""
    import gymnasium as gym  # noqa: PLC0415

    from mearm.config import load_config  # noqa: PLC0415

    with pytest.raises(EnvOptionError) as err:
        gym.make("mearm/Sort-v0", config=load_config("sim"))
    assert str(err.value) == (
        "the Config given: simulator is 'kinematic'; the environments run on the physical "
        "twin (simulator: mujoco, e.g. config='sim_mujoco')"
    )
    with pytest.raises(EnvOptionError, match=r"^config sim: simulator is 'kinematic'"):
        gym.make("mearm/Sort-v0", config="sim")


#: User policies whose ``reset()`` fails: one that wants a seed, one that raises.
RESET_POLICIES = """
import numpy as np

HOME = np.array([120.0, 93.0, -132.0, 60.0, 0.0], dtype=np.float32)


class WantsASeed:
    def reset(self, seed):
        self.seed = seed

    def __call__(self, observation):
        return HOME


class ResetRaises:
    def reset(self):
        raise ValueError("no camera")

    def __call__(self, observation):
        return HOME
"""


@pytest.mark.parametrize(
    ("name", "error"),
    [
        ("WantsASeed", "TypeError: WantsASeed.reset() missing 1 required positional argument"),
        ("ResetRaises", "ValueError: no camera"),
    ],
)
def test_a_policy_whose_reset_fails_fails_its_episodes_by_name(
    tmp_path, monkeypatch, capsys, name, error
):
    """A reset(seed) was blamed on --env-option (exit 2), a reset that raised was an
    "unexpected error" (exit 1, a crash log): now each episode fails naming it, as an
    act() that raises does, and --out is written."""
    (tmp_path / "q11_reset_policies.py").write_text(RESET_POLICIES)
    monkeypatch.syspath_prepend(str(tmp_path))
    out = tmp_path / "scores.json"
    code = eval_main(
        ["--policy", f"q11_reset_policies:{name}", "--episodes", "2", "--jobs", "1",
         "--env-option", "obs_type=state", "--out", str(out)]
    )  # fmt: skip
    assert code == 1
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(
        "episode   1/2 seed 0: failure, 0/1 in their bins, return 0, 0 steps"
    )
    assert f"; the policy's reset() raised {error}" in lines[0]
    assert f"wrote {out}" in lines


def test_a_video_ends_on_the_state_the_episode_reached(tmp_path, capsys):
    """It held the frame before each step and not the one after the last: 20 steps gave 20
    frames, and a success's video stopped one step before the object lay in its bin.
    lerobot-eval renders after the reset and after each step: steps + 1 frames."""
    av = pytest.importorskip("av")
    out = tmp_path / "scores.json"
    code = eval_main(
        ["--episodes", "1", "--jobs", "1", "--videos", "1", "--out", str(out),
         "--env-option", "max_episode_steps=20"]
    )  # fmt: skip
    assert code == 0
    assert "20 steps" in capsys.readouterr().out
    with av.open(str(tmp_path / "videos" / "episode_000_seed_0.mp4")) as video:
        assert sum(1 for _ in video.decode(video=0)) == 21


def test_a_baseline_trained_at_an_fps_the_rate_cannot_divide_names_the_option_that_fixes_it(
    tmp_path, capsys
):
    """The line said ``--set servo.rate_hz=...``, which eval-policy does not take (exit 2,
    unrecognized arguments): its config overrides go in ``--env-option overrides=[...]``."""
    pytest.importorskip("torch")
    policy = tmp_path / "bc.pt"
    assert bc_main(["--episodes", "1", "--jobs", "1", "--steps", "1", "--out", str(policy)]) == 0
    capsys.readouterr()
    with pytest.raises(MearmError) as err:
        eval_main([
            "--policy", str(policy), "--episodes", "1", "--jobs", "1",
            "--env-option", "obs_type=state", "--env-option", "overrides=[servo.rate_hz=25]",
        ])  # fmt: skip
    assert "--env-option 'overrides=[servo.rate_hz=...]'" in str(err.value)
    assert "--set" not in str(err.value)
