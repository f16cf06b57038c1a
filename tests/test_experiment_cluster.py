"""Sweeps on Dask (`mearm experiment --scheduler`): the log one process writes."""

import importlib.util
import json
import re
import socket
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from badinput import run_in_process
from built_once import computed_once
from conftest import interrupted_experiment
from test_sweeps import (
    OBJECTS,
    SERIAL_TRIALS,
    SWEEP,
    experiment,
    here,
    records,
    serial_prefix,
    serial_records,
)

from mearm.runlog import read_runlog

if importlib.util.find_spec("distributed") is None:  # not imported here: 0.3 s a worker
    pytest.skip("needs the cluster extra: pip install 'mearm[cluster]'", allow_module_level=True)


def analysis(log: Path) -> dict:
    # in this process: the test is about the numbers, not the interpreter (0.7 s a child)
    r = run_in_process(["analyze", log, "--json"], within_s=12)
    assert r.code == 0, r.stderr
    data = json.loads(r.stdout)
    assert data["analysis"].pop("source") == str(log)
    return data


@pytest.mark.heavy
def test_a_sweep_on_a_local_dask_cluster_writes_the_serial_log(tmp_path, tmp_path_factory):
    """Five seeded trials: --scheduler local (2 workers) writes the records --jobs 1 writes,
    in the same order, and analyze gives the same numbers (the process pool writes the
    serial log too: tests/test_sweeps.py)."""
    log = tmp_path / "dask.jsonl"
    r = experiment(*SWEEP, "--trials", 5, "--log", log, "--scheduler", "local", "--jobs", 2)
    assert r.returncode == 0, r.stderr
    where = r"2 Dask workers at tcp://127\.0\.0\.1:\d+"
    assert re.search(rf"5 trials written to .* \([\d.]+ trials/min, {where}\)", r.stdout)
    assert f"sorted {5 * OBJECTS} of {5 * OBJECTS} objects over 5 trials" in r.stdout
    assert records(log) == serial_records(tmp_path_factory, 5)
    assert [t.number for t in read_runlog(log).trials] == [0, 1, 2, 3, 4]
    serial = computed_once(
        tmp_path_factory,
        "serial-sweep-analysis",
        lambda: analysis(serial_prefix(tmp_path_factory, 5, tmp_path)),
    )
    assert analysis(log) == serial


@pytest.mark.slow
def test_ctrl_c_on_a_local_dask_cluster_keeps_the_trials_in_order_and_the_log_resumes(
    tmp_path, tmp_path_factory
):
    """Ctrl-C to the whole process group (the cluster's workers too, as a terminal sends
    it): exit 130, the log holds complete trials in order, and the command resumes it (two
    trials more) with the serial run's records."""
    log, trials = tmp_path / "trials.jsonl", 40
    # signalled once 2 trials are in the log (room for the workers to run ahead of the
    # writer: 12 trials of 12 objects; a trial of SWEEP's 3 objects takes a third as long)
    args = [*SWEEP, "--trials", trials, "--log", log, "--scheduler", "local"]
    code, err = interrupted_experiment(args, log)
    assert code == 130, err
    assert "Traceback" not in err, err
    contents = read_runlog(log)
    assert contents.problem is None
    got = [(t.number, t.complete) for t in contents.trials]
    assert 2 <= len(got) < trials, "the run was not stopped mid-way"
    assert got == [(k, True) for k in range(len(got))]
    written = log.read_bytes()
    # resumed to two trials past the stop (all of them would prove no more, at more cost)
    more = len(got) + 2
    r = experiment(*SWEEP, "--trials", more, "--log", log, "--scheduler", "local")
    assert r.returncode == 0 and f"running trials {len(got)}..{more - 1}" in r.stdout, r.stderr
    assert log.read_bytes().startswith(written)
    if more <= SERIAL_TRIALS:
        serial = serial_records(tmp_path_factory, more)
    else:  # the workers ran far ahead of the writer: a serial run of as many trials
        r = here("experiment", *SWEEP, "--trials", more, "--log", tmp_path / "serial.jsonl")
        assert r.code == 0, r.stderr
        serial = records(tmp_path / "serial.jsonl")
    assert records(log) == serial


@pytest.mark.heavy
@pytest.mark.parametrize(
    "args, needle",
    [
        (["--scheduler", "tcp://127.0.0.1:1"], "cannot reach a Dask scheduler there"),
        (["--scheduler", "127.0.0.1:8786"], "is not a Dask scheduler address"),
        (["--scheduler", "tcp://127.0.0.1:1", "--jobs", "2"], "--jobs sets the workers"),
        (["--config", "RIG", "--scheduler", "local"], "camera is not 'sim'"),
    ],
)
def test_a_scheduler_that_cannot_be_used_exits_2_before_touching_the_log(
    args, needle, tmp_path, quick_connect
):
    """Run in this process (the sweeps above run the command as its own process), the
    connection's wait cut to 1 s."""
    rig = tmp_path / "rig.yaml"
    rig.write_text(f"camera:\n  kind: folder\n  path: {tmp_path}\n")
    log = tmp_path / "t.jsonl"
    args = [str(rig) if a == "RIG" else a for a in args]
    r = run_in_process(["experiment", "--trials", 2, "--log", log, *args], within_s=10)
    assert r.code == 2 and not log.exists()
    assert len(r.stderr.strip().splitlines()) == 1 and needle in r.stderr, r.stderr


@pytest.fixture
def quick_connect(monkeypatch: pytest.MonkeyPatch) -> int:
    """The connection's wait for a scheduler cut from 5 s to 1 s: the seconds the
    silent server's message names (the wait plus one)."""
    from mearm.experiment import cluster

    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1)
    return 2


@contextmanager
def _not_a_scheduler(answer: bytes | None) -> Iterator[str]:
    """A TCP server on this machine that accepts and sends ``answer`` (None: nothing)."""
    server = socket.create_server(("127.0.0.1", 0))
    held: list[socket.socket] = []

    def serve() -> None:
        while True:
            try:
                conn, _ = server.accept()
            except OSError:
                return
            held.append(conn)
            if answer is not None:
                conn.sendall(answer)

    threading.Thread(target=serve, daemon=True).start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    finally:
        server.close()
        for conn in held:
            conn.close()


@pytest.mark.heavy
@pytest.mark.parametrize(
    "answer, needle",
    [(None, "did not answer as a Dask scheduler within {wait_s} s"),
     (b"HTTP/1.0 400 Bad Request\r\nServer: not-dask\r\n\r\n" * 4,
      "what answered there is not a Dask scheduler")],
    ids=["silent", "a web server"],
)  # fmt: skip
def test_a_server_that_is_not_a_scheduler_exits_2(answer, needle, tmp_path, quick_connect):
    """Dask waits for a peer's handshake without a limit (a silent server hung the command)
    and reads a web server's answer as a frame exabytes long: one line, exit 2, no log."""
    log = tmp_path / "t.jsonl"
    with _not_a_scheduler(answer) as address:
        argv = ["experiment", "--trials", 2, "--log", log, "--scheduler", address]
        r = run_in_process(argv, within_s=10)
    assert r.code == 2 and not log.exists(), r.stderr
    needle = needle.format(wait_s=quick_connect)
    assert len(r.stderr.strip().splitlines()) == 1 and needle in r.stderr, r.stderr


def test_without_dask_the_scheduler_option_names_the_extra(tmp_path, monkeypatch):
    """Dask not importable (as without the extra): one line naming the extra, exit 2."""
    # None in sys.modules makes `import distributed` fail, loaded or not (restored after)
    monkeypatch.setitem(sys.modules, "distributed", None)
    log = tmp_path / "t.jsonl"
    r = run_in_process(["experiment", "--trials", 2, "--log", log, "--scheduler", "local"])
    assert r.code == 2 and not log.exists()
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "pip install 'mearm[cluster]'" in r.stderr
