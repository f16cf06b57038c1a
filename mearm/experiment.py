"""Run repeated sorting trials into one run log, as in the paper's experiments.

Each trial sorts a new layout of 4 objects of each class at least 1 cm apart
(or the same ``--scene`` every time) and appends its records, under one header per trial,
to the run log; ``python -m mearm.analyze`` reads it back::

    python -m mearm.experiment --config configs/sim.yaml --trials 100 --seed 0 --log trials.jsonl

On a real rig (camera not simulated) each trial waits for you to lay the objects out and
press Enter. That needs a terminal: without one (standard input not a terminal, or
closed) the run stops with exit 2 before anything moves; ``--yes`` starts every trial
without asking. Simulated trials draw the layout, the servo noise and the camera noise
from the trial's own seed, so any trial can be rerun alone.

**Workers.** ``--jobs N`` runs simulated trials in N worker processes; ``--scheduler
ADDRESS`` on a Dask cluster (``tcp://host:port`` of a running scheduler, or ``local`` for
a LocalCluster of ``--jobs`` processes; the ``cluster`` extra). Either way each trial's
records come back as data and are appended in trial order: the log is the serial run's.

**Resuming.** The log is only ever appended to. Running again with the same ``--log``
continues the experiment: every trial already in it must have been written by this same
run — trial k's header has the seed, config and layout that ``--config``, ``--set``,
``--seed`` and ``--scene`` give trial k — else the run refuses with exit 2 and names the
first difference. It then starts at the trial after the last *complete* one (a trial
with its summary, which includes one that stopped early on a fault or Ctrl-C and said
so). A trial cut off before its summary (the process was killed) is run again under the
same number and seed: its partial records stay in the log, and ``mearm analyze`` leaves
them out because the same trial comes back complete later
(:meth:`~mearm.runlog.RunLogContents.latest`). A torn last line (killed mid-write) is
moved into a side file ``<log>.torn-<offset>`` first (:mod:`mearm.runlog.repair`). A log
damaged anywhere else is not resumed. When the log already holds the trials asked for,
the run says so and exits 0.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import sys
import tempfile
import threading
import time
import uuid
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import CancelledError, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import AbstractContextManager, ExitStack, contextmanager, nullcontext
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mearm.cli import (
    EXIT_FAILURE,
    EXIT_INTERRUPTED,
    ArgumentParser,
    add_config_argument,
    config_from_args,
    run,
    seed_value,
    worker_count,
)
from mearm.config import Config, SceneObject
from mearm.dataset.arguments import (
    add_record_arguments,
    check_record_arguments,
    close_recorder,
    recorder_from_args,
)
from mearm.errors import MearmError
from mearm.hardware.errors import ServoError
from mearm.runlog import (
    HeaderRecord,
    LogLock,
    RunLog,
    TornEnd,
    end_line,
    find_torn_end,
    read_runlog,
    set_aside_torn_end,
)
from mearm.runlog.errors import RunLogError
from mearm.task import (
    SortAborted,
    check_scene,
    load_scene,
    random_scene,
    run_sort,
    scene_layout,
)
from mearm.task.check import check_consistency
from mearm.task.report import Outcome
from mearm.vision.errors import CameraError

if TYPE_CHECKING:
    from mearm.dataset.recorder import DatasetRecorder

#: Objects per class in a random trial layout (the paper: 12 objects, 4 of each colour).
PER_CLASS = 4

#: Why a real rig's run cannot start without a terminal (and how to run it anyway).
NEEDS_TERMINAL = (
    "needs a terminal to confirm each layout (a real rig waits for Enter before every "
    "trial); pass --yes to start every trial without asking"
)


def trial_seed(seed: int, trial: int) -> int:
    """A trial's own seed, distinct for every (seed, trial) pair."""
    return int(np.random.SeedSequence([seed, trial]).generate_state(1)[0])


def trial_config(config: Config, seed: int) -> Config:
    """The config of one simulated trial: servo and camera noise reseeded."""
    servo = config.servo.model_copy(
        update={"error_model": config.servo.error_model.model_copy(update={"seed": seed})}
    )
    camera = config.camera.model_copy(update={"seed": seed})
    return config.model_copy(update={"servo": servo, "camera": camera})


@dataclass(frozen=True)
class TrialPlan:
    """What trial ``number`` of an experiment is, before it runs.

    Attributes:
        number: The trial number (from 0).
        seed: Its own seed (:func:`trial_seed`).
        config: Its config (:func:`trial_config`).
        layout: The simulated table it sorts, or ``None`` for the config's (a real rig).
    """

    number: int
    seed: int
    config: Config
    layout: list[SceneObject] | None


def plan_trial(
    config: Config, seed: int, number: int, scene: list[SceneObject] | None = None
) -> TrialPlan:
    """Trial ``number`` of the experiment with base ``seed`` (and ``--scene``, if given)."""
    s = trial_seed(seed, number)
    cfg = trial_config(config, s)
    layout = scene
    if layout is None and cfg.camera.kind == "sim":
        layout = random_scene(cfg, dict.fromkeys(cfg.task.class_names, PER_CLASS), s)
    return TrialPlan(number, s, cfg, layout)


def run_trials(
    config: Config,
    trials: int,
    seed: int,
    log: RunLog,
    *,
    scene: list[SceneObject] | None = None,
    start: int = 0,
    wait_for_user: Callable[[int], None] | None = None,
    progress: Callable[[int], None] | None = None,
    recorder: DatasetRecorder | None = None,
) -> dict[int, str | None]:
    """Run trials ``start`` .. ``trials``−1, one header per trial in ``log``.

    Args:
        config: The rig.
        trials: How many in the whole experiment.
        seed: Base seed; trial k uses :func:`trial_seed` (seed, k).
        log: Where the records go.
        scene: The same layout every trial instead of a random one.
        start: The first trial to run (the ones before are in the log already).
        wait_for_user: Called with the trial number before each trial on a real rig (to
            lay out the objects).
        progress: Called after each trial with the number of trials run so far.
        recorder: Records every trial's sorts into one dataset (``--record``), each
            episode tagged with its trial: a pick the dataset holds already (a trial cut
            off by a kill, run again) is not recorded twice.

    Returns:
        Per trial run, ``None`` if it cleared the table, else the reason it stopped.

    Raises:
        SortAborted: a trial was interrupted with Ctrl-C (the log holds what was done).
    """
    outcomes: dict[int, str | None] = {}
    for k in range(start, trials):
        plan = plan_trial(config, seed, k, scene)
        if wait_for_user is not None:
            wait_for_user(k)
        if recorder is not None:
            recorder.start_trial(plan.seed)
        try:
            run_sort(
                plan.config, scene=plan.layout, log=log, trial=k, seed=plan.seed, echo=None,
                recorder=recorder,
            )  # fmt: skip
            outcomes[k] = None
        except SortAborted as exc:
            if exc.interrupted:
                raise
            outcomes[k] = exc.reason
        if progress is not None:
            progress(len(outcomes))
    return outcomes


# -- trials in worker processes, here or on a Dask cluster


@dataclass(frozen=True)
class Recording:
    """How a worker records its trials' picks (``--record`` with ``--jobs``).

    Attributes:
        fps: Frames per second of the run's time [Hz].
        per: ``"pick"`` or ``"scene"``: what an episode is.
        codec: The video's codec (``--record-codec``).
    """

    fps: int
    per: str
    codec: str


#: What a worker process runs: (config, seed, scene, recording), set once by
#: :func:`_start_worker`.
_WORK: tuple[Config, int, list[SceneObject] | None, Recording | None] | None = None
#: Whether this worker has seen Ctrl-C (trials handed to it after that are not run).
_STOPPED = False
#: Whether this worker is running a trial (Ctrl-C then interrupts it).
_RUNNING = False

#: How to get the Dask engine that ``--scheduler`` needs.
CLUSTER_EXTRA = "pip install 'mearm[cluster]'"
#: Seconds to wait for a ``--scheduler`` to answer, and for it to have a worker.
CONNECT_TIMEOUT_S = 5


@dataclass(frozen=True)
class TrialResult:
    """What a worker reports back about trial ``number``.

    Attributes:
        number: The trial.
        ran: Whether it ran (a worker that saw Ctrl-C starts no more trials).
        reason: ``None`` if it cleared the table, else why it stopped.
        interrupted: It was stopped by Ctrl-C.
        error: A camera or servo that failed it (as the serial run reports it), if one did.
        records: Its run-log lines (JSON lines, as bytes), for the command to append.
        episodes: Its picks recorded, videos encoded (:class:`~mearm.dataset.sampler.
            EpisodeCapture`), for the command to write into the dataset.
    """

    number: int
    ran: bool = True
    reason: str | None = None
    interrupted: bool = False
    error: str | None = None
    records: bytes = b""
    episodes: tuple[Any, ...] = ()


def run_trial(
    config: Config,
    seed: int,
    scene: list[SceneObject] | None,
    number: int,
    recording: Recording | None = None,
) -> TrialResult:
    """Run trial ``number`` wherever this is called; its records come back as data.

    The trial writes its log into a temporary folder of the machine it runs on, which is
    read back and removed: a worker (a process here, or a Dask worker elsewhere) needs
    no file system shared with the command, only the arguments. With ``recording``, its
    picks come back as episodes, too.
    """
    global _RUNNING
    capture = None
    with tempfile.TemporaryDirectory(prefix="mearm-trial-") as tmp:
        part = Path(tmp) / f"trial-{number}.jsonl"
        try:
            _RUNNING = True  # Ctrl-C in a worker process now interrupts the trial
            plan = plan_trial(config, seed, number, scene)
            if recording is not None:
                from mearm.dataset.sampler import EpisodeCapture

                capture = EpisodeCapture(
                    plan.config, fps=recording.fps, per=recording.per,  # type: ignore[arg-type]
                    codec=recording.codec,
                )  # fmt: skip
                capture.start_trial(plan.seed)
            with RunLog(part, exclusive=True, fsync=False) as log:
                run_sort(
                    plan.config, scene=plan.layout, log=log, trial=number, seed=plan.seed,
                    echo=None, recorder=capture,
                )  # fmt: skip
            result = TrialResult(number)
        except SortAborted as exc:
            result = TrialResult(number, reason=exc.reason, interrupted=exc.interrupted)
        except KeyboardInterrupt:  # before the sort started; run_sort logged it if it had
            result = TrialResult(number, reason="interrupted (Ctrl-C)", interrupted=True)
        except (CameraError, ServoError) as exc:
            result = TrialResult(number, reason=str(exc), error=str(exc))
        finally:
            _RUNNING = False
            if capture is not None:
                capture.close()
        episodes = tuple(capture.episodes) if capture is not None else ()
        return replace(
            result, records=part.read_bytes() if part.exists() else b"", episodes=episodes
        )


def _on_interrupt(signum: int, frame: object) -> None:
    global _STOPPED
    _STOPPED = True
    if _RUNNING:
        raise KeyboardInterrupt


def _start_worker(
    config: Config, seed: int, scene: list[SceneObject] | None, recording: Recording | None
) -> None:
    """A worker's one-time setup: the experiment's settings once; Ctrl-C only stops trials."""
    global _WORK
    signal.signal(signal.SIGINT, _on_interrupt)
    _WORK = (config, seed, scene, recording)


def _trial_in_worker(number: int) -> TrialResult:
    """Run trial ``number`` in a worker process (:func:`run_trial`), unless Ctrl-C was seen."""
    assert _WORK is not None, "_start_worker was not run"
    if _STOPPED:
        return TrialResult(number, ran=False)
    config, seed, scene, recording = _WORK
    return run_trial(config, seed, scene, number, recording)


class TrialFailed(MearmError):
    """A trial run by a worker failed on its camera or servos (the log holds it)."""


#: Trials submitted per worker beyond the last one appended to the log (see
#: :func:`_append_in_order`).
AHEAD_PER_WORKER = 2


@dataclass
class Workers:
    """Somewhere that runs trials: :meth:`submit` trial k, get a future of its result.

    Attributes:
        submit: Starts trial k; returns a future (``result()``, ``done()``, ``cancel()``).
        lost: The exceptions a future raises when the worker running it died.
        count: How many trials run at once.
        where: Says where they run, for the line after the run.
    """

    submit: Callable[[int], Any]
    lost: tuple[type[BaseException], ...]
    count: int
    where: str


@contextmanager
def _process_pool(
    config: Config,
    seed: int,
    scene: list[SceneObject] | None,
    jobs: int,
    recording: Recording | None = None,
) -> Iterator[Workers]:
    """``jobs`` worker processes on this machine; closed (waiting for them) on the way out."""
    pool = ProcessPoolExecutor(
        max_workers=jobs, initializer=_start_worker, initargs=(config, seed, scene, recording)
    )
    try:
        yield Workers(
            lambda k: pool.submit(_trial_in_worker, k), (BrokenProcessPool,), jobs, "workers"
        )
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


@contextmanager
def _dask_cluster(
    config: Config, seed: int, scene: list[SceneObject] | None, scheduler: str, jobs: int
) -> Iterator[Workers]:
    """The Dask cluster of ``scheduler`` (``local``: a LocalCluster of ``jobs`` processes).

    Raises:
        MearmError: Dask is not installed, the scheduler does not answer within
            :data:`CONNECT_TIMEOUT_S`, has no workers, or its workers cannot run mearm.
    """
    try:
        from distributed import Client, KilledWorker, LocalCluster
    except ImportError:
        raise MearmError(
            f"--scheduler runs the trials on Dask, which is not installed: {CLUSTER_EXTRA}"
        ) from None
    with ExitStack() as stack:
        if scheduler == "local":
            cluster = stack.enter_context(_local_cluster(LocalCluster, jobs))
            address = cluster.scheduler_address
        else:
            address = _scheduler_address(scheduler)
            _probe_scheduler(address, scheduler)
        try:
            client = stack.enter_context(
                Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
            )
        except (OSError, ValueError, TypeError) as exc:
            raise MearmError(
                f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({_one_line(exc)})"
            ) from None
        try:
            client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
        except TimeoutError:
            raise MearmError(
                f"--scheduler {scheduler}: the scheduler has no workers (start some with "
                f"dask worker {address})"
            ) from None
        _check_workers(client, scheduler)
        threads = sum(client.nthreads().values())
        token = uuid.uuid4().hex[:8]

        def submit(k: int) -> Any:
            return client.submit(
                run_trial, config, seed, scene, k,
                key=f"mearm-trial-{k}-{token}", pure=False, priority=-k,
            )  # fmt: skip

        yield Workers(submit, (KilledWorker,), threads, f"Dask workers at {address}")


def _probe_scheduler(address: str, scheduler: str) -> None:
    """Ask ``address`` who it is: a Dask scheduler, or :class:`MearmError`.

    Dask's own connection waits for the peer's handshake without a time limit, so a
    server that accepts the connection and says nothing (a web server) hung the command,
    and one that answers something else made Dask read a frame exabytes long.

    Raises:
        MearmError: nothing connects or answers within :data:`CONNECT_TIMEOUT_S` (+1 s),
            or what answers is not a Dask scheduler.
    """
    import asyncio

    from distributed.comm import connect

    async def identity() -> Any:
        comm = await connect(address, timeout=CONNECT_TIMEOUT_S)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    # a second more than the connection's own limit, so that its error (refused, no
    # route) comes first and this one is the silent server's
    wait_s = CONNECT_TIMEOUT_S + 1
    try:
        reply = asyncio.run(asyncio.wait_for(identity(), wait_s))
    except TimeoutError:
        raise MearmError(
            f"--scheduler {scheduler}: something accepted the connection but did not answer "
            f"as a Dask scheduler within {wait_s} s"
        ) from None
    except OSError as exc:
        raise MearmError(
            f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({_one_line(exc)})"
        ) from None
    except Exception as exc:  # noqa: BLE001 - whatever a server that is not Dask causes
        raise MearmError(
            f"--scheduler {scheduler}: what answered there is not a Dask scheduler "
            f"({type(exc).__name__}: {_one_line(exc)})"
        ) from None
    if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        raise MearmError(
            f"--scheduler {scheduler}: what answered there is not a Dask scheduler (it "
            f"answered {repr(reply)[:60]})"
        )


def _scheduler_address(text: str) -> str:
    """``text`` if it is a Dask scheduler address (``tcp://host:port``), or :class:`MearmError`."""
    from distributed.comm import parse_address
    from distributed.comm.registry import get_backend

    try:
        scheme, _ = parse_address(text, strict=True)
        get_backend(scheme).get_address_host_port(text)
    except (ValueError, TypeError, NotImplementedError) as exc:  # inproc: no host, no port
        raise MearmError(
            f"--scheduler {text!r} is not a Dask scheduler address like tcp://host:8786, nor "
            f"'local' ({_one_line(exc)})"
        ) from None
    return text


@contextmanager
def _local_cluster(local_cluster: Any, jobs: int) -> Iterator[Any]:
    """A Dask LocalCluster of ``jobs`` worker processes of one thread each, quiet.

    Its workers start with Ctrl-C ignored (they inherit that): on Ctrl-C this process
    cancels their trials and closes them, as a remote cluster's are cancelled.
    """
    ignore = threading.current_thread() is threading.main_thread()
    before = signal.signal(signal.SIGINT, signal.SIG_IGN) if ignore else None
    try:
        cluster = local_cluster(
            n_workers=jobs,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            # only critical: closing the cluster after a Ctrl-C, a worker's heartbeat may
            # find the scheduler gone and log an ERROR with its traceback; what failed,
            # the command reports itself (a lost worker, a cancelled trial)
            silence_logs=logging.CRITICAL,
        )
    finally:
        if ignore:
            signal.signal(signal.SIGINT, before)
    with cluster:
        yield cluster


def _mearm_version() -> str:
    """The mearm version a worker imports (run on each Dask worker)."""
    import mearm

    return mearm.__version__


def _check_workers(client: Any, scheduler: str) -> None:
    """Every Dask worker imports this mearm version, or :class:`MearmError`."""
    import mearm

    try:
        versions = client.run(_mearm_version)
    except Exception as exc:  # the worker's own error, e.g. ModuleNotFoundError
        raise MearmError(
            f"--scheduler {scheduler}: its workers cannot run mearm trials "
            f"({type(exc).__name__}: {_one_line(exc)}); install mearm {mearm.__version__} on "
            "every worker"
        ) from None
    for worker, version in sorted(versions.items()):
        if version != mearm.__version__:
            raise MearmError(
                f"--scheduler {scheduler}: worker {worker} runs mearm {version}, this is "
                f"{mearm.__version__}; install the same version on every worker"
            )


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


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
    (interrupted, on Ctrl-C); on Dask they are dropped (a Dask task cannot be
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
            be used (see :func:`_dask_cluster`).
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
        MearmError: ``scheduler`` cannot be used (see :func:`_dask_cluster`).
    """
    if scheduler is None:
        return _process_pool(config, seed, scene, jobs, recording)
    return _dask_cluster(config, seed, scene, scheduler, jobs)


@contextmanager
def _ctrl_c() -> Iterator[threading.Event]:
    """Ctrl-C sets the event instead of raising; a second Ctrl-C raises KeyboardInterrupt.

    The first asks the trials to stop (the caller cancels them and appends what finished);
    the second gives up waiting for them. Outside the main thread: an event never set.
    """
    seen = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield seen
        return

    def on_interrupt(signum: int, frame: object) -> None:
        if seen.is_set():
            raise KeyboardInterrupt
        seen.set()

    before = signal.signal(signal.SIGINT, on_interrupt)
    try:
        yield seen
    finally:
        signal.signal(signal.SIGINT, before)


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
            # poll: Ctrl-C never lands inside the executor's wait; and look before each
            # trial, done or not (workers faster than the writing leave every future done
            # when it is reached, and the run went on to the end)
            while stop is None and (ctrl_c.is_set() or not fut.done()):
                if ctrl_c.wait(0.05):  # worker processes saw it, too
                    stop = SortAborted("interrupted (Ctrl-C)", interrupted=True)
                    cancel()
            while not fut.done():
                time.sleep(0.05)
            try:
                result: TrialResult = fut.result()
            except CancelledError as exc:
                result = TrialResult(k, ran=False)
                stop = stop or MearmError(
                    f"trial {k} was cancelled by the cluster ({_one_line(exc)}); the log "
                    f"holds trials {numbers.start}..{k - 1} and resumes at trial {k}"
                )
            except workers.lost:
                result = TrialResult(k, ran=False)
                stop = stop or MearmError(
                    f"a worker died during trial {k}; the log holds trials "
                    f"{numbers.start}..{k - 1} and resumes at trial {k}"
                )
            if not result.ran:
                # a worker that saw Ctrl-C itself runs no more trials: stopped, even when
                # this process had not polled its own Ctrl-C yet (the trial was done first)
                stop = stop or SortAborted("interrupted (Ctrl-C)", interrupted=True)
                break
            if recorder is not None and result.episodes:
                recorder.write_episodes(list(result.episodes))
            if result.records:
                out.write(result.records)
                out.flush()
                os.fsync(out.fileno())
            outcomes[k] = result.reason
            if progress is not None:
                progress(len(outcomes))
            if result.interrupted:
                stop = stop or SortAborted(result.reason or "interrupted", interrupted=True)
            elif result.error is not None:
                stop = stop or TrialFailed(f"trial {k}: {result.error}")
            if stop is not None:
                cancel()
            submit()
    if stop is not None:
        raise stop
    return outcomes


# -- resuming


@dataclass(frozen=True)
class Resume:
    """Where an experiment continues its log.

    Attributes:
        done: Trials 0 .. ``done``−1 are complete in the log; the run starts at ``done``.
        cut_off: Attempts of trial ``done`` in the log that stopped before their summary
            (it is run again).
        torn: The log's unfinished last line, or ``None``.
        torn_is_record: Whether that line is a whole record missing only its newline.
    """

    done: int = 0
    cut_off: int = 0
    torn: TornEnd | None = None
    torn_is_record: bool = False


def ready_to_append(path: Path, resume: Resume) -> Path | None:
    """Make a resumed log appendable: set its torn last line aside, or end its last line.

    Returns:
        The side file the torn line went to, or ``None``.

    Raises:
        RunLogError: The log cannot be changed (it is then as it was).
    """
    if resume.torn is None:
        return None
    if resume.torn_is_record:
        end_line(path)
        return None
    return set_aside_torn_end(path, resume.torn)


def resume_point(
    path: Path, config: Config, seed: int, scene: list[SceneObject] | None = None
) -> Resume:
    """Check that ``path`` holds this experiment's trials; say where to continue.

    Reads only; :func:`ready_to_append` then deals with a torn last line.

    Args:
        path: The ``--log``; a missing or empty file starts at trial 0.
        config: The experiment's config.
        seed: Its base seed.
        scene: Its ``--scene``, if any.

    Raises:
        RunLogError: The log cannot be read, is damaged before its last line, holds a
            lone sort run, trials out of order, or trials of another run (another config,
            seed or layout); the message names the first such trial and what differs.
    """
    if not path.exists() or (path.is_file() and path.stat().st_size == 0):
        return Resume()
    contents = read_runlog(path)
    torn = find_torn_end(path)
    problem = contents.problem
    if problem is not None and (torn is None or problem.line != torn.line):
        raise RunLogError(
            path,
            f"line {problem.line}: {problem.reason}; a damaged log is not resumed (mearm "
            "analyze reads it up to that line): write the new trials to another --log",
        )
    done = cut_off = 0
    plans: dict[int, TrialPlan] = {}
    for t in contents.trials:
        if t.number is None:
            raise RunLogError(
                path,
                f"line {t.line}: a sort run (trial null), not a trial of an experiment; "
                "give the experiment its own --log",
            )
        if t.number != done:
            raise RunLogError(
                path,
                f"line {t.line}: trial {t.number} where trial {done} comes next: not the "
                "trials of one experiment in order; write to another --log",
            )
        if t.number not in plans:  # attempts of one trial share its plan
            plans[t.number] = plan_trial(config, seed, t.number, scene)
        why = _differs(t.header, plans[t.number], seed)
        if why is not None:
            raise RunLogError(
                path,
                f"trial {t.number} (line {t.line}) was written by another run: {why}; resume "
                "with its --config, --set, --seed and --scene, or write to another --log",
            )
        if t.complete:
            done, cut_off = done + 1, 0
        else:
            cut_off += 1
    return Resume(done, cut_off, torn, torn_is_record=torn is not None and problem is None)


def _differs(header: HeaderRecord, plan: TrialPlan, seed: int) -> str | None:
    """How a logged trial's header differs from the trial this run would write, if it does."""
    if header.seed != plan.seed:
        return f"it was seeded {header.seed}; --seed {seed} seeds it {plan.seed}"
    difference = _first_difference(header.config, _json(plan.config.model_dump(mode="json")))
    if difference is not None:
        key, logged, now = difference
        return f"its config differs at {key or 'the top'} (log: {logged}; now: {now})"
    logged_scene = (header.model_extra or {}).get("scene")
    if logged_scene != _json(scene_layout(plan.config, plan.layout)):
        return "its table layout differs (was --scene given to one run and not the other?)"
    return None


def _json(value: Any) -> Any:
    """``value`` as it reads back from a log line (tuples → lists, keys → strings)."""
    return json.loads(json.dumps(value))


def _first_difference(logged: Any, now: Any, key: str = "") -> tuple[str, str, str] | None:
    """The dotted key where two JSON values first differ, and both values (shortened)."""
    if isinstance(logged, Mapping) and isinstance(now, Mapping):
        for name in sorted(set(logged) | set(now), key=str):
            sub = f"{key}.{name}" if key else str(name)
            if name not in logged or name not in now:
                return sub, _short(logged.get(name, "(none)")), _short(now.get(name, "(none)"))
            found = _first_difference(logged[name], now[name], sub)
            if found is not None:
                return found
        return None
    if isinstance(logged, list) and isinstance(now, list) and len(logged) == len(now):
        for i, (a, b) in enumerate(zip(logged, now, strict=True)):
            found = _first_difference(a, b, f"{key}[{i}]")
            if found is not None:
                return found
        return None
    same_type = type(logged) is type(now) or (_number(logged) and _number(now))
    if same_type and logged == now:
        return None
    return key, _short(logged), _short(now)


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _short(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 60 else text[:57] + "..."


# -- the prompt


def _has_terminal() -> bool:
    stdin = sys.stdin
    try:
        return stdin is not None and stdin.isatty()
    except (ValueError, OSError):  # a closed stream
        return False


def terminal_prompt(trials: int) -> Callable[[int], None]:
    """The wait before each trial of a real rig: Enter on the terminal.

    Raises:
        MearmError: Standard input is not a terminal (checked now, before anything
            moves), or it ends at a prompt (raised by the wait).
    """
    if not _has_terminal():
        raise MearmError(NEEDS_TERMINAL)

    def wait(k: int) -> None:
        try:
            input(f"trial {k + 1}/{trials}: lay out the objects, then press Enter ")
        except EOFError:
            raise MearmError(
                f"input ended at the prompt of trial {k}: {NEEDS_TERMINAL}; the same --log "
                f"resumes at trial {k}"
            ) from None

    return wait


def main(argv: Sequence[str] | None = None) -> int:
    """Run the trials; see the module docstring."""
    parser = ArgumentParser(prog="python -m mearm.experiment", description=__doc__.splitlines()[0])
    add_config_argument(parser)
    parser.add_argument(
        "--trials", type=int, default=100, help="number of trials in all (default 100)"
    )
    parser.add_argument("--seed", type=seed_value, default=0, help="base seed (default 0)")
    parser.add_argument(
        "--log",
        type=Path,
        required=True,
        help="JSON-lines log; one that holds trials of this run is continued",
    )
    parser.add_argument("--scene", type=Path, help="use this layout in every trial")
    parser.add_argument(
        "--yes",
        action="store_true",
        help="real rig: start every trial without waiting for Enter (needed without a "
        "terminal; lay the objects out beforehand)",
    )
    parser.add_argument(
        "--jobs",
        type=worker_count,
        default=None,
        help="simulated trials run at once, in worker processes (default 1; this machine "
        f"has {os.cpu_count()} CPUs), or the workers of --scheduler local; the log is the "
        "same, in trial order",
    )
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run the simulated trials on a Dask cluster: a running scheduler's address "
        "(tcp://host:port) or 'local' (a LocalCluster of --jobs processes, default 2); the "
        f"log is the same, in trial order (needs {CLUSTER_EXTRA})",
    )
    add_record_arguments(parser)
    args = parser.parse_args(argv)
    check_record_arguments(parser, args)
    if args.record is not None and args.scheduler is not None:
        parser.error("--record writes the dataset here: with --jobs, not with --scheduler")
    if args.trials < 1:
        parser.error(f"--trials must be ≥ 1, got {args.trials}")
    if args.scheduler not in (None, "local") and args.jobs is not None:
        parser.error(
            f"--jobs sets the workers of --scheduler local; the cluster at {args.scheduler} "
            "has its own workers"
        )
    if args.jobs is None:
        args.jobs = 2 if args.scheduler == "local" else 1
    config = config_from_args(args)
    check_consistency(config)  # before the scene, the log or any output: the config first
    scene = load_scene(args.scene, config.task.class_names) if args.scene else None
    if scene is not None and config.camera.kind != "sim":
        raise MearmError("--scene lays out the simulated table; this config's camera is not 'sim'")
    if scene is not None:
        check_scene(config, scene, str(args.scene))  # (without it, each trial draws its own)
    if args.scheduler is not None and config.camera.kind != "sim":
        raise MearmError(
            "--scheduler runs simulated trials on a cluster; this config's camera is not "
            "'sim' (a real rig sorts one trial at a time, here)"
        )
    if args.jobs > 1 and config.camera.kind != "sim":
        raise MearmError(
            f"--jobs {args.jobs} runs simulated trials at once; this config's camera is not "
            "'sim' (a real rig sorts one trial at a time)"
        )
    wait = None
    if config.camera.kind != "sim" and not args.yes:
        wait = terminal_prompt(args.trials)

    # one writer per log: taken before the log is read for resuming, so no other run
    # appends between that reading and this run's first record (a new log: RunLog's own)
    held = LogLock(args.log) if args.log.is_file() else None
    try:
        return _resume(args, config, scene, wait, held)
    finally:
        if held is not None:
            held.release()


def _resume(
    args: Any,
    config: Config,
    scene: list[SceneObject] | None,
    wait: Callable[[int], None] | None,
    held: LogLock | None,
) -> int:
    """Where the log leaves off, the workers, then the run (:func:`main`'s second half)."""
    resume = resume_point(args.log, config, args.seed, scene)
    if resume.done >= args.trials:
        print(
            f"{args.log} already holds {resume.done} complete trials (--trials {args.trials}): "
            "nothing to run"
        )
        return 0
    if resume.done or resume.cut_off:
        again = f"; trial {resume.done} again, it was cut off" if resume.cut_off else ""
        print(
            f"resuming {args.log}: {resume.done} complete trials there, running trials "
            f"{resume.done}..{args.trials - 1}{again}"
        )
    recorder = recorder_from_args(args, config)  # its directory checked before any trial
    # Workers first: a scheduler that cannot be used leaves the log as it was.
    parallel = args.jobs > 1 or args.scheduler is not None
    jobs = min(args.jobs, args.trials - resume.done)
    with (
        open_workers(config, args.seed, scene, jobs, args.scheduler, _recording(args))
        if parallel
        else nullcontext()
    ) as workers:
        try:
            return _run(args, config, scene, resume, wait, workers, recorder, held)
        finally:
            close_recorder(recorder, args.record)


def _run(
    args: Any,
    config: Config,
    scene: list[SceneObject] | None,
    resume: Resume,
    wait: Callable[[int], None] | None,
    workers: Workers | None,
    recorder: DatasetRecorder | None = None,
    held: LogLock | None = None,
) -> int:
    """The run of :func:`main` once its input is checked (and its workers are ready)."""
    set_aside = ready_to_append(args.log, resume)
    if set_aside is not None:
        print(
            f"note: {args.log} ended in a torn line (killed mid-write); its "
            f"{len(resume.torn.data) if resume.torn else 0} bytes were moved to {set_aside}",
            file=sys.stderr,
        )

    from tqdm import tqdm

    t0 = time.perf_counter()
    with (
        RunLog(args.log, lock=held) as log,
        tqdm(
            total=args.trials, initial=resume.done, unit="trial", file=sys.stderr, disable=None
        ) as bar,
    ):
        try:
            if workers is None:
                outcomes = run_trials(
                    config,
                    args.trials,
                    args.seed,
                    log,
                    scene=scene,
                    start=resume.done,
                    wait_for_user=wait,
                    progress=lambda done: _step(bar, recorder),
                    recorder=recorder,
                )
            else:
                numbers = range(resume.done, args.trials)
                outcomes = _append_in_order(
                    workers, numbers, args.log, lambda done: _step(bar, recorder), recorder
                )
        except SortAborted as exc:
            print(f"mearm.experiment: stopped: {exc.reason}", file=sys.stderr)
            return EXIT_INTERRUPTED
        except (CameraError, ServoError, TrialFailed) as exc:
            print(f"mearm.experiment: {exc}", file=sys.stderr)
            return EXIT_FAILURE
    wall = time.perf_counter() - t0
    failed = [(k, r) for k, r in outcomes.items() if r is not None]
    where = "1 process" if workers is None else f"{workers.count} {workers.where}"
    print(
        f"{len(outcomes)} trials written to {args.log} in {wall:.0f} s "
        f"({60 * len(outcomes) / wall:.1f} trials/min, {where}); {len(failed)} stopped early"
    )
    for k, reason in failed:
        print(f"  trial {k}: {reason}")
    print(f"analyse: python -m mearm.analyze {args.log} --out report/")
    print(_totals(args.log, args.trials))
    return EXIT_FAILURE if failed else 0


def _recording(args: Any) -> Recording | None:
    """What the worker processes record, with ``--record``."""
    if args.record is None:
        return None
    return Recording(args.record_fps, args.record_per, args.record_codec)


def _step(bar: Any, recorder: DatasetRecorder | None) -> None:
    """One more trial on the progress bar, with the episodes recorded so far."""
    if recorder is not None:
        bar.set_postfix_str(f"{recorder.episodes_written} episodes", refresh=False)
    bar.update(1)


def _totals(path: Path, trials: int) -> str:
    """``sorted N of M objects over K trials (…reasons…)``, from the log's summaries.

    Counts each trial number once (its complete attempt), resumed trials included. Objects
    left in a trial are the experiment's data, not a failure of the command.
    """
    total = Outcome()
    done: set[int] = set()
    for trial in reversed(read_runlog(path).trials):
        s = trial.summary
        number = trial.header.trial
        if s is None or number is None or number in done or number >= trials:
            continue
        done.add(number)
        for name, n in (s.objects or s.sorted).items():
            total.seen[name] = total.seen.get(name, 0) + n
        for name, n in s.sorted.items():
            total.sorted[name] = total.sorted.get(name, 0) + n
        for kind, n in (s.left or {}).items():
            total.left[kind] = total.left.get(kind, 0) + n
    line = total.line()
    head, _, rest = line.partition(" objects")
    return f"{head} objects over {len(done)} trials{rest}"


if __name__ == "__main__":
    run(main)
