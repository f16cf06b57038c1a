"""What every benchmark section shares: its options, its rows, the registry, timing."""

from __future__ import annotations

import dataclasses
import math
import os
import platform
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BenchOptions:
    """What every section gets: how many rounds to run.

    Attributes:
        repeat: Rounds; the best is kept.
        ik_targets: The ik section's peer targets (``None``: its 500); a test's hook.
    """

    repeat: int
    ik_targets: int | None = None


@dataclass(frozen=True)
class Row:
    """One measured figure.

    Attributes:
        target: What the figure is held to (``"≤ +100 %"``), or ``""``: none.
        met: Whether the figure met ``target`` (``None``: no target). A missed target
            is said in the row and the bench's last line; it is not a failure of the run.
    """

    section: str
    name: str
    value: float
    unit: str
    note: str = ""
    target: str = ""
    met: bool | None = None


def against(
    row: Row,
    target: str,
    *,
    at_most: float | None = None,
    at_least: float | None = None,
    valid: bool = True,
) -> Row:
    """``row`` held to ``target``: ``met`` when its value is within the bound(s).

    ``valid`` false (a measured run failed) or a value that is not a number is not met.
    """
    value = row.value
    met = (
        valid
        and math.isfinite(value)
        and (at_most is None or value <= at_most)
        and (at_least is None or value >= at_least)
    )
    return dataclasses.replace(row, target=target, met=met)


#: What a row shows in place of a difference of timings that came out ≤ 0: no figure.
BELOW_RESOLUTION = "below timing resolution"


def difference_row(section: str, name: str, value: float, unit: str, note: str, parts: str) -> Row:
    """A figure from a difference of timings; not a number (and said so) unless > 0.

    A difference at or under zero is the timings' noise, not a cost: printed as a
    measurement it would be a negative cost. ``parts`` names the two timings.
    """
    if value > 0:
        return Row(section, name, value, unit, note)
    why = f"{BELOW_RESOLUTION}: {parts}"
    return Row(section, name, float("nan"), unit, f"{why}; {note}" if note else why)


Section = Callable[[BenchOptions], list[Row]]
SECTIONS: dict[str, Section] = {}


def section(name: str) -> Callable[[Section], Section]:
    """Register a benchmark section under ``name`` (used by ``--only``)."""

    def register(fn: Section) -> Section:
        if name in SECTIONS:
            raise ValueError(f"benchmark section {name!r} registered twice")
        SECTIONS[name] = fn
        return fn

    return register


def best_seconds(
    fns: dict[str, Callable[[], object]],
    repeat: int,
    inner: dict[str, int] | None = None,
    progress: str | None = None,
) -> dict[str, float]:
    """Best wall time of each callable [s] over ``repeat`` interleaved rounds.

    In each round callable ``key`` is timed ``inner[key]`` times (default 1): fast ones
    get more tries, so that the best of them escapes other processes' bursts as well as
    the best of one slow call averages over them. ``progress``: a tqdm bar with this
    label on stderr, one tick a round (hidden when stderr is not a terminal).
    """
    from tqdm import tqdm  # noqa: PLC0415

    inner = inner or {}
    best = dict.fromkeys(fns, float("inf"))
    rounds = tqdm(
        range(repeat),
        desc=progress,
        unit="round",
        file=sys.stderr,
        disable=True if progress is None else None,
    )
    for _ in rounds:
        for key, fn in fns.items():
            for _ in range(inner.get(key, 1)):
                t0 = time.perf_counter()
                fn()
                best[key] = min(best[key], time.perf_counter() - t0)
    return best


#: The libraries the bench's figures move with, by distribution and as the line names them:
#: a figure measured with one version of them may not hold with another (MuJoCo's physics
#: and renderer, Pinocchio's and coal's kinematics and distances, OpenCV's detection,
#: PyAV's encoders).
FIGURE_LIBRARIES = (
    ("mujoco", "MuJoCo"),
    ("pin", "Pinocchio"),
    ("coal", "coal"),
    ("opencv-python-headless", "OpenCV"),
    ("av", "PyAV"),
)


def library_versions() -> str:
    """The versions of :data:`FIGURE_LIBRARIES` installed here; one not installed is left out."""
    from importlib import metadata  # noqa: PLC0415

    found = []
    for dist, name in FIGURE_LIBRARIES:
        try:
            found.append(f"{name} {metadata.version(dist)}")
        except metadata.PackageNotFoundError:
            continue
    return ", ".join(found)


def machine() -> str:
    """CPU model, Python and NumPy versions, the figures' libraries' versions, current load.

    The CPU model as ``lscpu`` prints it; the libraries as :func:`library_versions` names
    them.
    """
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        load = f"; load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs"
    except OSError:
        load = ""
    libraries = library_versions()
    libraries = f"; {libraries}" if libraries else ""
    return f"{cpu}; Python {platform.python_version()}; NumPy {np.__version__}{libraries}{load}"


def child_seconds(argv: Sequence[str], env: dict[str, str]) -> tuple[float, float, int]:
    """CPU time (user + sys) [s], wall time [s] and exit status of ``python *argv``."""
    import resource  # noqa: PLC0415
    import subprocess  # noqa: PLC0415

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, *argv], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall, proc.returncode
