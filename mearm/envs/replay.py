"""Replay a recorded episode's ``action`` column in the environment of its scene.

An episode recorded per scene (``mearm sort --config C --random N --seed S --record DIR
--record-per scene --record-fps F``) starts where :meth:`TwinEnv.reset` leaves the arm:
at home, after the sorter's first command. Its frame k holds the command in effect as
the clock reached frame k's time, so frames 1, 2, … are the actions of steps 0, 1, …
(frame 0's is already in effect). The environment steps at the recording's fps (it must
divide the servo rate); after the last action the objects are given up to
:data:`SETTLE_S` to come to rest, as the sort gives them before it counts.

    python -m mearm.envs.replay DIR --episode 0

The dataset keeps each such episode's scene with its ``--config`` and ``--set``
(``meta/mearm_episodes.json``): a ``--random`` sort's ``--seed`` and count, or the table
itself, each object's class and place (a ``--scene`` sort's, an experiment trial's, with
the trial's seed). The replay lays that scene and runs the config as the sort ran it:
its own servo and camera seeds for a ``mearm sort``, the trial's
(:func:`~mearm.experiment.trial_config`) for a trial. It refuses a ``--seed`` or
``--objects`` that disagrees, or any with a table (exit 2). An episode recorded without
a scene by an older mearm needs both given (its table drawn by ``random_scene(config,
N, seed)``; a ``--scene`` sort's or a trial's cannot be). The config's arm must be the
recording's (``robot_type`` and the action's names in ``info.json``), else exit 2
naming both. A sort that calibrated its servos by the camera at its start
(``servo.calibrate_at_start``) ran with a calibration the dataset does not keep: give
the file its ``--save-calibration`` wrote (``--set servo.calibration_file=FILE``).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mearm.cli import ArgumentParser, config_path_value, plain_int, run, seed_value
from mearm.config import Config, SceneObject, load_config
from mearm.dataset.errors import DatasetError
from mearm.dataset.reading import read_info, read_table, read_tags
from mearm.dataset.recorder import import_extra
from mearm.dataset.sampler import state_names

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
        objects: Objects in the scene.
        table: The scene laid, each object's class and place, in the twin's order.
    """

    steps: int
    bins: dict[str, str]
    in_bins: int
    success: bool
    refused: int
    objects: int = 0
    table: tuple[SceneObject, ...] = ()


@dataclass(frozen=True)
class ReplayPlan:
    """What a replay of an episode steps, and in which scene.

    Attributes:
        actions: The episode's ``action`` column, (k, n).
        fps: The recording's frames per second.
        seed: The environment's reset seed: the scene's, drawn by it (a ``--random``
            sort's); with a ``table``, the trial's (else 0), which then draws nothing.
        objects: Its number of objects.
        config: The config the environment runs as the sort ran it (its arm the
            recording's, a trial's noise seeds its own), not reseeded.
        table: The table laid as it was recorded, or ``None``: drawn from ``seed``.
    """

    actions: np.ndarray
    fps: int
    seed: int
    objects: int
    config: Config
    table: tuple[SceneObject, ...] | None = None


def plan_replay(
    root: Path,
    episode: int,
    *,
    seed: int | None = None,
    objects: int | None = None,
    config: str | Path | Config | None = None,
    overrides: Sequence[str] = (),
) -> ReplayPlan:
    """Check a replay's inputs against the recording, before any step.

    ``seed``, ``objects`` and ``config`` default to the episode's recorded scene
    (``meta/mearm_episodes.json``); without one, ``seed`` and ``objects`` must be given
    and ``config`` is ``sim_mujoco``. A recorded table is laid as it is: no ``seed`` nor
    ``objects`` draws it.

    Raises:
        DatasetError: no dataset there, no such episode, a file of it damaged, a
            ``seed`` or ``objects`` the recorded scene disagrees with (any, with a
            recorded table), none to default to, or a config whose arm is not the
            recording's.
        ConfigError: the config cannot be loaded.
    """
    info = read_info(root)
    total = info["total_episodes"]
    if not 0 <= episode < total:
        raise DatasetError(root, f"has no episode {episode} (it holds episodes 0..{total - 1})")
    recorded = read_tags(root, total)[1][episode]
    table = None
    if recorded is None:
        if seed is None or objects is None:
            missing = "--seed" if seed is None else "--objects"
            raise DatasetError(
                root,
                f"episode {episode} keeps no scene (recorded without --random N --seed S, "
                f"or by an older mearm): give {missing} (the sort's --seed and --random N)",
            )
    elif recorded.table is not None:
        given = "--seed" if seed is not None else "--objects" if objects is not None else ""
        if given:
            raise DatasetError(
                root,
                f"episode {episode} was recorded on a table of {recorded.objects} objects "
                "laid as they were (a --scene sort's or an experiment trial's), not drawn "
                f"by --random N --seed S: leave {given} out to replay it",
            )
        table = recorded.table
        seed = 0 if recorded.noise_seed is None else recorded.noise_seed
        objects = recorded.objects
    else:
        for flag, given_value, there in (
            ("--seed", seed, recorded.seed),
            ("--objects", objects, recorded.objects),
        ):
            if given_value is not None and given_value != there:
                raise DatasetError(
                    root,
                    f"episode {episode} was recorded with --random {recorded.objects} "
                    f"--seed {recorded.seed}, not {flag} {given_value}: leave {flag} out to "
                    "replay the recorded scene",
                )
        seed, objects = recorded.seed, recorded.objects
    assert seed is not None and objects is not None  # given, else refused above
    if config is None and recorded is not None:
        config, overrides = recorded.config, recorded.overrides
    elif config is None:
        config = "sim_mujoco"
    cfg = config if isinstance(config, Config) else load_config(config, tuple(overrides))
    _check_arm(root, info, cfg, config)
    if recorded is not None and recorded.noise_seed is not None:
        from mearm.experiment.trials import trial_config  # noqa: PLC0415

        cfg = trial_config(cfg, recorded.noise_seed)  # the trial's servo kit and noise
    actions, fps = episode_actions(root, episode, info)
    return ReplayPlan(actions, fps, seed, objects, cfg, table)


def _check_arm(root: Path, info: dict[str, Any], config: Config, name: object) -> None:
    """Refuse a config whose arm is not the one the dataset was recorded with."""
    shown = f"--config {name}"
    if name is None or isinstance(name, Config):
        shown = "the built-in sim" if name is None else "the config"
    there = info.get("robot_type")
    if there != config.arm.name:
        raise DatasetError(
            root,
            f"recorded with the arm {there!r}, {shown} has the arm {config.arm.name!r}: "
            "give the --config it was recorded with",
        )
    action = info["features"].get("action", {})
    names = state_names(config)
    if action.get("names") != names:
        width = (action.get("shape") or [None])[0]
        raise DatasetError(
            root,
            f"its action is {width} numbers ({', '.join(map(str, action.get('names') or []))}), "
            f"{shown}'s arm takes {len(names)} ({', '.join(names)}): give the --config it "
            "was recorded with",
        )


def episode_actions(
    root: Path, episode: int, info: dict[str, Any] | None = None
) -> tuple[np.ndarray, int]:
    """The ``action`` column of episode ``episode`` of a dataset, (k, n), and its fps.

    Raises:
        DatasetError: no dataset there, a file of it damaged, or no such episode.
    """
    fps = int((info or read_info(root))["fps"])
    pq = import_extra(av_here=False)[1]
    rows: list[Any] = []
    columns = ["episode_index", "frame_index", "action"]
    for path in sorted((root / "data").glob("*/*.parquet")):
        table = read_table(pq, root, str(path.relative_to(root)), columns, only=True)
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
    root: Path,
    episode: int,
    *,
    seed: int | None = None,
    objects: int | None = None,
    config: str | Path | Config | None = None,
    overrides: Sequence[str] = (),
    env_id: str = "mearm/Sort-v0",
    **options: Any,
) -> Replayed:
    """Step episode ``episode``'s actions in ``env_id`` on its scene (module docstring).

    The environment runs the config as the sort ran it (``reseed=False``: the sort's own
    servo and camera seeds, a trial's its trial's), on the recorded table if there is one.

    Args:
        root: The dataset.
        episode: Its episode index.
        seed: The scene's seed (``--seed`` of the recorded sort); default: the recorded
            one. None with a recorded table.
        objects: Its objects (``--random N``); default: the recorded number. None with a
            recorded table.
        config: The sort's config; default: the recorded one (else ``sim_mujoco``).
        overrides: ``--set`` values for a ``config`` given by name or file.
        env_id: The environment (``mearm/Sort-v0`` for a scene of ``objects``).
        options: The environment's other options.

    Raises:
        DatasetError: the inputs do not match the recording (:func:`plan_replay`).
    """
    import gymnasium as gym  # noqa: PLC0415

    import mearm.envs  # noqa: F401, PLC0415
    from mearm.envs.twin_env import TwinEnv  # noqa: PLC0415

    plan = plan_replay(
        root, episode, seed=seed, objects=objects, config=config, overrides=overrides
    )
    actions = plan.actions
    env = gym.make(
        env_id, fps=plan.fps, obs_type="state", max_episode_steps=None, config=plan.config,
        objects=plan.objects, scene=plan.table, reseed=False, **options,
    )  # fmt: skip
    try:
        env.reset(seed=plan.seed)
        refused = 0
        with warnings.catch_warnings():
            # the recording goes on past the step that put the last object in its bin (the
            # sorter's way home): stepped as recorded, not a misuse of the ended episode
            warnings.filterwarnings("ignore", message=r".*step\(\) after the episode returned")
            for action in actions[1:]:
                *_, info = env.step(action.astype(np.float32))
                refused += bool(info["refused"])
                if info.get("fault"):  # the physics diverged: the environment steps no more
                    break
        twin_env = env.unwrapped
        assert isinstance(twin_env, TwinEnv) and twin_env.twin is not None
        twin = twin_env.twin
        twin.settle_objects(SETTLE_S)
        bins = twin.objects_in_bin()
        own = dict(zip(twin.object_ids, (o.color for o in twin_env.scene), strict=True))
        in_bins = sum(1 for oid, cls in bins.items() if own[oid] == cls)
        return Replayed(
            len(actions) - 1, bins, in_bins, in_bins == len(own), refused, len(own),
            tuple(twin_env.scene),
        )  # fmt: skip
    finally:
        env.close()


def main(argv: Sequence[str] | None = None) -> int:
    """Replay one episode and print where its objects ended; 1 if not all in their bins."""
    parser = ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="the dataset's directory")
    parser.add_argument("--episode", type=plain_int, default=0, help="episode index (default 0)")
    parser.add_argument(
        "--config",
        type=config_path_value,
        help="the recorded sort's config (default: the recorded one, else sim_mujoco)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override one value of --config (repeatable)",
    )
    parser.add_argument(
        "--objects", type=plain_int, help="--random N of the sort (default: recorded)"
    )
    parser.add_argument("--seed", type=seed_value, help="--seed of the sort (default: recorded)")
    args = parser.parse_args(argv)
    if args.set and args.config is None:
        parser.error("--set overrides --config: give --config too")
    out = replay(
        args.dataset,
        args.episode,
        seed=args.seed,
        objects=args.objects,
        config=args.config,
        overrides=args.set,
    )
    where = ", ".join(f"{o} in {b}" for o, b in sorted(out.bins.items())) or "none in a bin"
    print(f"replayed {out.steps} steps ({out.refused} refused): {where}")
    print(f"{out.in_bins} of {out.objects} objects in their bins (simulated)")
    return 0 if out.success else 1


if __name__ == "__main__":
    run(main)
