"""A recording's video encoder that cannot start: said as what it is, nothing left behind.

The run log said "after the sort: …" of an encoder that failed before the sort moved
anything; and a start that failed after the ring of frames was made in ``/dev/shm``
(out of file descriptors, the process not started) left its ~24 MB segment there.
"""

from __future__ import annotations

import errno
import json
import multiprocessing.context
import os
import resource
from collections.abc import Iterator
from multiprocessing import resource_tracker
from pathlib import Path

import pytest
from badinput import run_in_process
from test_dataset_outputs import SIM, _own_shm_possible, _record

from mearm.dataset import video_encoder
from mearm.dataset.errors import EncoderError
from mearm.dataset.video_encoder import SHM_DIR, EncoderProcess

SHAPE = (48, 64, 3)


@pytest.fixture
def rings(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The names of the rings this test's encoders make (not another test's: the suite's
    workers record at the same time, and /dev/shm is the machine's)."""
    made: list[str] = []
    make = video_encoder.ring_memory

    def recorded(size: int):  # noqa: ANN202
        shm = make(size)
        made.append(shm.name.lstrip("/"))
        return shm

    monkeypatch.setattr(video_encoder, "ring_memory", recorded)
    return made


def _left(rings: list[str]) -> set[str]:
    """Those of ``rings`` still in /dev/shm; asserting the list is not empty first."""
    assert rings, "no ring was made: the test did not reach the step it is about"
    return {name for name in rings if (SHM_DIR / name).exists()}


def _open_fds() -> set[int]:
    return {int(fd) for fd in os.listdir("/proc/self/fd")}


def _faults(log: Path) -> list[str]:
    """The reasons of the run log's faults."""
    records = [json.loads(line) for line in log.read_text().splitlines()]
    return [r["reason"] for r in records if r["type"] == "fault"]


def _cannot_fork(*_args: object) -> None:
    raise OSError(errno.EAGAIN, os.strerror(errno.EAGAIN))  # fork() out of processes


@pytest.mark.heavy
def test_a_full_dev_shm_is_logged_before_the_sort(tmp_path: Path) -> None:
    """The ring's shared memory cannot be had: the log's fault says the sort never
    started; exit status and stderr's one line are as before."""
    _own_shm_possible()
    root, log = tmp_path / "ds", tmp_path / "run.jsonl"
    run = _record(root, "--log", str(log), shm="size=64k")
    assert run.returncode == 1, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mearm sort: error: /dev/shm/mearm-ring-"), lines
    said = lines[0].removeprefix("mearm sort: error: ")
    assert _faults(log) == [f"before the sort started: {said}"]


def test_an_encoder_process_that_cannot_start_is_logged_before_the_sort(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, rings: list[str]
) -> None:
    """The encoder's process cannot be started (fork fails): the log's fault says the
    sort never started; one line on stderr, exit 1 (the run failed; the input was good)."""
    monkeypatch.setattr(multiprocessing.context.SpawnProcess, "start", _cannot_fork)
    root, log = tmp_path / "ds", tmp_path / "run.jsonl"
    run = run_in_process(
        ["sort", "--config", SIM, "--random", "2", "--quiet", "--record", root,
         "--record-codec", "h264", "--log", log],
        within_s=30,
    )  # fmt: skip
    said = f"cannot start the video encoder process ([Errno {errno.EAGAIN}] "
    assert run.code == 1, run.stderr  # a failure of the run, not bad input
    assert run.stderr.splitlines() == [f"mearm sort: error: {said}{os.strerror(errno.EAGAIN)})"]
    assert _faults(log) == [f"before the sort started: {said}{os.strerror(errno.EAGAIN)})"]
    assert _left(rings) == set()


@pytest.fixture
def made_once() -> Iterator[None]:
    """What a process's first segment and first shared value make, made: the tracker of
    shared memory (a pipe) and the heap of shared values (a file). Both stay, and would
    otherwise be new file descriptors where a test counts them."""
    resource_tracker.ensure_running()
    value = multiprocessing.get_context("spawn").Value("q", 0, lock=False)
    yield
    del value


@pytest.fixture
def fds_for_the_ring_only(made_once: None) -> Iterator[None]:
    """Every file descriptor this process may open taken but two: the ring's segment gets
    them (its own, and the one ``mmap`` dups), and the encoder's pipe then fails (EMFILE)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (max(_open_fds()) + 64, hard))
    taken: list[int] = []
    try:
        with pytest.raises(OSError, match="Too many open files"):
            while True:
                taken.append(os.open(os.devnull, os.O_RDONLY))
        for _ in range(2):
            os.close(taken.pop())
        yield
    finally:
        for fd in taken:
            os.close(fd)
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))


def test_out_of_file_descriptors_after_the_ring_leaves_no_segment(
    fds_for_the_ring_only: None, rings: list[str]
) -> None:
    """Out of file descriptors once the ring is made (for the pipe): an
    :class:`EncoderError` (a recording then fails as when the process cannot start), the
    segment removed and its descriptor closed."""
    fds = _open_fds()
    with pytest.raises(
        EncoderError, match=r"cannot start the video encoder process \(\[Errno 24\]"
    ):
        EncoderProcess(SHAPE, 10, "h264")
    assert _left(rings) == set()
    assert _open_fds() == fds


def test_a_process_that_cannot_start_leaves_no_segment_and_no_pipe(
    made_once: None, monkeypatch: pytest.MonkeyPatch, rings: list[str]
) -> None:
    """The process cannot be started: the same :class:`EncoderError` as before, the
    segment removed, both ends of the pipe closed, while the error is still held (the
    process's end was left to the garbage collector, kept open by the error's traceback)."""
    monkeypatch.setattr(multiprocessing.context.SpawnProcess, "start", _cannot_fork)
    fds = _open_fds()
    with pytest.raises(EncoderError, match="cannot start the video encoder process") as raised:
        EncoderProcess(SHAPE, 10, "h264")
    assert _left(rings) == set()
    assert _open_fds() == fds, raised.value
