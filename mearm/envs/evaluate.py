"""Run a policy over seeded episodes, in worker processes, and score it as lerobot-eval does.

Each episode is one environment reset with its seed (``first_seed`` … + N − 1) and run
until it succeeds, fails or reaches ``max_episode_steps``. ``jobs`` workers each make the
environment and the policy once and take seeds; the records come back in seed order,
whatever the number of workers. A policy that raises, or gives an action that is not
finite (NaN after 50 good steps), ends its episode as a failure that names the error, and
the next episode runs (as does one whose ``reset()`` raises); an action that is not
numbers or of the wrong shape stops the whole run
(:class:`~mearm.envs.errors.PolicyError`: the policy is wired wrong).

Stopping: when the pool is shut down before its work is done (Ctrl-C, SIGTERM or SIGHUP
in the parent, which takes them as Ctrl-C; an error), the workers end the episodes they
run at their next step, write no video of them and take no more (:class:`_Pool`); a
worker that gets one of those signals itself does the same.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.connection
import os
import signal
import threading
from collections.abc import Callable, Generator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from mearm import interrupts
from mearm.cli import ordered_results
from mearm.config.base import MAX_SEED
from mearm.envs.policies import Policy, checked_action, load_policy, not_finite
from mearm.errors import MearmError

#: The encoding of ``--videos`` (a key of :data:`mearm.dataset.lerobot_format.VIDEO_CODECS`):
#: H.264, as ``lerobot-eval`` writes its videos.
EVAL_VIDEO_CODEC = "h264"


@dataclass(frozen=True)
class EpisodeResult:
    """One episode's outcome.

    Attributes:
        seed: Its seed.
        success: Whether every object ended in its bin.
        sum_reward: Its return (objects put in their bins, less any taken out).
        max_reward: The largest reward of a step.
        steps: Steps taken.
        in_bins: Objects in their bins at the end, of ``objects``.
        objects: Objects in the scene.
        error: Why it failed besides the task: the policy raised (named) or gave an
            action that is not finite, or a fault.
        video: The video written of it, or ``""``.
    """

    seed: int
    success: bool
    sum_reward: float
    max_reward: float
    steps: int
    in_bins: int
    objects: int
    error: str = ""
    video: str = ""


@dataclass(frozen=True)
class Job:
    """What every worker runs: an environment, its options, a policy."""

    env_id: str
    env_options: dict[str, Any]
    policy: str
    video_dir: str | None = None
    videos: int = 0


def video_name(index: int, seed: int) -> str:
    """The file name of the video of the ``index``-th episode, of ``seed``."""
    return f"episode_{index:03d}_seed_{seed}.mp4"


def check_seed_range(first_seed: int, episodes: int) -> None:
    """Refuse seeds ``first_seed`` … + ``episodes`` − 1 that run past the last seed.

    Checked before any episode runs: the first episode out of range stopped the run
    after the others had run (exit 2, and eval-policy wrote no ``--out``, bc no
    ``--demos``).

    Raises:
        MearmError: the last seed is beyond :data:`~mearm.config.base.MAX_SEED`.
    """
    last = first_seed + episodes - 1
    if last > MAX_SEED:
        raise MearmError(
            f"--first-seed {first_seed} and --episodes {episodes} run to seed {last}, past "
            f"the last seed, {MAX_SEED}: give a --first-seed of at most {MAX_SEED - episodes + 1}"
        )


def summary(results: Sequence[EpisodeResult]) -> dict[str, Any]:
    """lerobot-eval's aggregates: ``pc_success`` [%], ``avg_sum_reward``, ``avg_max_reward``."""
    n = len(results)
    return {
        "pc_success": 100.0 * sum(r.success for r in results) / n,
        "avg_sum_reward": float(np.mean([r.sum_reward for r in results])),
        "avg_max_reward": float(np.mean([r.max_reward for r in results])),
        "n_episodes": n,
        "per_episode": [asdict(r) for r in results],
    }


class Runner:
    """One environment and one policy, running episodes one after another."""

    def __init__(self, job: Job):
        import mearm.envs  # noqa: F401, PLC0415  (registers the environments)

        self.job = job
        options = dict(job.env_options)
        probe = gym.make(job.env_id, **{**options, "obs_type": "state"})
        space = probe.action_space
        probe.close()
        assert isinstance(space, gym.spaces.Box)
        self.space = space
        self.policy: Policy = load_policy(job.policy, space)
        options["expert"] = self.policy.needs_expert
        if job.videos:
            options["render_mode"] = "rgb_array"
        self.env = gym.make(job.env_id, **options)
        #: Whether to stop now (a worker's: its pool is shut down, or it got a stop signal).
        self.should_stop: Callable[[], bool] = lambda: False

    def episode(self, seed: int, index: int) -> EpisodeResult:
        """Run the episode of ``seed`` (``index``: its place, for the video's name).

        Raises:
            PolicyError: an action that is not numbers or not the action's shape.
            KeyboardInterrupt: :attr:`should_stop` said so (no video is written).
        """
        env, policy = self.env, self.policy
        obs, info = env.reset(seed=seed)
        frames: list[np.ndarray] | None = [] if index < self.job.videos else None
        total, best, steps, error = 0.0, -np.inf, 0, ""
        try:  # a user's reset() (one that wants a seed, or raises) fails as its act() does
            policy.reset(seed)
        except Exception as exc:
            error = f"the policy's reset() raised {type(exc).__name__}: {exc}"
        done = bool(error)
        while not done:
            if self.should_stop():
                raise KeyboardInterrupt("stopped")
            if frames is not None:
                frames.append(env.render())  # type: ignore[arg-type]
            try:
                raw = policy.act(obs, info)
            except Exception as exc:
                error = f"the policy raised {type(exc).__name__}: {exc}"
                break
            action = checked_action(raw, self.space)
            error = not_finite(action)
            if error:
                break
            obs, reward, terminated, truncated, info = env.step(action)
            total += float(reward)
            best = max(best, float(reward))
            steps += 1
            done = terminated or truncated
            if info.get("fault"):
                error = f"fault: {info['fault']}"
        if frames and done:  # the end it reached, as lerobot-eval renders after each step
            frames.append(env.render())  # type: ignore[arg-type]
        video = ""
        if frames and self.job.video_dir is not None:
            video = str(Path(self.job.video_dir) / video_name(index, seed))
            write_video(Path(video), frames, int(env.metadata["render_fps"]))
        return EpisodeResult(
            seed,
            bool(info["is_success"]) and not error,
            total,
            0.0 if steps == 0 else best,
            steps,
            int(info["in_bins"]),
            int(info["objects"]),
            " ".join(error.split()),  # one line, whatever the policy's message held
            video,
        )

    def close(self) -> None:  # noqa: D102
        self.env.close()


def write_video(path: Path, frames: Sequence[np.ndarray], fps: int) -> None:
    """Frames (H, W, 3) RGB as an H.264 MP4 (PyAV, of ``mearm[record]``), in one step.

    H.264 as ``lerobot-eval`` writes its videos (libx264, yuv420p), at the settings of
    ``--record-codec h264`` (:data:`~mearm.dataset.lerobot_format.VIDEO_CODECS`: one
    thread, a worker's core each). Not SVT-AV1 at its defaults, as before: run as root
    under load, the encode now and then blocked in ``svt_av1_enc_get_packet`` for good,
    and with it the worker and a parent stopping its pool. The likely cause, found later,
    is the realtime policy SVT-AV1 gives its threads as root, which the recorder now
    undoes (:func:`~mearm.dataset.encoder_server.scheduling_kept`); the evaluation's
    videos stay H.264, the format ``lerobot-eval`` writes. Written beside
    ``path`` and renamed onto it once whole: a signal or a full disk leaves the file that
    was there (``--force``) and no half video.
    """
    from mearm.dataset import lerobot_format as L  # noqa: PLC0415
    from mearm.dataset.recorder import import_extra  # noqa: PLC0415

    av = import_extra()[2]
    spec = L.VIDEO_CODECS[EVAL_VIDEO_CODEC]
    path.parent.mkdir(parents=True, exist_ok=True)
    part = path.with_name(f".{path.name}.{os.getpid()}.part")
    try:
        with av.open(str(part), "w", format="mp4") as out:
            stream = out.add_stream(spec.encoder, rate=fps, options=spec.options())
            stream.height, stream.width = frames[0].shape[:2]
            stream.pix_fmt = L.VIDEO_PIX_FMT
            for k, rgb in enumerate(frames):
                frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(rgb), format="rgb24")
                frame.pts = k
                for packet in stream.encode(frame):
                    out.mux(packet)
            for packet in stream.encode():
                out.mux(packet)
        os.replace(part, path)
    except BaseException:
        part.unlink(missing_ok=True)
        raise


#: The worker's runner, made once by :func:`_start_worker`.
_RUNNER: Runner | None = None
#: Set by the parent when it shuts the pool down (:class:`_Pool`).
_STOP: Any = None
#: Whether this worker got Ctrl-C, SIGTERM or SIGHUP, or its parent is gone.
_SIGNALLED = False
#: Whether its parent is gone (killed outright): the worker ends after the episode it runs.
_ORPHANED = False
#: Whether this worker runs an episode now.
_BUSY = False
#: How often a worker checks that its parent is still there [s].
PARENT_POLL_S = 0.2
#: The signals a worker takes as "stop" (and the parent defers while it starts them).
_WORKER_SIGNALS = (signal.SIGINT, *interrupts.STOP_SIGNALS)


def _on_stop_signal(signum: int, frame: object) -> None:
    """A worker's Ctrl-C, SIGTERM or SIGHUP: stop at the next step (no traceback here)."""
    global _SIGNALLED
    _SIGNALLED = True


def _stopped() -> bool:
    return _SIGNALLED or (_STOP is not None and _STOP.is_set())


def _watch_parent(sentinel: int, parent: int) -> None:
    """End this worker once its parent (``parent``: its id) has gone, whatever ended it.

    An idle worker waits for work that will never come: it ends at once; a busy one ends
    its episode at the next step, writes no video of it, and ends (:func:`_in_worker`).

    The sentinel alone is not enough: with ``fork``, a worker started later inherits the
    parent's end of an earlier worker's sentinel pipe, so the earlier one saw its parent
    die only once every later sibling had ended (and never, beside a stuck one). The
    parent's process id is watched too: an orphan is given to another parent. The id is
    the one the parent recorded before it forked, not this worker's ``getppid()`` when
    the watch starts: a parent killed before that (a loaded machine can keep a new
    worker waiting that long) had already given the worker to another parent, whose id
    never changed after.
    """
    global _SIGNALLED, _ORPHANED
    while not multiprocessing.connection.wait([sentinel], timeout=PARENT_POLL_S):
        if os.getppid() != parent:
            break
    _SIGNALLED = _ORPHANED = True
    if not _BUSY:
        os._exit(1)


def _start_worker(job: Job, stop: Any) -> None:
    """A worker's setup: its stop signals only note the stop; its runner, made once.

    With ``fork`` the worker would otherwise keep the parent's handlers (SIGTERM raising
    wherever it waits, with a traceback of its own) or die of the signal mid-video. The
    parent started it with those signals blocked (:meth:`_Pool.submit`): one sent since
    arrives here, once the handler is in place.
    """
    global _RUNNER, _STOP
    _STOP = stop
    for sig in _WORKER_SIGNALS:
        if signal.getsignal(sig) is not signal.SIG_IGN:  # under nohup: stays ignored
            signal.signal(sig, _on_stop_signal)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _WORKER_SIGNALS)
    parent = multiprocessing.parent_process()
    if parent is not None:
        watch = (parent.sentinel, parent.pid)
        threading.Thread(target=_watch_parent, args=watch, daemon=True).start()
    _RUNNER = Runner(job)
    _RUNNER.should_stop = _stopped


def _in_worker(seed: int, index: int) -> EpisodeResult:
    global _BUSY
    assert _RUNNER is not None, "_start_worker was not run"
    _BUSY = True
    try:
        if _stopped():
            raise KeyboardInterrupt("stopped")
        return _RUNNER.episode(seed, index)
    finally:
        _BUSY = False
        if _ORPHANED:  # no one takes the result
            os._exit(1)


class _Pool(ProcessPoolExecutor):
    """The workers, told to stop when the pool is shut down.

    :func:`~mearm.cli.ordered_results` shuts the pool down, waiting for the workers,
    when the parent leaves early (Ctrl-C, or SIGTERM taken as Ctrl-C): the workers then
    end their episodes at the next step instead of running them out, so none outlives
    the parent (a SIGTERM used to end the parent alone, and a worker went on to write a
    video after it had gone).
    """

    def __init__(self, workers: int, job: Job):
        context = multiprocessing.get_context()
        self._stop = context.Event()
        super().__init__(
            max_workers=workers, mp_context=context, initializer=_start_worker,
            initargs=(job, self._stop),
        )  # fmt: skip

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        """Submit with Ctrl-C, SIGTERM and SIGHUP held back until it returns.

        The first submit starts the workers; a Ctrl-C raised inside it (between forking
        them and starting the thread that manages them) left a pool that its shutdown
        could not stop, and the parent waited at exit for workers that waited for work.
        """
        if not hasattr(signal, "pthread_sigmask"):
            return super().submit(fn, *args, **kwargs)
        held = signal.pthread_sigmask(signal.SIG_BLOCK, _WORKER_SIGNALS)
        try:
            return super().submit(fn, *args, **kwargs)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, held)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:  # noqa: FBT001, FBT002 - Executor's
        """Tell the workers to stop, and shut the pool down whole: a Ctrl-C is taken after.

        A second Ctrl-C (or SIGTERM) while the pool waited for its workers to end their
        episodes cut the shutdown in two: the workers were never told to end, and the
        parent, after "interrupted", waited at exit for them forever (two SIGINTs 10 ms
        apart, as ``timeout -s INT`` sends one to the command and one to its group).
        """
        with interrupts.signals_deferred():
            self._stop.set()  # the work is done, or given up: either way, nothing more to run
            super().shutdown(wait=wait, cancel_futures=cancel_futures)


def run_episodes(job: Job, seeds: Sequence[int], jobs: int) -> Generator[EpisodeResult]:
    """Each seed's result, in the order of ``seeds``, from ``jobs`` workers (1: here).

    Raises:
        PolicyError: the policy does not load, or gave an action the environment cannot
            take (the run stops).
    """
    if jobs == 1:
        runner = Runner(job)
        try:
            for i, seed in enumerate(seeds):
                yield runner.episode(seed, i)
        finally:
            runner.close()
        return
    Runner(Job(job.env_id, job.env_options, job.policy)).close()  # bad input: here, at once
    pool = _Pool(min(jobs, len(seeds)), job)
    yield from ordered_results(pool, _in_worker, ((s, i) for i, s in enumerate(seeds)))
