"""Lines of ``mearm experiment`` and ``mearm dataset``, and the encoder's ring in /dev/shm.

Every file or folder a command writes is named on stdout in a ``wrote`` line, before the
outcome line, a run that stopped included: ``mearm experiment`` named neither its log nor
its dataset, and ``mearm dataset show`` said ``contact sheet: P``. Bad input is refused
before anything is on stdout (a ``resuming …`` line came before the refusal of a dataset
folder not empty). A recording killed with its whole process group (``kill -9``, which
takes multiprocessing's resource tracker too) left the encoder's 24 MB ring in /dev/shm,
and a container's 64 MB filled with two of them.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from multiprocessing import resource_tracker
from multiprocessing.shared_memory import SharedMemory
from pathlib import Path

import pytest
from badinput import ROOT, Outcome, run_in_process

from mearm.dataset import video_encoder
from mearm.dataset.video_encoder import SHM_DIR

PYTHON_ENV = {**os.environ, "PYTHONPATH": str(ROOT), "MUJOCO_GL": "egl"}


# ----------------------------------------------------------------- the encoder's ring


def _rings_mapped(pid: int) -> set[str]:
    """The /dev/shm segments process ``pid`` maps (their names, removed or not)."""
    try:
        maps = Path(f"/proc/{pid}/maps").read_text()
    except OSError:
        return set()
    prefix = f"{SHM_DIR}/"
    return {
        line.split(prefix, 1)[1].removesuffix(" (deleted)").strip()
        for line in maps.splitlines()
        if prefix in line
    }


def _sweep() -> None:
    """What the next recording does first: make a ring (and remove it again)."""
    shm = video_encoder.ring_memory(4096)
    shm.close()
    shm.unlink()


@pytest.mark.heavy
def test_a_recording_killed_with_its_process_group_leaves_no_ring(tmp_path: Path) -> None:
    """``kill -9`` of the sort's process group mid-recording: its ring is not in
    /dev/shm once the next recording has started (it stayed there for good)."""
    argv = [sys.executable, "-m", "mearm", "sort", "--config", "sim_mujoco", "--random", "6",
            "--record", str(tmp_path / "ds"), "--record-codec", "h264"]  # fmt: skip
    sort = subprocess.Popen(
        argv, cwd=tmp_path, env=PYTHON_ENV, stdout=subprocess.PIPE, text=True,
        stderr=subprocess.DEVNULL, start_new_session=True,
    )  # fmt: skip
    try:
        assert sort.stdout is not None
        lines = []
        for line in sort.stdout:  # the first pick-and-place recorded: mid-recording
            lines.append(line)
            if line.startswith("place "):
                break
        rings = _rings_mapped(sort.pid)
        assert rings, f"no ring mapped: the sort did not record ({lines})"
    finally:
        os.killpg(sort.pid, signal.SIGKILL)
        sort.wait(timeout=60)
    deadline = time.monotonic() + 30  # the group's other processes die with it
    while time.monotonic() < deadline and any(_rings_mapped(p) for p in _group(sort.pid)):
        time.sleep(0.1)
    _sweep()
    assert {name for name in rings if (SHM_DIR / name).exists()} == set()


def _group(pgid: int) -> list[int]:
    """The processes still in process group ``pgid``."""
    pids = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if os.getpgid(int(entry.name)) == pgid:
                    pids.append(int(entry.name))
            except OSError:
                continue
    return pids


def _dead_pid() -> int:
    """The id of a process that has ended."""
    done = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)  # fmt: skip
    return int(done.stdout)


def _left_segment(pid: int) -> str:
    """A ring's segment as a kill before the encoder mapped it leaves it, created by ``pid``."""
    name = f"{video_encoder.RING_PREFIX}{pid}-test{os.getpid()}"
    shm = SharedMemory(name, create=True, size=4096)
    resource_tracker.unregister(shm._name, "shared_memory")  # type: ignore[attr-defined]
    shm.close()  # as its killed tracker: nobody removes it now
    return name


def test_the_next_ring_removes_one_whose_creator_is_gone() -> None:
    """A ring left by a process that is gone is removed when a ring is made; one whose
    creator is alive stays."""
    stale = _left_segment(_dead_pid())
    alive = _left_segment(os.getppid())
    try:
        _sweep()
        assert not (SHM_DIR / stale).exists()
        assert (SHM_DIR / alive).exists()
    finally:
        for name in (stale, alive):
            (SHM_DIR / name).unlink(missing_ok=True)


def test_a_ring_leaves_dev_shm_once_the_encoder_maps_it() -> None:
    """The encoder process unlinks the ring's name as soon as it has it mapped: a kill of
    both then leaves nothing (the kernel frees a segment no one maps or names)."""
    encoder = video_encoder.EncoderProcess((48, 64, 3), 10, "h264")
    try:
        name = encoder._shm.name.lstrip("/")  # noqa: SLF001
        assert name.startswith(f"{video_encoder.RING_PREFIX}{os.getpid()}-")
        deadline = time.monotonic() + 60  # the encoder process starting: a hang fails
        while (SHM_DIR / name).exists() and time.monotonic() < deadline:
            assert encoder._proc.is_alive()  # noqa: SLF001
            time.sleep(0.05)
        assert not (SHM_DIR / name).exists()
    finally:
        encoder.close()


# ----------------------------------------------------------------- mearm experiment

#: One object: a quick trial.
ONE = "- {color: red, x: -10.99, y: 49.70}\n"


def _experiment(*args: object) -> Outcome:
    """``mearm experiment --config sim --scene scene.yaml ARGS`` in this process."""
    Path("scene.yaml").write_text(ONE)
    argv = ["experiment", "--config", "sim", "--scene", "scene.yaml", *map(str, args)]
    return run_in_process(argv, within_s=120)


def test_an_experiment_names_its_log_and_its_dataset_before_the_totals(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``wrote LOG`` and ``wrote DIR/ (…)`` on stdout, the totals line still the last; a
    run with nothing to run wrote nothing and names nothing."""
    monkeypatch.chdir(tmp_path)
    out = _experiment("--trials", 1, "--log", "t.jsonl", "--record", "ds",
                      "--record-codec", "h264")  # fmt: skip
    assert out.code == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[-1] == "sorted 1 of 1 objects over 1 trial", lines
    assert lines[-3] == "wrote t.jsonl", lines
    assert re.fullmatch(r"wrote ds/ \(1 episode, \d+ frames\)", lines[-2]), lines
    assert "1 trial written to t.jsonl" in out.stdout
    out = _experiment("--trials", 1, "--log", "t.jsonl")
    assert out.code == 0, out.stderr
    assert out.stdout.splitlines() == [
        "t.jsonl already holds 1 complete trial (--trials 1): nothing to run",
        "sorted 1 of 1 objects over 1 trial",
    ]


def test_a_resumed_run_counts_one_complete_trial_as_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    assert _experiment("--trials", 1, "--log", "t.jsonl").code == 0
    out = _experiment("--trials", 2, "--log", "t.jsonl")
    assert out.code == 0, out.stderr
    assert out.stdout.splitlines()[0] == (
        "resuming t.jsonl: 1 complete trial there, running trials 1..1"
    )


def test_the_analyse_hint_names_a_folder_analyze_writes_without_force(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The hint named ``report/`` though it held another run's report, which ``mearm
    analyze --out report/`` then refused; an empty ``report/`` is still named."""
    monkeypatch.chdir(tmp_path)

    def hint(log: str) -> str:
        out = _experiment("--trials", 1, "--log", log)
        assert out.code == 0, out.stderr
        return next(ln for ln in out.stdout.splitlines() if ln.startswith("analyse: "))

    Path("report").mkdir()
    assert hint("a.jsonl") == "analyse: mearm analyze a.jsonl --out report/"
    assert run_in_process(["analyze", "a.jsonl", "--out", "report/"], within_s=60).code == 0
    assert hint("b.jsonl") == "analyse: mearm analyze b.jsonl --out report-2/"
    assert run_in_process(["analyze", "b.jsonl", "--out", "report-2/"], within_s=60).code == 0
    assert Path("report/report.md").read_text() != Path("report-2/report.md").read_text()


def test_a_dataset_not_empty_is_refused_before_anything_on_stdout(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A resumed log and ``--record`` into a folder that holds a file: exit 2, one line on
    stderr, nothing on stdout (a ``resuming …`` line came first), the log as it was."""
    monkeypatch.chdir(tmp_path)
    assert _experiment("--trials", 1, "--log", "t.jsonl").code == 0
    before = Path("t.jsonl").read_bytes()
    Path("ds").mkdir()
    Path("ds", "notes.txt").write_text("mine\n")
    out = _experiment("--trials", 2, "--log", "t.jsonl", "--record", "ds",
                      "--record-codec", "h264")  # fmt: skip
    assert out.code == 2, out.stderr
    assert out.stdout == ""
    assert len(out.stderr.strip().splitlines()) == 1 and "ds: is not empty" in out.stderr
    assert Path("t.jsonl").read_bytes() == before
