"""Demonstrations: the expert's episodes in an environment, as state-action pairs.

Each worker makes the environment once (``obs_type="state"``, the sorter beside it) and
runs the seeds it is handed; the episodes come back in seed order. Only successful
episodes are kept: a demonstration shows the task done.
"""

from __future__ import annotations

from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Demos:
    """State-action pairs of expert episodes.

    Attributes:
        agent_pos: (k, n) the arm's state per step.
        environment_state: (k, m) the objects per step.
        action: (k, n) the expert's action.
        episode: (k,) the seed of each step's episode.
        step: (k,) each step's index in its episode.
    """

    agent_pos: np.ndarray
    environment_state: np.ndarray
    action: np.ndarray
    episode: np.ndarray
    step: np.ndarray

    def save(self, path: Path) -> None:
        """Write as ``.npz``."""
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(path, **self.__dict__)

    @classmethod
    def load(cls, path: Path) -> Demos:
        """Read what :meth:`save` wrote."""
        with np.load(path) as data:
            return cls(*(data[k] for k in FIELDS))


FIELDS = ("agent_pos", "environment_state", "action", "episode", "step")


def _episode(env: Any, seed: int) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
    obs, info = env.reset(seed=seed)
    pos, state, act = [], [], []
    done = False
    while not done:
        action = info["expert_action"]
        pos.append(obs["agent_pos"])
        state.append(obs["environment_state"])
        act.append(action)
        obs, _, terminated, truncated, info = env.step(action)
        done = terminated or truncated
    if not info["is_success"]:
        return [], [], []
    return pos, state, act


def _collect(env_id: str, options: dict[str, Any], seeds: Sequence[int]) -> Demos:
    import gymnasium as gym  # noqa: PLC0415

    import mearm.envs  # noqa: F401, PLC0415

    env = gym.make(env_id, **{**options, "obs_type": "state", "expert": True})
    n = int(np.prod(env.action_space.shape or (0,)))
    pos: list[np.ndarray] = []
    state: list[np.ndarray] = []
    act: list[np.ndarray] = []
    ep: list[int] = []
    index: list[int] = []
    try:
        for seed in seeds:
            p, s, a = _episode(env, seed)
            pos += p
            state += s
            act += a
            ep += [seed] * len(p)
            index += list(range(len(p)))
    finally:
        env.close()
    return Demos(
        np.array(pos, dtype=np.float32).reshape(-1, n),
        np.array(state, dtype=np.float32).reshape(len(pos), -1),
        np.array(act, dtype=np.float32).reshape(-1, n),
        np.array(ep, dtype=np.int64),
        np.array(index, dtype=np.int64),
    )


def collect(env_id: str, options: dict[str, Any], seeds: Sequence[int], jobs: int = 1) -> Demos:
    """The expert's successful episodes of ``seeds``, from ``jobs`` worker processes."""
    seeds = list(seeds)
    if jobs == 1 or len(seeds) < 2:
        return _collect(env_id, options, seeds)
    parts = [seeds[k::jobs] for k in range(jobs)]
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        done = list(pool.map(_collect, [env_id] * jobs, [options] * jobs, parts))
    order = np.argsort(np.concatenate([d.episode for d in done]), kind="stable")
    return Demos(*(np.concatenate([getattr(d, f) for d in done])[order] for f in FIELDS))
