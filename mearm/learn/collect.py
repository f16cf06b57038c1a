"""Demonstrations: the expert's episodes in an environment, as state-action pairs.

Each worker makes the environment once (``obs_type="state"``, the sorter beside it) and
runs the seeds it is handed; the episodes come back in seed order. Only successful
episodes are kept: a demonstration shows the task done. A saved file also says what its
episodes were collected for (:data:`META_KEY`), so that a later run can refuse demos
of another environment, config or seed range instead of training on them unawares.
"""

from __future__ import annotations

import functools
import io
import json
import os
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mearm import interrupts
from mearm.learn.errors import DemosError


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

    def save(self, path: Path, meta: dict[str, Any] | None = None) -> None:
        """Write as ``.npz``, with ``meta`` (what the episodes were collected for).

        In one step (:func:`mearm.fileio.write_atomic`): a full disk or a signal leaves
        no half file for the next run to reuse, and the name is kept as given (numpy
        would add ``.npz`` to another suffix, and the next run would not find it).

        Raises:
            OSError: the file cannot be written.
        """
        from mearm.fileio import write_atomic  # noqa: PLC0415

        arrays: dict[str, Any] = dict(self.__dict__)
        if meta is not None:
            arrays[META_KEY] = np.array(json.dumps(meta, sort_keys=True))
        buffer = io.BytesIO()
        np.savez_compressed(buffer, **arrays)
        write_atomic(path, buffer.getvalue())

    @classmethod
    def load(cls, path: Path) -> Demos:
        """Read what :meth:`save` wrote (:func:`read_demos`, without its metadata)."""
        return read_demos(path)[0]


FIELDS = ("agent_pos", "environment_state", "action", "episode", "step")

#: The entry of a demos file that holds its metadata (JSON text).
META_KEY = "meta"


def read_demos(path: Path) -> tuple[Demos, dict[str, Any] | None]:
    """The demonstrations in ``path`` and their metadata (``None``: an older file).

    Raises:
        DemosError: not an ``.npz`` file, one without the arrays :meth:`Demos.save`
            writes, a damaged one, or arrays of disagreeing lengths.
    """
    what = f"--demos {path}"
    hint = "give a file mearm.learn.bc saved, or a new path to collect into"
    try:
        with open(path, "rb") as f:
            head = f.read(6)
    except OSError as exc:
        raise DemosError(f"{what}: cannot read it ({exc.strerror})") from None
    if not head:
        raise DemosError(f"{what}: the file is empty; {hint}")
    if not head.startswith((b"PK\x03\x04", b"\x93NUMPY")):
        raise DemosError(f"{what}: not a demonstrations file (.npz, a zip archive); {hint}")
    try:
        data = np.load(path, allow_pickle=False)
        if not isinstance(data, np.lib.npyio.NpzFile):
            raise DemosError(f"{what}: one array (.npy), not a demonstrations file (.npz); {hint}")
        with data:
            missing = [k for k in FIELDS if k not in data.files]
            if missing:
                raise DemosError(
                    f"{what}: not a demonstrations file of mearm.learn: it has no "
                    f"{', '.join(missing)}; {hint}"
                )
            demos = Demos(*(np.asarray(data[k]) for k in FIELDS))
            meta = json.loads(str(data[META_KEY])) if META_KEY in data.files else None
    except DemosError:
        raise
    except Exception as exc:  # numpy, zipfile and zlib each say "damaged" their own way
        raise DemosError(
            f"{what}: a damaged or truncated .npz ({type(exc).__name__}: "
            f"{' '.join(str(exc).split())[:80]}); {hint}"
        ) from None
    k = len(demos.action)
    shapes_ok = (
        demos.agent_pos.ndim == demos.environment_state.ndim == demos.action.ndim == 2
        and demos.episode.ndim == demos.step.ndim == 1
        and all(len(getattr(demos, f)) == k for f in FIELDS)
    )
    if not shapes_ok:
        raise DemosError(f"{what}: its arrays disagree in shape (a damaged demonstrations file)")
    if meta is not None and not isinstance(meta, dict):
        raise DemosError(f"{what}: its metadata is not a mapping (a damaged demonstrations file)")
    return demos, meta


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
    # a worker whose parent is gone ends (kill -9 of the command): not an orphan at work
    orphaned = functools.partial(interrupts.end_when_orphaned, os.getpid())
    with ProcessPoolExecutor(max_workers=jobs, initializer=orphaned) as pool:
        done = list(pool.map(_collect, [env_id] * jobs, [options] * jobs, parts))
    order = np.argsort(np.concatenate([d.episode for d in done]), kind="stable")
    return Demos(*(np.concatenate([getattr(d, f) for d in done])[order] for f in FIELDS))
