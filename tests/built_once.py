"""Expensive fixtures built once per test run, shared by every xdist worker.

A module-scoped fixture runs once in each worker that runs one of its module's tests:
with three workers, a wheel is built and installed three times. :func:`built_once`
builds a folder once per run, under the run's shared temporary folder, behind a file lock:
the first worker builds it, the others wait and reuse it. A build that fails leaves no
finished folder behind (the next worker tries again and fails the same way).
"""

from __future__ import annotations

import fcntl
import os
import pickle
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import pytest

T = TypeVar("T")


def built_once(factory: pytest.TempPathFactory, name: str, build: Callable[[Path], None]) -> Path:
    """The folder ``name``, filled by ``build(folder)`` the first time any worker asks.

    Whatever reads it must not write into it: every worker sees the same folder.
    """
    base = factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        base = base.parent  # the run's folder, above each worker's own
    path = base / f"built-once-{name}"
    with open(base / f"built-once-{name}.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        done = base / f"built-once-{name}.built"  # beside it: the folder holds only the build
        if not done.exists():
            shutil.rmtree(path, ignore_errors=True)
            path.mkdir()
            build(path)
            done.touch()
    return path


def computed_once(factory: pytest.TempPathFactory, name: str, compute: Callable[[], T]) -> T:
    """``compute()``, computed once per test run and shared by the workers (pickled)."""

    def build(path: Path) -> None:
        (path / "value.pickle").write_bytes(pickle.dumps(compute()))

    return pickle.loads((built_once(factory, name, build) / "value.pickle").read_bytes())
