"""Run a policy over seeded episodes, in worker processes, and score it as lerobot-eval does.

Each episode is one environment reset with its seed (``first_seed`` … + N − 1) and run
until it succeeds, fails or reaches ``max_episode_steps``. ``jobs`` workers each make the
environment and the policy once and take seeds; the records come back in seed order,
whatever the number of workers. A policy that raises ends its episode as a failure that
names the error; an action of the wrong shape or not finite stops the whole run
(:class:`~mearm.envs.errors.PolicyError`: the policy is wrong, not the episode).
"""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from mearm.cli import ordered_results
from mearm.envs.policies import Policy, checked_action, load_policy


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
        error: Why it failed besides the task: the policy raised (named), or a fault.
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

    def episode(self, seed: int, index: int) -> EpisodeResult:
        """Run the episode of ``seed`` (``index``: its place, for the video's name)."""
        env, policy = self.env, self.policy
        obs, info = env.reset(seed=seed)
        policy.reset(seed)
        frames: list[np.ndarray] | None = [] if index < self.job.videos else None
        total, best, steps, error = 0.0, -np.inf, 0, ""
        done = False
        while not done:
            if frames is not None:
                frames.append(env.render())  # type: ignore[arg-type]
            try:
                raw = policy.act(obs, info)
            except Exception as exc:
                error = f"the policy raised {type(exc).__name__}: {exc}"
                break
            obs, reward, terminated, truncated, info = env.step(checked_action(raw, self.space))
            total += float(reward)
            best = max(best, float(reward))
            steps += 1
            done = terminated or truncated
            if info.get("fault"):
                error = f"fault: {info['fault']}"
        video = ""
        if frames and self.job.video_dir is not None:
            video = str(Path(self.job.video_dir) / f"episode_{index:03d}_seed_{seed}.mp4")
            write_video(Path(video), frames, int(env.metadata["render_fps"]))
        return EpisodeResult(
            seed,
            bool(info["is_success"]) and not error,
            total,
            0.0 if steps == 0 else best,
            steps,
            int(info["in_bins"]),
            int(info["objects"]),
            error,
            video,
        )

    def close(self) -> None:  # noqa: D102
        self.env.close()


def write_video(path: Path, frames: Sequence[np.ndarray], fps: int) -> None:
    """Frames (H, W, 3) RGB as an AV1 MP4 (PyAV, of ``mearm[record]``)."""
    from mearm.dataset import lerobot_format as L  # noqa: PLC0415
    from mearm.dataset.recorder import import_extra  # noqa: PLC0415

    av = import_extra()[2]
    os.environ.setdefault("SVT_LOG", "1")  # SVT-AV1: errors only, not its banner
    path.parent.mkdir(parents=True, exist_ok=True)
    with av.open(str(path), "w") as out:
        stream = out.add_stream(L.VIDEO_CODEC, rate=fps, options={"crf": str(L.VIDEO_CRF)})
        stream.height, stream.width = frames[0].shape[:2]
        stream.pix_fmt = L.VIDEO_PIX_FMT
        for k, rgb in enumerate(frames):
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(rgb), format="rgb24")
            frame.pts = k
            for packet in stream.encode(frame):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)


#: The worker's runner, made once by :func:`_start_worker`.
_RUNNER: Runner | None = None


def _start_worker(job: Job) -> None:
    global _RUNNER
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent cancels; no worker tracebacks
    _RUNNER = Runner(job)


def _in_worker(seed: int, index: int) -> EpisodeResult:
    assert _RUNNER is not None, "_start_worker was not run"
    return _RUNNER.episode(seed, index)


def run_episodes(job: Job, seeds: Sequence[int], jobs: int) -> Iterator[EpisodeResult]:
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
    pool = ProcessPoolExecutor(
        max_workers=min(jobs, len(seeds)), initializer=_start_worker, initargs=(job,)
    )
    yield from ordered_results(pool, _in_worker, ((s, i) for i, s in enumerate(seeds)))
