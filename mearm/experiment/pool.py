"""Where trials run: the :class:`Workers` interface, and worker processes on this machine.

Each worker process keeps its settings and its Ctrl-C state in one :class:`WorkerProcess`
(one per process, set up by the pool's initializer): after Ctrl-C it interrupts the
trial it runs and starts no more. A worker whose parent is gone (``kill -9`` of the
command) interrupts its trial as Ctrl-C does and ends
(:func:`mearm.interrupts.end_when_orphaned`): it would otherwise wait for work forever.
"""

from __future__ import annotations

import os
import signal
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from mearm import interrupts
from mearm.config import Config, SceneObject
from mearm.experiment.trials import Recording, TrialResult, run_trial


@dataclass
class Workers:
    """Somewhere that runs trials: :meth:`submit` trial k, get a future of its result.

    Attributes:
        submit: Starts trial k; returns a future (``result()``, ``done()``, ``cancel()``).
        lost: The exceptions a future raises when the worker running it died.
        count: How many trials run at once.
        where: Says where they run, after ``count`` in the line after the run (``2 workers``).
    """

    submit: Callable[[int], Any]
    lost: tuple[type[BaseException], ...]
    count: int
    where: str


@dataclass
class WorkerProcess:
    """One worker process's settings and Ctrl-C state.

    Attributes:
        work: (config, seed, scene, recording), set once by :meth:`start`.
        stopped: This worker has seen Ctrl-C (trials handed to it after that are not run).
        running: It is running a trial (Ctrl-C then interrupts it).
    """

    work: tuple[Config, int, list[SceneObject] | None, Recording | None] | None = None
    stopped: bool = False
    running: bool = False

    def start(
        self,
        config: Config,
        seed: int,
        scene: list[SceneObject] | None,
        recording: Recording | None,
    ) -> None:
        """The one-time setup: the experiment's settings once; Ctrl-C only stops trials."""
        signal.signal(signal.SIGINT, self.on_interrupt)
        self.work = (config, seed, scene, recording)

    def on_interrupt(self, signum: int, frame: object) -> None:
        """Ctrl-C: run no more trials, and interrupt the one running."""
        self.stopped = True
        if self.running:
            raise KeyboardInterrupt

    def set_running(self, running: bool) -> None:  # noqa: FBT001 - run_trial's hook
        """Whether a trial runs now (passed to :func:`run_trial`)."""
        self.running = running

    def run(self, number: int) -> TrialResult:
        """Run trial ``number`` (:func:`run_trial`), unless Ctrl-C was seen."""
        assert self.work is not None, "_start_worker was not run"
        if self.stopped:
            return TrialResult(number, ran=False)
        config, seed, scene, recording = self.work
        return run_trial(config, seed, scene, number, recording, running=self.set_running)


#: This process's worker state (used only in the pool's worker processes).
_WORKER = WorkerProcess()


def _start_worker(
    config: Config,
    seed: int,
    scene: list[SceneObject] | None,
    recording: Recording | None,
    parent: int,
) -> None:
    _WORKER.start(config, seed, scene, recording)
    interrupts.end_when_orphaned(parent, busy=lambda: _WORKER.running)


def _trial_in_worker(number: int) -> TrialResult:
    return _WORKER.run(number)


@contextmanager
def process_pool(
    config: Config,
    seed: int,
    scene: list[SceneObject] | None,
    jobs: int,
    recording: Recording | None = None,
) -> Iterator[Workers]:
    """``jobs`` worker processes on this machine; closed (waiting for them) on the way out."""
    pool = ProcessPoolExecutor(
        max_workers=jobs,
        initializer=_start_worker,
        initargs=(config, seed, scene, recording, os.getpid()),
    )
    try:
        yield Workers(
            lambda k: pool.submit(_trial_in_worker, k),
            (BrokenProcessPool,),
            jobs,
            "worker" if jobs == 1 else "workers",
        )
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
