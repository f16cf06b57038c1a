"""Trials run by workers, appended to the run log in trial order as they finish.

Whichever worker finishes first, the log gets the records the serial run writes, in the
same order; Ctrl-C, a failed trial or a lost worker cancels what has not started and
keeps every trial finished in order, so the log resumes. A trial Ctrl-C interrupted is
the last one appended, as in the serial run: the log resumes by running it again.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import CancelledError
from contextlib import AbstractContextManager, contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

from mearm import interrupts
from mearm.config import Config, SceneObject
from mearm.errors import MearmError
from mearm.experiment.cluster import dask_cluster
from mearm.experiment.errors import TrialFailed, one_line
from mearm.experiment.pool import Workers, process_pool
from mearm.experiment.trials import Recording, TrialResult
from mearm.task import SortAborted

if TYPE_CHECKING:
    from mearm.dataset.recorder import DatasetRecorder

#: Trials submitted per worker beyond the last one appended to the log (see
#: :func:`_append_in_order`).
AHEAD_PER_WORKER = 2


def run_trials_parallel(
    config: Config,
    trials: int,
    seed: int,
    log_path: Path,
    jobs: int,
    *,
    scene: list[SceneObject] | None = None,
    start: int = 0,
    progress: Callable[[int], None] | None = None,
    scheduler: str | None = None,
) -> dict[int, str | None]:
    """Run trials ``start`` .. ``trials``−1 in ``jobs`` worker processes, or on Dask.

    Every trial runs in :func:`run_trial` on a worker, which sends its records back;
    this process appends each trial's records to ``log_path`` in trial order as soon as
    every trial before it is in, so the log holds the same records in the same order as
    :func:`run_trials` writes (only the wall-clock fields ``started`` and ``elapsed_s``
    differ), wherever the trials ran; at most :data:`AHEAD_PER_WORKER` trials per worker
    are submitted beyond the last one appended. On Ctrl-C, a failed trial or a lost worker, trials
    not yet started are cancelled and every finished trial up to the first unfinished one
    is appended in order before this returns or raises: nothing that was finished in order
    is lost, and the log resumes. In worker processes the running trials finish first
    (interrupted, on Ctrl-C): the first of them in trial order is appended, as the
    serial run leaves it, and none after it (the log resumes by running that trial
    again, and the ones after it); on Dask they are dropped (a Dask task cannot be
    interrupted) and run again when the log resumes.

    Args:
        config: The rig (simulated).
        trials: How many in the whole experiment.
        seed: Base seed; trial k uses :func:`trial_seed` (seed, k).
        log_path: The run log (appended to; its torn end, if any, already dealt with).
        jobs: Worker processes (≥ 2 without ``scheduler``; :func:`run_trials` runs trials in
            this process), or the workers of ``scheduler="local"``.
        scene: The same layout every trial instead of a random one.
        start: The first trial to run (the ones before are in the log already).
        progress: Called after each trial is appended with the number appended so far.
        scheduler: A Dask scheduler's address (``tcp://host:port``), or ``local`` for a
            Dask LocalCluster of ``jobs`` processes; ``None``: a process pool.

    Returns:
        Per trial run, ``None`` if it cleared the table, else the reason it stopped.

    Raises:
        SortAborted: Ctrl-C (the log holds every trial finished in order).
        TrialFailed: a trial's camera or servos failed (as the serial run stops on
            :class:`CameraError` or :class:`ServoError`).
        MearmError: a worker died, the cluster cancelled a trial, or ``scheduler`` cannot
            be used (see :func:`dask_cluster`).
    """
    numbers = range(start, trials)
    with open_workers(config, seed, scene, min(jobs, len(numbers)), scheduler) as workers:
        return _append_in_order(workers, numbers, log_path, progress)


def open_workers(
    config: Config,
    seed: int,
    scene: list[SceneObject] | None,
    jobs: int,
    scheduler: str | None,
    recording: Recording | None = None,
) -> AbstractContextManager[Workers]:
    """Where :func:`run_trials_parallel` runs trials: ``jobs`` processes, or Dask.

    ``recording``: the worker processes record their trials' picks (not on Dask).

    Raises:
        MearmError: ``scheduler`` cannot be used (see :func:`dask_cluster`).
    """
    if scheduler is None:
        return process_pool(config, seed, scene, jobs, recording)
    return dask_cluster(config, seed, scene, scheduler, jobs)


@contextmanager
def _ctrl_c() -> Iterator[threading.Event]:
    """Ctrl-C sets the event instead of raising; a second Ctrl-C raises KeyboardInterrupt.

    The first asks the trials to stop (the caller cancels them and appends what finished);
    the second gives up waiting for them. SIGTERM and SIGHUP, where the command takes them
    as Ctrl-C (:func:`mearm.interrupts.stop_signals_as_ctrl_c`), do the same; only this
    process gets them, so the workers finish the trials they run, each ending parked.
    Outside the main thread: an event never set.
    """
    seen = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield seen
        return

    def on_interrupt(signum: int, frame: object) -> None:
        interrupts.received(signum)
        if seen.is_set():
            raise KeyboardInterrupt
        seen.set()

    sigs = (signal.SIGINT, *interrupts.taken_as_ctrl_c())
    before = {sig: signal.signal(sig, on_interrupt) for sig in sigs}
    try:
        yield seen
    finally:
        for sig, handler in before.items():
            signal.signal(sig, handler)


def _append_in_order(
    workers: Workers,
    numbers: range,
    log_path: Path,
    progress: Callable[[int], None] | None,
    recorder: DatasetRecorder | None = None,
) -> dict[int, str | None]:
    """Submit trials ``numbers`` to ``workers``; append their records in trial order.

    See :func:`run_trials_parallel` (returns and raises as it does). A trial's recorded
    episodes go into ``recorder``'s dataset before its records into the log: a kill
    between the two leaves the trial to run again, and its picks are not written twice.
    """
    outcomes: dict[int, str | None] = {}
    stop: BaseException | None = None
    # At most AHEAD_PER_WORKER trials per worker are submitted past the last one written:
    # a slow trial holds back only those (not every later trial, finished and then lost
    # to a Ctrl-C), and the log keeps up with the run.
    window = AHEAD_PER_WORKER * max(1, workers.count)
    futures: dict[int, Any] = {}
    to_submit = iter(numbers)

    def submit() -> None:
        while stop is None and len(futures) < window:
            k = next(to_submit, None)
            if k is None:
                return
            futures[k] = workers.submit(k)

    def cancel() -> None:
        for f in futures.values():
            if not f.done():  # a finished Dask future cancelled would drop its result
                f.cancel()

    submit()
    with log_path.open("ab") as out, _ctrl_c() as ctrl_c:
        for k in numbers:
            if k not in futures:  # stopped before it was submitted
                break
            fut = futures.pop(k)
            stop = _wait(fut, ctrl_c, stop, cancel)
            result, lost = _result(fut, k, numbers.start, workers.lost)
            stop = stop or lost
            if not result.ran:
                # a worker that saw Ctrl-C itself runs no more trials: stopped, even when
                # this process had not polled its own Ctrl-C yet (the trial was done first)
                why = f"interrupted ({interrupts.stopped_by()})"
                stop = stop or SortAborted(why, interrupted=True)
                break
            _append(out, result, recorder)
            outcomes[k] = result.reason
            if progress is not None:
                progress(len(outcomes))
            if result.interrupted:
                stop = _trials_own_stop(result, stop)
                cancel()
                break  # run again on resuming: a trial after it would leave a gap
            if result.error is not None:
                stop = stop or TrialFailed(f"trial {k}: {result.error}")
            if stop is not None:
                cancel()
            submit()
    if stop is not None:
        raise stop
    return outcomes


def _trials_own_stop(result: TrialResult, stop: BaseException | None) -> BaseException:
    """The stop of a run whose trial ``result`` was interrupted: the trial's own reason.

    It says how the trial ended (``interrupted (Ctrl-C); arm parked at home``), where the
    stop this process's Ctrl-C made (:func:`_wait`; the only interrupted stop there is
    before a trial's is read) says only that it came: the command's last line said less
    than the log. Any other stop (a failed trial, a lost worker) stays.
    """
    if stop is not None and not (isinstance(stop, SortAborted) and stop.interrupted):
        return stop
    return SortAborted(result.reason or "interrupted", interrupted=True)


def _wait(
    fut: Any,
    ctrl_c: threading.Event,
    stop: BaseException | None,
    cancel: Callable[[], None],
) -> BaseException | None:
    """Wait for ``fut`` to be done; Ctrl-C meanwhile stops the run and cancels its trials.

    Returns:
        ``stop``, or the Ctrl-C that stops the run now.
    """
    # poll: Ctrl-C never lands inside the executor's wait; and look before each trial,
    # done or not (with workers faster than the writing, every future is done when reached)
    while stop is None and (ctrl_c.is_set() or not fut.done()):
        if ctrl_c.wait(0.05):  # worker processes saw Ctrl-C, too
            stop = SortAborted(f"interrupted ({interrupts.stopped_by()})", interrupted=True)
            cancel()
    while not fut.done():
        time.sleep(0.05)
    return stop


def _append(out: BinaryIO, result: TrialResult, recorder: DatasetRecorder | None) -> None:
    """A trial's episodes into the dataset, then its records onto the log (synced)."""
    if recorder is not None and result.episodes:
        recorder.write_episodes(list(result.episodes))
    if result.records:
        out.write(result.records)
        out.flush()
        os.fsync(out.fileno())


def _result(
    fut: Any, k: int, first: int, lost: tuple[type[BaseException], ...]
) -> tuple[TrialResult, MearmError | None]:
    """Trial ``k``'s result from its finished future, or why it has none (not run)."""
    try:
        return fut.result(), None
    except CancelledError as exc:
        return TrialResult(k, ran=False), MearmError(
            f"trial {k} was cancelled by the cluster ({one_line(exc)}); the log "
            f"holds trials {first}..{k - 1} and resumes at trial {k}"
        )
    except lost:
        return TrialResult(k, ran=False), MearmError(
            f"a worker died during trial {k}; the log holds trials "
            f"{first}..{k - 1} and resumes at trial {k}"
        )
