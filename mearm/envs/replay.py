"""Replay a recorded episode's ``action`` column in the environment of its scene.

An episode recorded per scene (``mearm sort --config C --random N --seed S --record DIR
--record-per scene --record-fps F``) starts where :meth:`TwinEnv.reset` leaves the arm:
at home, after the sorter's first command. Its frame k holds the command in effect as
the clock reached frame k's time, so frames 1, 2, … are the actions of steps 0, 1, …
(frame 0's is already in effect). The environment steps at the recording's fps (it must
divide the servo rate); after the last action the objects are given up to
:data:`SETTLE_S` to come to rest, as the sort gives them before it counts.

    python -m mearm.envs.replay DIR --episode 0

An episode per pick after a sort's first starts where the one before it left the arm
and the table (``meta/mearm_starts.json``,
:class:`~mearm.dataset.recorder.EpisodeStart`): the replay steps the sort's episodes
before it first, from the reset, each one's first action held over the time between
them (the sort looking at the table; going home to look again is not recorded, and is
replayed as the straight way to where the next pick begins). It succeeds when the pick
put one more object in its own bin, of its task's class; a scene's, when every object is
in its own. A pick whose start the dataset does not know (its
:attr:`~mearm.dataset.recorder.EpisodeStart.why`, or that of an episode before it in its
sort) is replayed from the reset, the reason said on stderr.

The dataset keeps each such episode's scene with its ``--config`` and ``--set``
(``meta/mearm_episodes.json``): a ``--random`` sort's ``--seed`` and count, or the table
itself, each object's class and place (a ``--scene`` sort's, a sort's of the config's
own table, an experiment trial's, with the trial's seed). The replay lays that scene and
runs the config as the sort ran it: its own servo and camera seeds for a ``mearm sort``,
the trial's (:func:`~mearm.experiment.trial_config`) for a trial, and the servo
calibration a sort made at its start (``servo.calibrate_at_start``), kept in the dataset
as a servo calibration file, unless the config names one of its own. It refuses a
``--seed`` or ``--objects`` that disagrees, or any with a table (exit 2). An episode
recorded without a scene by an older mearm needs both given (its table drawn by
``random_scene(config, N, seed)``; a ``--scene`` sort's or a trial's cannot be). The
config's arm must be the recording's (``robot_type`` and the action's names in
``info.json``), else exit 2 naming both. A dataset ``mearm dataset check`` fails (its
videos not decoded: a torn episode, an action that is not finite) is refused, exit 2,
before any step.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mearm.cli import (
    ArgumentParser,
    config_path_value,
    plain_int,
    run,
    say_on_stderr,
    seed_value,
)
from mearm.config import Config, SceneObject, load_config
from mearm.dataset.errors import DatasetError
from mearm.dataset.format_check import refuse_damaged
from mearm.dataset.reading import damaged, read_info, read_table, read_tags, read_tasks
from mearm.dataset.recorder import EpisodeStart, import_extra, read_starts
from mearm.dataset.sampler import state_names, task_sentence

if TYPE_CHECKING:
    import gymnasium as gym

#: How long the replay holds the last action for the objects to come to rest [s].
SETTLE_S = 2.0


@dataclass(frozen=True)
class Replayed:
    """How a replay ended.

    Attributes:
        steps: The episode's actions stepped.
        bins: Each object in a bin → that bin's class (:meth:`TwinArm.objects_in_bin`).
        in_bins: Objects in their own class's bin.
        success: A scene's episode: whether every object is. A pick's: whether it put
            one more object in its own bin, of its task's class (:attr:`pick`), and took
            none out.
        refused: Steps whose action the environment refused (the sort's before the
            episode's included).
        objects: Objects in the scene.
        table: The scene laid, each object's class and place, in the twin's order.
        lead_steps: The actions stepped before the episode's own: the sort's episodes
            before it, and the time between them (:attr:`ReplayPlan.lead`).
        before: Objects in their own class's bin as the episode's own actions began.
        start_state: The arm as the episode's own actions began, measured as its
            ``observation.state`` (its frame 0, as recorded); empty if a fault came first.
        pick: A pick's episode: its task's class; ``None``: a scene's.
        start_known: Whether the recording says where the episode starts (else it is
            replayed from the reset's start).
        why_not_known: If not, why (:attr:`ReplayPlan.why_not_known`).
    """

    steps: int
    bins: dict[str, str]
    in_bins: int
    success: bool
    refused: int
    objects: int = 0
    table: tuple[SceneObject, ...] = ()
    lead_steps: int = 0
    before: int = 0
    start_state: tuple[float, ...] = ()
    pick: str | None = None
    start_known: bool = True
    why_not_known: str = ""


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
            recording's, a trial's noise seeds its own, the servo calibration the sort
            made at its start), not reseeded.
        table: The table laid as it was recorded, or ``None``: drawn from ``seed``.
        lead: The actions stepped from the reset before the episode's own, (m, n): an
            episode per pick after its sort's first starts where the one before it
            ended, so each episode of the sort before it, from the sort's first, with
            its first action held over the frames between them
            (:class:`~mearm.dataset.recorder.EpisodeStart`); none for a sort's first.
        pick: A pick's episode: its task's class; ``None``: a scene's (or a task that
            names none of the config's classes).
        start_known: Whether the recording says where the episode starts, and where
            each episode before it in its sort does; if not, it is replayed from the
            reset's start.
        why_not_known: If not, why: the recording's reason (:class:`EpisodeStart`), of
            the episode or of the one before it in its sort whose start is not known.
    """

    actions: np.ndarray
    fps: int
    seed: int
    objects: int
    config: Config
    table: tuple[SceneObject, ...] | None = None
    lead: np.ndarray | None = None
    pick: str | None = None
    start_known: bool = True
    why_not_known: str = ""


def plan_replay(
    root: Path,
    episode: int,
    *,
    seed: int | None = None,
    objects: int | None = None,
    config: str | Path | Config | None = None,
    overrides: Sequence[str] = (),
    overrides_as: str = "overrides",
) -> ReplayPlan:
    """Check a replay's inputs against the recording, before any step.

    ``seed``, ``objects`` and ``config`` default to the episode's recorded scene
    (``meta/mearm_episodes.json``); without one, ``seed`` and ``objects`` must be given
    and ``config`` is ``sim_mujoco``. A recorded table is laid as it is: no ``seed`` nor
    ``objects`` draws it. The servo calibration the sort made at its start is applied
    unless the config names a ``servo.calibration_file`` of its own. A bad override is
    said of ``overrides_as`` (the command passes its flag, ``--set``).

    Raises:
        DatasetError: no dataset there, no such episode, a file of it damaged or a rule
            of ``mearm dataset check`` broken (its videos not decoded: a torn episode,
            an action that is not finite), a ``seed`` or ``objects`` the recorded scene
            disagrees with (any, with a recorded table), none to default to, or a config
            whose arm is not the recording's.
        ConfigError: the config cannot be loaded.
        ServoCalibrationError: the recorded servo calibration is not one of this arm's.
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
    cfg = (
        config
        if isinstance(config, Config)
        else load_config(config, tuple(overrides), path_as="config", overrides_as=overrides_as)
    )
    _check_arm(root, info, cfg, config)
    if recorded is not None and recorded.noise_seed is not None:
        from mearm.experiment.trials import trial_config  # noqa: PLC0415

        cfg = trial_config(cfg, recorded.noise_seed)  # the trial's servo kit and noise
    starts = read_starts(root, total)
    servos = starts[episode].servos
    if servos is not None and cfg.servo.calibration_file is None:
        cfg = _calibrated(root, servos, cfg)
    chain = _chain(starts, episode)
    why = chain if isinstance(chain, str) else ""
    columns, fps = _actions(root, set(chain) if isinstance(chain, list) else {episode}, info)
    actions, task = columns[episode]
    lead = _lead(chain, starts, columns) if isinstance(chain, list) else actions[:0]
    pick = next((c for c in cfg.task.class_names if task_sentence(c) == task), None)
    # the files read whole, a rule broken still (a torn episode, an action that is not
    # finite) would be replayed wrong, or crash the replay halfway
    refuse_damaged(root)
    return ReplayPlan(actions, fps, seed, objects, cfg, table, lead, pick, not why, why)


def _calibrated(root: Path, rel: str, config: Config) -> Config:
    """``config`` with the servo calibration file ``rel`` of the dataset, as a config names it.

    Raises:
        DatasetError: the file is not there.
        ServoCalibrationError: it is not a servo calibration of the config's arm.
    """
    from mearm.config.servo_file import apply_servo_calibration_file  # noqa: PLC0415

    path = (root / rel).resolve()
    if not path.is_file():
        raise damaged(root, rel, "is missing (the servo calibration an episode ran)")
    servo = config.servo.model_copy(update={"calibration_file": str(path)})
    return apply_servo_calibration_file(config.model_copy(update={"servo": servo}), path)


#: Why an episode's start is not known, when its entry does not say (``{}``, written by
#: a mearm that kept no reason).
NO_REASON_KEPT = (
    "the dataset does not say why (recorded by a mearm that kept no reason; mostly a "
    "trial's pick run again by --resume, the pick before it recorded by the killed run)"
)


def _chain(starts: list[EpisodeStart], episode: int) -> list[int] | str:
    """The episodes of ``episode``'s sort from its first to it; not known: why."""
    chain = [episode]
    while True:
        k = chain[-1]
        start = starts[k]
        if not start.known:
            why = start.why or NO_REASON_KEPT
            if k == episode:
                return why
            return f"it continues episode {k} of its sort, whose start is not known: {why}"
        if start.after is None:
            return chain[::-1]
        chain.append(start.after)


def _lead(
    chain: list[int], starts: list[EpisodeStart], columns: dict[int, tuple[np.ndarray, str]]
) -> np.ndarray:
    """The actions stepped before the last episode of ``chain``'s own (:attr:`ReplayPlan.lead`)."""
    parts = []
    for k in chain:  # the first's gap is none: it starts at the reset
        actions = columns[k][0]
        parts.append(np.repeat(actions[:1], starts[k].gap_frames, axis=0))
        if k != chain[-1]:
            parts.append(actions[1:])
    return np.concatenate(parts)


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
    columns, fps = _actions(root, {episode}, info)
    return columns[episode][0], fps


def _actions(
    root: Path, episodes: set[int], info: dict[str, Any] | None = None
) -> tuple[dict[int, tuple[np.ndarray, str]], int]:
    """Each of ``episodes``' ``action`` column, (k, n), and task; the dataset's fps.

    The data files are read once for them all.

    Raises:
        DatasetError: no dataset there, a file of it damaged, or no such episode.
    """
    fps = int((info or read_info(root))["fps"])
    pq = import_extra(av_here=False)[1]
    rows: dict[int, list[Any]] = {k: [] for k in episodes}
    task_of: dict[int, int] = {}
    columns = ["episode_index", "frame_index", "action", "task_index"]
    for path in sorted((root / "data").glob("*/*.parquet")):
        rel = str(path.relative_to(root))
        table = read_table(pq, root, rel, columns, only=True)
        index = np.asarray(table["episode_index"].to_numpy())
        for k in episodes:
            mask = index == k
            if mask.any():
                frames = np.asarray(table["frame_index"].to_numpy())[mask]
                actions = np.array(table["action"].to_pylist(), dtype=np.float64)[mask]
                rows[k].extend(zip(frames.tolist(), actions, strict=True))
                task_of[k] = int(np.asarray(table["task_index"].to_numpy())[mask][0])
    tasks = read_tasks(pq, root) if task_of else []
    out = {}
    for k in sorted(episodes):
        if not rows[k]:
            raise DatasetError(root, f"has no episode {k}")
        if not 0 <= task_of[k] < len(tasks):
            raise damaged(root, "data", f"episode {k}'s task_index {task_of[k]} names no task")
        rows[k].sort(key=lambda r: r[0])
        out[k] = (np.stack([a for _, a in rows[k]]), tasks[task_of[k]])
    return out, fps


def replay(
    root: Path,
    episode: int,
    *,
    seed: int | None = None,
    objects: int | None = None,
    config: str | Path | Config | None = None,
    overrides: Sequence[str] = (),
    overrides_as: str = "overrides",
    env_id: str = "mearm/Sort-v0",
    **options: Any,
) -> Replayed:
    """Step episode ``episode``'s actions in ``env_id`` on its scene (module docstring).

    The environment runs the config as the sort ran it (``reseed=False``: the sort's own
    servo and camera seeds, a trial's its trial's, the servo calibration it made at its
    start), on the recorded table if there is one; an episode per pick after its sort's
    first starts after the sort's episodes before it (:attr:`ReplayPlan.lead`).

    Args:
        root: The dataset.
        episode: Its episode index.
        seed: The scene's seed (``--seed`` of the recorded sort); default: the recorded
            one. None with a recorded table.
        objects: Its objects (``--random N``); default: the recorded number. None with a
            recorded table.
        config: The sort's config; default: the recorded one (else ``sim_mujoco``).
        overrides: ``--set`` values for a ``config`` given by name or file.
        overrides_as: What a bad override is said of (``--set`` for the command's).
        env_id: The environment (``mearm/Sort-v0`` for a scene of ``objects``).
        options: The environment's other options.

    Raises:
        DatasetError: the inputs do not match the recording (:func:`plan_replay`).
    """
    import gymnasium as gym  # noqa: PLC0415

    import mearm.envs  # noqa: F401, PLC0415
    from mearm.envs.twin_env import TwinEnv  # noqa: PLC0415

    plan = plan_replay(
        root,
        episode,
        seed=seed,
        objects=objects,
        config=config,
        overrides=overrides,
        overrides_as=overrides_as,
    )
    actions = plan.actions
    lead = plan.lead if plan.lead is not None else actions[:0]
    env = gym.make(
        env_id, fps=plan.fps, obs_type="state", max_episode_steps=None, config=plan.config,
        objects=plan.objects, scene=plan.table, reseed=False, **options,
    )  # fmt: skip
    try:
        env.reset(seed=plan.seed)
        twin_env = env.unwrapped
        assert isinstance(twin_env, TwinEnv) and twin_env.twin is not None
        twin = twin_env.twin
        own = dict(zip(twin.object_ids, (o.color for o in twin_env.scene), strict=True))

        def in_own_bins() -> set[str]:
            return {oid for oid, cls in twin.objects_in_bin().items() if own[oid] == cls}

        with warnings.catch_warnings():
            # the recording goes on past the step that put the last object in its bin (the
            # sorter's way home): stepped as recorded, not a misuse of the ended episode
            warnings.filterwarnings("ignore", message=r".*step\(\) after the episode returned")
            refused, fault = _step(env, lead)
            start: tuple[float, ...] = ()
            before: set[str] = set()
            if not fault:
                start = tuple(float(v) for v in twin_env.spec_actions.agent_pos(twin))
                before = in_own_bins()
                more, fault = _step(env, actions[1:])
                refused += more
        twin.settle_objects(SETTLE_S)
        bins = twin.objects_in_bin()
        after = in_own_bins()
        if plan.pick is None:
            success = len(after) == len(own)
        else:
            new = after - before
            success = before <= after and [own[oid] for oid in new] == [plan.pick]
        return Replayed(
            len(actions) - 1, bins, len(after), success, refused, len(own),
            tuple(twin_env.scene), len(lead), len(before), start, plan.pick, plan.start_known,
            plan.why_not_known,
        )  # fmt: skip
    finally:
        env.close()


def _step(env: gym.Env[Any, Any], actions: np.ndarray) -> tuple[int, bool]:
    """Step each action; the steps refused, and whether a fault stopped the stepping.

    After a fault (the physics diverged) the environment steps no more.
    """
    refused = 0
    for action in actions:
        *_, info = env.step(action.astype(np.float32))
        refused += bool(info["refused"])
        if info.get("fault"):
            return refused, True
    return refused, False


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
        overrides_as="--set",
    )
    if out.pick is not None and not out.start_known:
        say_on_stderr(
            f"note: episode {args.episode} is a pick whose start the dataset does not keep: "
            f"{out.why_not_known}; replayed from where the environment's reset leaves the arm",
            "python -m mearm.envs.replay",
        )
    where = ", ".join(f"{o} in {b}" for o, b in sorted(out.bins.items())) or "none in a bin"
    lead = f" after {out.lead_steps} of its sort's before it" if out.lead_steps else ""
    print(f"replayed {out.steps} steps{lead} ({out.refused} refused): {where}")
    if out.pick is None:
        print(f"{out.in_bins} of {out.objects} objects in their bins (simulated)")
    else:
        print(
            f"{out.in_bins} of {out.objects} objects in their bins, {out.before} before this "
            f"pick of a {out.pick} object: {'one' if out.success else 'not one'} more of it "
            "(simulated)"
        )
    return 0 if out.success else 1


if __name__ == "__main__":
    run(main)
