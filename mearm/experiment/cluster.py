"""Trials on a Dask cluster (``--scheduler``): connect, check the workers, submit.

Needs the ``cluster`` extra; a scheduler that is missing, silent, not Dask, without
workers or with workers of another mearm version is a :class:`MearmError` before any
trial runs.
"""

from __future__ import annotations

import logging
import signal
import threading
import uuid
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from typing import Any

from mearm.config import Config, SceneObject
from mearm.errors import MearmError
from mearm.experiment.errors import one_line
from mearm.experiment.pool import Workers
from mearm.experiment.trials import run_trial

#: How to get the Dask engine that ``--scheduler`` needs.
CLUSTER_EXTRA = "pip install 'mearm[cluster]'"
#: Seconds to wait for a ``--scheduler`` to answer, and for it to have a worker.
CONNECT_TIMEOUT_S = 5


@contextmanager
def dask_cluster(
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
                f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({one_line(exc)})"
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

        noun = "Dask worker" if threads == 1 else "Dask workers"
        yield Workers(submit, (KilledWorker,), threads, f"{noun} at {address}")


def _probe_scheduler(address: str, scheduler: str) -> None:
    """Ask ``address`` who it is: a Dask scheduler, or :class:`MearmError`.

    Dask's own connection waits for the peer's handshake without a time limit: a server
    that accepts and says nothing (a web server) would hang the command, and one that
    answers something else would have Dask read a bogus frame length.

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
            f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({one_line(exc)})"
        ) from None
    except Exception as exc:  # noqa: BLE001 - whatever a server that is not Dask causes
        raise MearmError(
            f"--scheduler {scheduler}: what answered there is not a Dask scheduler "
            f"({type(exc).__name__}: {one_line(exc)})"
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
            f"'local' ({one_line(exc)})"
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
            f"({type(exc).__name__}: {one_line(exc)}); install mearm {mearm.__version__} on "
            "every worker"
        ) from None
    for worker, version in sorted(versions.items()):
        if version != mearm.__version__:
            raise MearmError(
                f"--scheduler {scheduler}: worker {worker} runs mearm {version}, this is "
                f"{mearm.__version__}; install the same version on every worker"
            )
