"""``mearm render-calibration --force`` stopped by a signal: the earlier run or the new one, whole.

A real ``python -m mearm render-calibration --force`` writes into a folder that holds an
earlier run (more views, a raised view, truth files) and a file of the user's. The test
watches the folder and, at a chosen moment, freezes the process (SIGSTOP), looks whether
it has done its job, sends it SIGINT (or SIGTERM) if not, and lets it go on (SIGCONT).
Nothing in the folder changes while the process is frozen, so the test knows where the
signal lands, however slowly a loaded machine runs. Afterwards the folder holds the
earlier run byte for byte or the new one, and nothing else (no temporary file); the
command said ``interrupted`` (exit 130; 143 for SIGTERM) or, not signalled, finished
(exit 0). Before the fix a Ctrl-C once the files were being written left part of the
earlier run, part of the new one, or nothing.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from badinput import run_in_process

from mearm.errors import MearmError
from mearm.interrupts import signals_deferred
from mearm.tools.render_calibration import _replace_earlier_run

COMMAND = ["render-calibration", "--config", "sim_mujoco"]
#: The earlier run, and the new one: fewer views and no raised view or truth files, so an
#: earlier file left beside the new ones is seen.
EARLIER = ["--views", "3", "--seed", "1", "--raised-height-cm", "10", "--truth"]
NEW = ["--views", "2", "--seed", "0"]
#: A file of the user's in the folder: every run keeps it.
USERS = {"notes.txt": b"mine\n"}
#: Past this a run or a wait has hung: the test's failure [s].
HANG_S = 300.0
#: How often the folder is looked at [s].
POLL_S = 0.002
#: Runs the first-change case makes at most to land its signal before the run ends.
MOMENT_0_TRIES = 5


def _start(out: Path, *args: str) -> subprocess.Popen[bytes]:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.Popen(
        [sys.executable, "-m", "mearm", *COMMAND, "--out", str(out), *args],
        cwd=out.parent, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )  # fmt: skip


def _files(folder: Path) -> dict[str, bytes]:
    """Every file below ``folder`` (hidden ones too) by its path there, with its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def _state(folder: Path) -> frozenset[tuple[str, int, int]]:
    """What the watcher sees below ``folder``: each entry's path, size and mtime."""
    seen = set()
    for where, folders, files in os.walk(folder):
        for name in folders + files:
            path = os.path.join(where, name)
            try:
                st = os.lstat(path)
            except FileNotFoundError:  # gone since the folder was listed
                continue
            seen.add((os.path.relpath(path, folder), st.st_size, st.st_mtime_ns))
    return frozenset(seen)


def _wait_for(moment: int, folder: Path, proc: subprocess.Popen[bytes]) -> bool:
    """Wait until the folder has changed and then changed ``moment`` times more.

    A change counts once two looks in a row see the folder other than it was (the
    command's check that it may write there, a file made and removed at once, does not).
    False: the process ended first.
    """
    deadline = time.monotonic() + HANG_S
    initial = last = _state(folder)
    changed, changes = False, 0
    while proc.poll() is None:
        assert time.monotonic() < deadline, f"render-calibration still running after {HANG_S} s"
        time.sleep(POLL_S)
        now = _state(folder)
        if not changed:
            changed = now != initial and last != initial
            if changed and moment == 0:
                return True
        elif now != last:
            changes += 1
            if changes >= moment:
                return True
        last = now
    return False


def _wait_stopped(pid: int) -> None:
    """Until the process is frozen (SIGSTOP) or has ended (a zombie, not yet reaped)."""
    deadline = time.monotonic() + HANG_S
    while True:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        if state in ("T", "Z"):
            return
        assert time.monotonic() < deadline, f"process {pid} not stopped after {HANG_S} s"
        time.sleep(0.001)


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, bytes]]:
    """(A folder holding the earlier run and the user's file, the new run's files): both
    run in this process (the signals go to the tests' own runs, each a process)."""
    base = tmp_path_factory.mktemp("runs")
    for out, args in ((base / "earlier", EARLIER), (base / "new", NEW)):
        res = run_in_process([*COMMAND, "--out", out, *args], within_s=30, cwd=base)
        assert res.code == 0, res.stderr
    for name, data in USERS.items():
        (base / "earlier" / name).write_bytes(data)
    return base / "earlier", _files(base / "new")


@pytest.mark.heavy
@pytest.mark.parametrize(
    ("moment", "sig"),
    [
        (0, signal.SIGINT),  # the folder's first change
        (1, signal.SIGINT),  # then the first file written, and later ones: a run makes
        (3, signal.SIGINT),  # about ten changes, two to each file written
        (6, signal.SIGINT),
        (0, signal.SIGTERM),
    ],
)
def test_a_signal_leaves_the_earlier_run_or_the_new_one(
    runs: tuple[Path, dict[str, bytes]], tmp_path: Path, moment: int, sig: signal.Signals
) -> None:
    earlier_folder, new_run = runs
    new = {**new_run, **USERS}
    # The folder's first change is a few milliseconds before the files are written: a
    # loaded machine may run the whole write before the watcher looks twice. That run is
    # checked as a finished one, and the case tries again (at most MOMENT_0_TRIES runs).
    for attempt in range(MOMENT_0_TRIES if moment == 0 else 1):
        folder = tmp_path / f"calib{attempt}"
        shutil.copytree(earlier_folder, folder)
        earlier = _files(folder)
        proc = _start(folder, *NEW, "--force")
        try:
            reached = _wait_for(moment, folder, proc)
            if reached:  # not reaped yet (poll said it ran): the pid is still this process's
                os.kill(proc.pid, signal.SIGSTOP)
                _wait_stopped(proc.pid)
            signalled = reached and _files(folder) != new
            if signalled:
                os.kill(proc.pid, sig)
            if reached:
                os.kill(proc.pid, signal.SIGCONT)
            out, err = proc.communicate(timeout=HANG_S)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
        _check_run(folder, earlier, new, signalled, proc.returncode, out, err, sig)
        if signalled:
            break
    if moment == 0:
        assert signalled, f"every one of {MOMENT_0_TRIES} runs finished before the signal"


def _check_run(
    folder: Path,
    earlier: dict[str, bytes],
    new: dict[str, bytes],
    signalled: bool,
    code: int | None,
    out: bytes,
    err: bytes,
    sig: signal.Signals,
) -> None:
    """The folder holds one run whole, and the command said what became of it."""
    after = _files(folder)
    assert sorted(p.name for p in folder.iterdir()) == sorted(after), "a folder was left"
    whole = after in (earlier, new)
    assert whole, f"neither run whole: {sorted(after)}"
    if signalled:
        assert code == 128 + sig, err.decode()
        assert err.decode().strip() == "mearm render-calibration: interrupted"
        assert out == b""
    else:
        assert code == 0, err.decode()
        assert after == new


@pytest.fixture
def ctrl_c_raises() -> Iterator[None]:
    """Ctrl-C raises KeyboardInterrupt here, as in a command (a test worker may ignore it)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


@pytest.mark.usefixtures("ctrl_c_raises")
def test_a_ctrl_c_during_the_swap_is_taken_after_it() -> None:
    """Received by another thread (MuJoCo's renderer and NumPy start some), where holding
    it back in the main thread (``pthread_sigmask``) does not keep it out of the block."""
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    ran = []
    try:
        with pytest.raises(KeyboardInterrupt), signals_deferred():
            assert other.ident is not None
            signal.pthread_kill(other.ident, signal.SIGINT)
            for _ in range(50):  # Python code, where a KeyboardInterrupt would be raised
                time.sleep(0.001)
            ran.append("to the end")
    finally:
        stop.set()
        other.join()
    assert ran == ["to the end"]


def test_a_rename_that_fails_puts_the_earlier_run_back(tmp_path: Path) -> None:
    """A folder named as one of the new files: refused, and the earlier run kept whole."""
    out, staging = tmp_path / "calib", tmp_path / "calib" / ".render_calibration.1.tmp"
    staging.mkdir(parents=True)
    for name in ("board_00.png", "board_01.png", "raised.png", "notes.txt"):
        (out / name).write_text(f"earlier {name}")
    (out / "sheet.png").mkdir()
    for name in ("board_00.png", "sheet.png"):
        (staging / name).write_text(f"new {name}")
    before = _files(out)
    with pytest.raises(MearmError, match=r"cannot replace sheet\.png .*kept as they were"):
        _replace_earlier_run(staging, out, ["board_00.png", "sheet.png"])
    assert not staging.exists()
    assert _files(out) == {k: v for k, v in before.items() if not k.startswith(".")}
    assert (out / "sheet.png").is_dir()


def test_a_ctrl_c_between_the_writing_and_the_swap_removes_the_hidden_folder(
    tmp_path: Path, runs: tuple[Path, dict[str, bytes]], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A Ctrl-C once every new file is written, before the renames take signals in hand:
    the earlier run is kept whole, and the hidden folder holding the new one goes. (CI's
    signal case once stopped the command there: the folder was left.)"""
    import mearm.tools.render_calibration as tool

    def ctrl_c(*_args: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(tool, "_replace_earlier_run", ctrl_c)
    folder = tmp_path / "calib"
    shutil.copytree(runs[0], folder)
    earlier = _files(folder)
    res = run_in_process([*COMMAND, "--out", folder, *NEW, "--force"], within_s=60)
    assert res.code == 130, res.stderr
    assert sorted(p.name for p in folder.iterdir()) == sorted(earlier), "a folder was left"
    assert _files(folder) == earlier


@pytest.mark.heavy
def test_a_killed_runs_hidden_folder_is_removed(tmp_path: Path) -> None:
    """A run killed outright (SIGKILL) leaves its hidden folder: the next run removes it,
    and does not count it as an earlier run's file."""
    out = tmp_path / "calib"
    leftover = out / ".render_calibration.4242.tmp"
    leftover.mkdir(parents=True)
    (leftover / "board_00.png").write_bytes(b"half")
    res = run_in_process([*COMMAND, "--out", out, "--views", "1"], within_s=60)
    assert res.code == 0, res.stderr
    assert sorted(p.name for p in out.iterdir()) == [
        "board_00.png", "sheet.png", "sheet_markers.txt"
    ]  # fmt: skip
