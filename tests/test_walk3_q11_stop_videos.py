"""docs/learning.md walked a third time: a stopped eval-policy names every video it wrote."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import mearm.envs  # noqa: F401  (registers the environments)

ROOT = Path(__file__).resolve().parent.parent

#: Holds the arm at home; slow (2 s a step) in the episode of seed 0 only, known by its
#: first observation (its objects), so that seed 1's episode ends, and writes its video,
#: while seed 0's still runs and holds back the lines in seed order.
POLICY = """
import os
import time

import numpy as np

SEED0 = np.array([float(v) for v in os.environ["Q11_SEED0"].split(",")], dtype=np.float32)
HOME = np.array([120.0, 93.0, -132.0, 60.0, 0.0], dtype=np.float32)


class HomeSlowOnSeed0:
    def __init__(self):
        self.slow = None

    def reset(self):
        self.slow = None

    def __call__(self, observation):
        if self.slow is None:
            self.slow = bool(np.allclose(observation["environment_state"], SEED0, atol=1e-3))
        if self.slow:
            time.sleep(2)
        return HOME
"""


def test_a_video_written_while_an_earlier_episode_ran_is_named_when_stopped(tmp_path):
    """Seed 1's video was written, but its line waited for seed 0's, and Ctrl-C dropped
    both: a file on disk that no ``wrote`` line named."""
    env = gym.make("mearm/PickPlace-v0", obs_type="state")
    seed0 = env.reset(seed=0)[0]["environment_state"]
    env.close()
    (tmp_path / "q11_policy.py").write_text(textwrap.dedent(POLICY))
    environ = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)]),
        "Q11_SEED0": ",".join(f"{v:.6f}" for v in np.asarray(seed0)),
        "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
    }
    out = tmp_path / "scores.json"
    proc = subprocess.Popen(
        [sys.executable, "-m", "mearm", "eval-policy", "--policy", "q11_policy:HomeSlowOnSeed0",
         "--episodes", "2", "--jobs", "2", "--videos", "2", "--out", out.name,
         "--env-option", "obs_type=state", "--env-option", "max_episode_steps=30"],
        cwd=tmp_path, env=environ, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    video1 = tmp_path / "videos" / "episode_001_seed_1.mp4"
    deadline = time.monotonic() + 120
    while not video1.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert video1.exists(), proc.communicate(timeout=60)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr
    assert stdout.splitlines() == ["wrote videos/episode_001_seed_1.mp4"], stdout
    assert not (tmp_path / "videos" / "episode_000_seed_0.mp4").exists()  # stopped: none
    assert not out.exists()
