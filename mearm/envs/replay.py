"""Replay a recorded episode's ``action`` column in the environment of its scene.

An episode recorded per scene (``mearm sort --config C --random N --seed S --record DIR
--record-per scene --record-fps F``) starts where :meth:`TwinEnv.reset` leaves the arm:
at home, after the sorter's first command. Its frame k holds the command in effect as
the clock reached frame k's time, so frames 1, 2, … are the actions of steps 0, 1, …
(frame 0's is already in effect). The environment steps at the recording's fps (it must
divide the servo rate); after the last action the objects are given up to
:data:`SETTLE_S` to come to rest, as the sort gives them before it counts.

    python -m mearm.envs.replay DIR --episode 0 --config sim_mujoco --objects 3 --seed 7
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mearm.cli import ArgumentParser, run, seed_value
from mearm.dataset import lerobot_format as L
from mearm.dataset.errors import DatasetError
from mearm.dataset.recorder import import_extra

#: How long the replay holds the last action for the objects to come to rest [s].
SETTLE_S = 2.0


@dataclass(frozen=True)
class Replayed:
    """How a replay ended.

    Attributes:
        steps: Actions stepped.
        bins: Each object in a bin → that bin's class (:meth:`TwinArm.objects_in_bin`).
        in_bins: Objects in their own class's bin.
        success: Whether every object is.
        refused: Steps whose action the environment refused.
    """

    steps: int
    bins: dict[str, str]
    in_bins: int
    success: bool
    refused: int


def episode_actions(root: Path, episode: int) -> tuple[np.ndarray, int]:
    """The ``action`` column of episode ``episode`` of a dataset, (k, n), and its fps.

    Raises:
        DatasetError: no dataset there, or no such episode.
    """
    info_path = root / L.INFO_PATH
    if not info_path.exists():
        raise DatasetError(root, f"has no {L.INFO_PATH}: not a LeRobot dataset")
    fps = int(json.loads(info_path.read_text())["fps"])
    pq = import_extra()[1]
    rows: list[Any] = []
    for path in sorted((root / "data").glob("*/*.parquet")):
        table = pq.read_table(path, columns=["episode_index", "frame_index", "action"])
        mask = np.asarray(table["episode_index"].to_numpy()) == episode
        if mask.any():
            frames = np.asarray(table["frame_index"].to_numpy())[mask]
            actions = np.array(table["action"].to_pylist(), dtype=np.float64)[mask]
            rows.extend(zip(frames.tolist(), actions, strict=True))
    if not rows:
        raise DatasetError(root, f"has no episode {episode}")
    rows.sort(key=lambda r: r[0])
    return np.stack([a for _, a in rows]), fps


def replay(
    root: Path, episode: int, *, seed: int, env_id: str = "mearm/Sort-v0", **options: Any
) -> Replayed:
    """Step episode ``episode``'s actions in ``env_id`` reset with ``seed`` (module docstring).

    Args:
        root: The dataset.
        episode: Its episode index.
        seed: The scene's seed (``--seed`` of the recorded sort).
        env_id: The environment (``mearm/Sort-v0`` for a scene of ``objects``).
        options: The environment's options (``config``, ``objects``, …).
    """
    import gymnasium as gym  # noqa: PLC0415

    import mearm.envs  # noqa: F401, PLC0415
    from mearm.envs.twin_env import TwinEnv  # noqa: PLC0415

    actions, fps = episode_actions(root, episode)
    env = gym.make(env_id, fps=fps, obs_type="state", max_episode_steps=None, **options)
    try:
        env.reset(seed=seed)
        refused = 0
        for action in actions[1:]:
            *_, info = env.step(action.astype(np.float32))
            refused += bool(info["refused"])
        twin_env = env.unwrapped
        assert isinstance(twin_env, TwinEnv) and twin_env.twin is not None
        twin = twin_env.twin
        twin.settle_objects(SETTLE_S)
        bins = twin.objects_in_bin()
        own = dict(zip(twin.object_ids, (o.color for o in twin_env.scene), strict=True))
        in_bins = sum(1 for oid, cls in bins.items() if own[oid] == cls)
        return Replayed(len(actions) - 1, bins, in_bins, in_bins == len(own), refused)
    finally:
        env.close()


def main(argv: Sequence[str] | None = None) -> int:
    """Replay one episode and print where its objects ended; 1 if not all in their bins."""
    parser = ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="the dataset's directory")
    parser.add_argument("--episode", type=int, default=0, help="episode index (default 0)")
    parser.add_argument("--config", default="sim_mujoco", help="the recorded sort's config")
    parser.add_argument("--objects", type=int, required=True, help="--random N of the sort")
    parser.add_argument("--seed", type=seed_value, required=True, help="--seed of the sort")
    args = parser.parse_args(argv)
    out = replay(
        args.dataset, args.episode, seed=args.seed, config=args.config, objects=args.objects
    )
    where = ", ".join(f"{o} in {b}" for o, b in sorted(out.bins.items())) or "none in a bin"
    print(f"replayed {out.steps} steps ({out.refused} refused): {where}")
    print(f"{out.in_bins} of {args.objects} objects in their bins (simulated)")
    return 0 if out.success else 1


if __name__ == "__main__":
    run(main)
