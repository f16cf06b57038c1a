"""Ctrl-C held back while an episode is written, or a temporary file made, with threads alive.

``no_interrupt()`` (an episode being written, :mod:`mearm.dataset.sampler`) and
``write_atomic``'s making of its temporary file (:mod:`mearm.fileio`) blocked SIGINT with
``pthread_sigmask`` in the calling thread only. With another thread alive that takes the
signal (a recorder's writer thread is one: Mesa's renderer threads block every signal,
and ``import mearm`` keeps NumPy's OpenBLAS to one thread), the kernel hands the signal
to that thread and Python raised ``KeyboardInterrupt`` in the main thread, inside the
block all the same: an episode cut in the middle of its writing, a temporary file
made but not yet known, left behind. The main thread now takes the signals after the
block (:func:`mearm.interrupts.signals_deferred`); another thread still blocks them.

Each case is a real process that sends itself SIGINT inside the block and waits until
the signal has come (its wake-up byte), so where ``KeyboardInterrupt`` is raised does not
depend on timing.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from conftest import ROOT

from mearm import fileio
from mearm.dataset.sampler import no_interrupt

#: The child: a thread like a recorder's writer alive, then SIGINT inside a block.
CHILD = r"""
import json, os, select, signal, sys, tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from mearm import fileio
from mearm.dataset.sampler import no_interrupt

writer = ThreadPoolExecutor(max_workers=1)  # as a DatasetRecorder's writer thread
writer.submit(lambda: None).result()


def takes_sigint(task):
    status = Path(f"/proc/self/task/{task}/status").read_text()
    blocked = int(status.split("SigBlk:")[1].split()[0], 16)
    return not blocked & (1 << (signal.SIGINT - 1))


if not any(takes_sigint(t) for t in os.listdir("/proc/self/task") if int(t) != os.getpid()):
    sys.exit(3)  # no other thread takes the signal: the case would show nothing
wake_r, wake_w = os.pipe()
os.set_blocking(wake_w, False)
signal.set_wakeup_fd(wake_w)


def ctrl_c():
    # to the process, as a terminal's: the kernel picks a thread that does not block it
    os.kill(os.getpid(), signal.SIGINT)
    select.select([wake_r], [], [])  # it has come: its C handler ran, in some thread
    for _ in range(1000):  # the main thread checks for it here at the latest
        pass


stage = "before"
if sys.argv[1] == "no_interrupt":
    try:
        with no_interrupt():
            stage = "inside"
            ctrl_c()
            stage = "the block's end"
        stage = "after"
    except KeyboardInterrupt:
        print(json.dumps({"interrupted at": stage}))
else:
    folder = Path(sys.argv[2])
    target = folder / "kept.json"
    target.write_text("old")
    real = tempfile.mkstemp

    def mkstemp(*args, **kwargs):
        made = real(*args, **kwargs)
        ctrl_c()
        return made

    tempfile.mkstemp = mkstemp
    try:
        fileio.write_atomic(target, "new")
    except KeyboardInterrupt:
        print(json.dumps({"files": sorted(os.listdir(folder)), "kept": target.read_text()}))
"""


def _child(*args: str) -> dict[str, object]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run(
        [sys.executable, "-c", CHILD, *args],
        capture_output=True, text=True, cwd=ROOT, env=env, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 0, f"exit {proc.returncode}: {proc.stdout}{proc.stderr}"
    return json.loads(proc.stdout)


@pytest.mark.heavy
def test_ctrl_c_while_an_episode_is_written_comes_after_it() -> None:
    """``KeyboardInterrupt`` at the block's end, not inside (before: inside)."""
    assert _child("no_interrupt") == {"interrupted at": "the block's end"}


@pytest.mark.heavy
def test_ctrl_c_while_write_atomic_makes_its_file_leaves_none(tmp_path: Path) -> None:
    """Ctrl-C as the temporary file is made: raised once it is known, and removed; the
    target untouched (before: raised before it was known, ``.kept.json.*.tmp`` left)."""
    assert _child("write_atomic", str(tmp_path)) == {"files": ["kept.json"], "kept": "old"}


def test_outside_the_main_thread_the_signals_are_blocked_in_that_thread() -> None:
    """Where no handler can be set (a writer thread, a Dask worker's): blocked there for
    the block, as before, the handlers left as they were."""
    seen: dict[str, set[int]] = {}
    handler = signal.getsignal(signal.SIGINT)

    def work() -> None:
        for name, held in (("no_interrupt", no_interrupt), ("signals_held", fileio.signals_held)):
            with held():
                seen[name] = set(signal.pthread_sigmask(signal.SIG_BLOCK, []))
        seen["after"] = set(signal.pthread_sigmask(signal.SIG_BLOCK, []))

    thread = threading.Thread(target=work)
    thread.start()
    thread.join()
    held = {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}
    assert held <= seen["no_interrupt"] and held <= seen["signals_held"]
    assert not held & seen["after"]
    assert signal.getsignal(signal.SIGINT) is handler
