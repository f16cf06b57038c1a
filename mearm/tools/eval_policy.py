"""Score a policy over seeded episodes of a twin environment, as lerobot-eval does.

    mearm eval-policy --env mearm/PickPlace-v0 --policy expert --episodes 50 --out pp.json
    mearm eval-policy --env mearm/Sort-v0 --policy mymodule:act --episodes 20 --jobs 2

``--policy``: ``expert`` (the sorter, stepped), ``random``, ``module:callable`` (a
function of the observation, or a class whose instances are) or a baseline ``FILE.pt``
(``mearm[learn]``). Episode k has seed ``--first-seed`` + k. Prints one line per episode
as it ends (seed order) and the totals; ``--out`` writes them as JSON (``pc_success``,
``avg_sum_reward``, ``avg_max_reward`` and per episode its seed, outcome, return and
steps); ``--videos K`` writes the first K episodes as MP4s into ``videos/`` beside it
(``./videos/`` without ``--out``). Each file is named as it is written: ``wrote
videos/episode_….mp4`` after its episode's line, ``wrote OUT`` before the totals, which
stay last. An ``--out`` or a video that exists is refused before any episode runs, unless
``--force``.
``--env-option key=value`` passes an option to the environment (``objects``, ``scene``,
``reseed``, ``fps``, ``obs_type``, ``image_size``, ``overrides``, ``max_episode_steps``;
values in YAML; the config is ``--config``'s). Exit 0; 1 if the
success rate is below ``--require`` or an episode ended on an error (the policy raised,
gave an action that is not finite, or a fault: the episode's ``error`` says which, the
others are scored and ``--out`` is written); 2 on bad input (one line): a policy that
does not load, a baseline trained for another environment or ``fps`` or of other input
or output sizes, an action of the wrong shape, an unknown option, ``--episodes`` below 1,
seeds past 2³²−1, an ``--out`` that is the policy's file or the config, an ``--out`` or
video that exists (without ``--force``), a ``videos`` that is not a folder.
SIGTERM and SIGHUP stop it as Ctrl-C does (exit 143, 129; Ctrl-C 130), workers and all.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from mearm import interrupts
from mearm.cli import (
    ArgumentParser,
    check_output_file,
    check_output_folder,
    invoked_as,
    plain_float,
    plain_int,
    refuse_to_replace,
    run,
    seed_value,
    worker_count,
    write_text_atomic,
)
from mearm.errors import MearmError

if TYPE_CHECKING:  # Gymnasium is imported once the command has checked it is installed
    from mearm.envs.evaluate import EpisodeResult, Job

#: Options the evaluation sets itself.
OWN_OPTIONS = ("expert", "render_mode", "task")
#: Options of the environments that a flag of the command gives: ``--env-option`` refuses
#: them, naming the flag (``config=`` replaced ``--config`` silently, and the totals line
#: and the check of ``--out`` against the config went on naming ``--config``'s).
FLAG_OPTIONS = {"config": "--config"}


def env_options(pairs: Sequence[str]) -> dict[str, Any]:
    """``key=value`` strings as the environment's keyword arguments (values in YAML).

    Raises:
        EnvOptionError: not ``key=value``, or a key the environments do not take.
    """
    from mearm.envs.errors import EnvOptionError  # noqa: PLC0415
    from mearm.envs.twin_env import options_taken  # noqa: PLC0415

    known = [k for k in options_taken() if k not in (*OWN_OPTIONS, *FLAG_OPTIONS)]
    known += ["max_episode_steps"]
    out: dict[str, Any] = {}
    for pair in pairs:
        key, sep, text = pair.partition("=")
        if not sep or not key:
            raise EnvOptionError(f"--env-option {pair!r}: give key=value")
        if key in FLAG_OPTIONS:
            raise EnvOptionError(f"--env-option {key}: give {FLAG_OPTIONS[key]} instead")
        if key not in known:
            raise EnvOptionError(
                f"--env-option {key}: not an option of the environments; they take "
                + ", ".join(known)
            )
        try:
            out[key] = yaml.safe_load(text)
        except yaml.YAMLError:
            raise EnvOptionError(f"--env-option {pair!r}: the value is not YAML") from None
        if key == "image_size" and isinstance(out[key], list):
            out[key] = tuple(out[key])
        if key == "max_episode_steps":
            _check_max_episode_steps(out[key])
    return out


def _check_max_episode_steps(value: object) -> None:
    """Refuse a step limit that is not a whole number ≥ 1 (``null``: the environment's).

    Gymnasium's own check took 0 and -3 for a crash ("unexpected error", exit 1) and
    ``true`` for one step.

    Raises:
        EnvOptionError: a bool, not a whole number, or below 1.
    """
    from mearm.envs.errors import EnvOptionError  # noqa: PLC0415

    if value is None:
        return
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise EnvOptionError(
            f"--env-option max_episode_steps must be a whole number of at least 1, got {value!r}"
        )


def _require_gymnasium() -> None:
    """Refuse, in one line, to run without the ``gym`` extra."""
    try:
        import gymnasium  # noqa: F401, PLC0415
    except ImportError:
        raise MearmError(
            "mearm eval-policy needs Gymnasium, which is not installed: pip install 'mearm[gym]'"
        ) from None


def module_file(name: str) -> Path | None:
    """The file the module called ``name`` would be imported from, or ``None``."""
    import importlib.util  # noqa: PLC0415

    try:
        spec = importlib.util.find_spec(name)
    except (ImportError, ValueError):  # not importable: said when the policy loads
        return None
    if spec is None or spec.origin is None or not Path(spec.origin).is_file():
        return None
    return Path(spec.origin).resolve()


def _refuse_an_input_as_out(out: Path, policy: str, config: str) -> None:
    """Refuse an ``--out`` that is the policy's file or the config: the scores would replace it.

    Raises:
        MearmError: ``out`` is one of them (through links and ``./`` alike).
    """
    from mearm.config.files import resolve_config_path  # noqa: PLC0415

    target = out.resolve()
    if Path(policy).resolve() == target:
        raise MearmError(f"--out {out} is the --policy file: write the scores elsewhere")
    module_name, sep, _ = policy.partition(":")
    if sep and module_name and module_file(module_name) == target:
        raise MearmError(
            f"--out {out} is the source of --policy {policy}: write the scores elsewhere"
        )
    try:
        config_file = resolve_config_path(config).resolve()
    except MearmError:  # an unknown name: said when the environment loads it
        return
    if config_file == target:
        raise MearmError(f"--out {out} is the --config file: write the scores elsewhere")


def _check_baseline_fits(path: Path, env_id: str, options: dict[str, Any]) -> None:
    """Refuse a baseline trained for another environment, before any episode runs.

    By the environment it names, by the steps per second it was trained at (its clock
    input counts steps, and each action is held one step: at another ``fps`` it ran,
    and failed, on a clock that meant another time), then by the sizes of its input and
    output against this environment's observation and action (another arm, another
    number of objects): each episode would otherwise end on a shape error and the run
    report 0 %.

    Raises:
        PolicyError: another environment or ``fps``, or sizes that do not match.
        EnvOptionError: an option of the wrong type for the environment.
    """
    import gymnasium as gym  # noqa: PLC0415

    import mearm.envs  # noqa: F401, PLC0415  (registers the environments)
    from mearm.envs.errors import EnvOptionError, PolicyError  # noqa: PLC0415
    from mearm.learn.baseline import load_baseline  # noqa: PLC0415

    policy = load_baseline(path)
    trained_on = policy.meta.get("env_id")
    if trained_on is not None and trained_on != env_id:
        raise PolicyError(
            f"policy {path} was trained on {trained_on}, not {env_id}: its "
            f"observations and actions are another environment's (give --env {trained_on})"
        )
    try:
        probe = gym.make(env_id, **{**options, "obs_type": "state"})
    except TypeError as exc:
        raise EnvOptionError(f"--env-option: {exc}") from None
    try:
        observed = probe.observation_space
        assert isinstance(observed, gym.spaces.Dict)
        n_in = 1  # the clock
        for key in ("agent_pos", "environment_state"):
            n_in += math.prod(observed[key].shape or ())
        n_out = math.prod(probe.action_space.shape or ())
        fps = int(probe.metadata["render_fps"])
        rate = float(probe.unwrapped.base_config.servo.rate_hz)  # type: ignore[attr-defined]
    finally:
        probe.close()
    trained_fps = policy.meta.get("fps")  # None: a baseline saved before it was kept
    if trained_fps is not None and trained_fps != fps:
        divides = trained_fps > 0 and abs(rate / trained_fps - round(rate / trained_fps)) < 1e-9
        fix = (  # fps must divide the servos' rate: only then is the option a way out
            f"give --env-option fps={trained_fps}, or the servo.rate_hz it was trained at"
            if divides
            else f"it must divide servo.rate_hz = {rate:g} Hz: give the servo.rate_hz it "
            f"was trained at (--env-option 'overrides=[servo.rate_hz=...]')"
        )
        raise PolicyError(
            f"policy {path} was trained at {trained_fps} steps per second and {env_id} here "
            f"steps at {fps}: its clock and each action's hold would be another time ({fix})"
        )
    takes, gives = int(policy.mean.shape[0]), int(policy.scaling.shape[1])
    if (takes, gives) != (n_in, n_out):
        options_then = policy.meta.get("env_options", {})
        trained = ", ".join(f"{k}={v}" for k, v in options_then.items()) or "options unknown"
        raise PolicyError(
            f"policy {path} takes {takes} inputs and gives {gives} actions, but {env_id} here "
            f"gives {n_in} (agent_pos, environment_state and the clock) and takes {n_out}: it "
            f"was trained for another arm or number of objects (with {trained})"
        )


def _check_videos(folder: Path, first_seed: int, k: int, *, force: bool) -> None:
    """Refuse, before any episode, a ``videos`` that is not a folder or videos that exist.

    Raises:
        MearmError: ``folder`` is a file (it crashed on FileExistsError after the first
            episode), or one of the K videos exists and ``force`` is false.
    """
    from mearm.envs.evaluate import video_name  # noqa: PLC0415

    if folder.exists() and not folder.is_dir():
        raise MearmError(
            f"--videos: {folder} is a file, not a folder; the videos go into a folder of that "
            "name (beside --out, else here): move the file or give --out elsewhere"
        )
    check_output_folder(folder, "--videos")
    for i in range(k):
        path = folder / video_name(i, first_seed + i)
        check_output_file(path, "--videos")
        refuse_to_replace(path, "--videos", force)


def _check_outputs(args: argparse.Namespace) -> str | None:
    """Refuse, before any episode, an ``--out`` or videos that cannot or may not be written.

    Returns:
        The videos' folder (``--videos``), else ``None``.

    Raises:
        MearmError: one of them, named.
    """
    if args.out is not None:
        check_output_file(args.out, "--out")
        _refuse_an_input_as_out(args.out, args.policy, args.config)
        refuse_to_replace(args.out, "--out", args.force)
    if not args.videos:
        return None
    folder = (args.out.parent if args.out else Path(".")) / "videos"
    _check_videos(folder, args.first_seed, args.videos, force=args.force)
    return str(folder)


class _VideosWritten:
    """The videos a run may write, to name those a stop kept it from naming.

    A worker writes its episode's video before the parent reports the episode, in seed
    order: an episode that ended, and wrote its video, while an earlier one still ran was
    never reported when Ctrl-C or SIGTERM stopped the run, and its video stayed unnamed.
    A file is known as written by this run from its identity before the run (none, or
    another file: ``--force`` replaced it).
    """

    def __init__(self, folder: str | None, seeds: Sequence[int]):
        from mearm.envs.evaluate import video_name  # noqa: PLC0415

        self.paths = (
            [str(Path(folder) / video_name(i, seed)) for i, seed in enumerate(seeds)]
            if folder is not None
            else []
        )
        self.before = {path: self._identity(path) for path in self.paths}
        #: The videos named on stdout so far.
        self.named: set[str] = set()

    @staticmethod
    def _identity(path: str) -> tuple[int, int, int] | None:
        try:
            st = os.stat(path)
        except OSError:
            return None
        return st.st_dev, st.st_ino, st.st_mtime_ns

    def unnamed(self) -> list[str]:
        """The videos this run wrote and did not name, in seed order."""
        return [
            path
            for path in self.paths
            if path not in self.named
            and (now := self._identity(path)) is not None
            and now != self.before[path]
        ]


def _run_and_print(args: argparse.Namespace, job: Job, seeds: Sequence[int]) -> list[EpisodeResult]:
    """Run the episodes, printing a line per episode (and its video) as it ends.

    Stopped (Ctrl-C, SIGTERM, SIGHUP), it names the videos its workers wrote that no line
    named yet (:class:`_VideosWritten`) before the stop goes on.

    Raises:
        EnvOptionError: an option of the wrong type for the environment.
    """
    from mearm.envs.errors import EnvOptionError  # noqa: PLC0415
    from mearm.envs.evaluate import run_episodes  # noqa: PLC0415

    results = []
    videos = _VideosWritten(job.video_dir, seeds[: args.videos])
    try:
        episodes = contextlib.closing(run_episodes(job, seeds, args.jobs))
        with episodes as each:  # left early (a signal while printing): the pool stops too
            for k, result in enumerate(each, 1):
                results.append(result)
                outcome = "success" if result.success else "failure"
                why = f"; {result.error}" if result.error else ""
                print(
                    f"episode {k:3d}/{args.episodes} seed {result.seed}: {outcome}, "
                    f"{result.in_bins}/{result.objects} in their bins, return "
                    f"{result.sum_reward:g}, {result.steps} steps{why}",
                    flush=True,
                )
                if result.video:  # written by the time its episode is reported
                    print(f"wrote {result.video}", flush=True)
                    videos.named.add(result.video)
    except TypeError as exc:  # an option of the wrong type for the environment
        raise EnvOptionError(f"--env-option: {exc}") from None
    except KeyboardInterrupt:  # the pool is shut down: every video its workers wrote is there
        for path in videos.unnamed():
            print(f"wrote {path}", flush=True)
        raise
    return results


def main(argv: Sequence[str] | None = None) -> int:
    """Run the episodes; print and write the scores; 1 below ``--require`` or on an error.

    SIGTERM and SIGHUP stop it as Ctrl-C does: the workers end their episodes and the
    pool is shut down (a SIGTERM used to end this process alone, and its workers ran on).
    """
    with interrupts.stop_signals_as_ctrl_c():
        return _eval_policy(argv)


def _eval_policy(argv: Sequence[str] | None) -> int:
    parser = ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="mearm/PickPlace-v0", help="environment id")
    parser.add_argument(
        "--policy", default="expert", help="expert, random, module:callable, FILE.pt"
    )
    parser.add_argument("--config", default="sim_mujoco", help="twin config (name or file)")
    parser.add_argument("--episodes", type=plain_int, default=50, help="episodes, seeds S … S+N−1")
    parser.add_argument("--first-seed", type=seed_value, default=0, help="S (default 0)")
    parser.add_argument(
        "--jobs", type=worker_count, default=2,
        help=f"worker processes (default 2; {os.cpu_count()} CPUs here); 1 runs here",
    )  # fmt: skip
    parser.add_argument("--env-option", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--out", type=Path, default=None, help="write the scores as JSON")
    parser.add_argument(
        "--videos", type=plain_int, default=0, metavar="K",
        help="write the first K episodes as MP4s into videos/ beside --out (without --out: "
        "./videos/); an episode_*.mp4 of the same name is refused unless --force",
    )  # fmt: skip
    parser.add_argument(
        "--force", action="store_true",
        help="replace an existing --out and the videos of the same names",
    )  # fmt: skip
    parser.add_argument(
        "--require", type=plain_float, default=0.0, help="exit 1 below this success share"
    )
    args = parser.parse_args(argv)
    _require_gymnasium()
    from mearm.envs import MAX_EPISODE_STEPS  # noqa: PLC0415
    from mearm.envs.evaluate import Job, check_seed_range, summary  # noqa: PLC0415

    if args.episodes < 1:
        raise MearmError(f"--episodes must be at least 1, got {args.episodes}")
    check_seed_range(args.first_seed, args.episodes)  # before any episode runs
    if not 0 <= args.videos <= args.episodes:
        raise MearmError(f"--videos must be in [0, --episodes], got {args.videos}")
    if not 0 <= args.require <= 1:
        raise MearmError(f"--require is a share in [0, 1], got {args.require}")
    if args.env not in MAX_EPISODE_STEPS:  # the environments mearm.envs registers
        raise MearmError(f"--env must be {' or '.join(MAX_EPISODE_STEPS)}, got {args.env!r}")
    video_dir = _check_outputs(args)
    options = {"config": args.config, **env_options(args.env_option)}
    if args.policy.endswith(".pt"):  # a baseline knows its environment: say so before running
        _check_baseline_fits(Path(args.policy), args.env, options)
    job = Job(args.env, options, args.policy, video_dir, args.videos)
    seeds = range(args.first_seed, args.first_seed + args.episodes)
    t0 = time.perf_counter()
    results = _run_and_print(args, job, seeds)
    scores = summary(results)
    wall = time.perf_counter() - t0
    failed = [r for r in results if r.error]
    if args.out is not None:
        record = {
            "env": args.env,
            "env_options": options,
            "policy": args.policy,
            "first_seed": args.first_seed,
            "simulated": True,
            **scores,
        }
        write_text_atomic(args.out, json.dumps(record, indent=2) + "\n")
        print(f"wrote {args.out}")
    # the totals last: the line that says whether the policy passed
    print(
        f"{args.policy} on {args.env} ({args.config}, simulated): success "
        f"{scores['pc_success']:.1f} % of {len(results)} episodes, mean return "
        f"{scores['avg_sum_reward']:.2f}, in {wall:.0f} s"
    )
    prog = invoked_as("python -m mearm.tools.eval_policy")
    if len(failed) == len(results):  # nothing was scored: not a 0 % policy, a broken run
        print(
            f"{prog}: every episode ended on an error, so the policy was not scored (the "
            f"first: {failed[0].error})",
            file=sys.stderr,
        )
        return 1
    if failed:  # the others are scored, but the run did not score what it was asked to
        print(
            f"{prog}: {len(failed)} of {len(results)} episodes ended on an error (the first, "
            f"seed {failed[0].seed}: {failed[0].error})",
            file=sys.stderr,
        )
        return 1
    if scores["pc_success"] < 100 * args.require:  # the run's job: the share it was asked for
        print(
            f"{prog}: success {scores['pc_success']:.1f} % is below --require "
            f"{args.require:g} ({100 * args.require:g} %)",
            file=sys.stderr,
        )
        return 1
    return 0


if __name__ == "__main__":
    run(main)
