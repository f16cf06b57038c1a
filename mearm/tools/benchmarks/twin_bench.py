"""The ``twin`` section: the MuJoCo twin's real-time factor, physics alone and in a sort."""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from mearm.tools.benchmarks.bench_base import BenchOptions, Row, against, child_seconds, section

if TYPE_CHECKING:
    from mearm.config import Config


#: The twin's configs, by the name the rows show.
TWIN_CONFIGS = ("sim_mujoco", "sim_5dof_mujoco")
#: Most rounds the twin section runs, whatever ``--repeat`` says: each is a whole sort
#: per config (about 10 s on the paper arm).
TWIN_ROUNDS = 3
#: Steps of bare ``mj_step`` timed at the home keyframe per round.
BARE_STEPS = 2000
#: The bar of the physics' real-time factor during a sort [×].
PHYSICS_RTF_BAR = 50.0
#: The bar of the paper arm's whole sort process's real-time factor [×].
PROCESS_RTF_BAR = 15.0


@dataclass
class TwinSort:
    """What one sort on the twin cost.

    Attributes:
        physics_s: Wall time inside the twin's physics (``TwinArm._run``) [s].
        physics_cpu_s: The thread's CPU time in there [s]: what other processes on a
            busy machine do not inflate.
        sim_s: Simulated time the physics advanced [s].
        steps: Physics steps taken.
        timestep_s: The model's timestep [s].
        render_s: Wall time rendering camera frames [s].
        frames: Frames rendered.
        sort_s: Wall time of the whole sort: opening the rig (building the model, the
            renderer), detection, IK, physics, rendering [s].
        sorted_text: ``"sorted N of M"``.
    """

    physics_s: float = 0.0
    physics_cpu_s: float = 0.0
    sim_s: float = 0.0
    steps: int = 0
    timestep_s: float = 0.0
    render_s: float = 0.0
    frames: int = 0
    sort_s: float = 0.0
    sorted_text: str = ""


@contextmanager
def _timing_twin(into: TwinSort) -> Iterator[None]:
    """Time the twin's physics and its camera's rendering into ``into`` while open."""
    from unittest import mock  # noqa: PLC0415

    from mearm.sim.twin.twin_bus import TwinArm  # noqa: PLC0415
    from mearm.sim.twin.twin_camera import TwinCamera  # noqa: PLC0415

    run_physics, read_frame = TwinArm._run, TwinCamera._read

    def timed_run(self: TwinArm, seconds: float) -> None:
        t_sim, t0, c0 = self.data.time, time.perf_counter(), time.thread_time()
        run_physics(self, seconds)
        into.physics_s += time.perf_counter() - t0
        into.physics_cpu_s += time.thread_time() - c0
        into.sim_s += self.data.time - t_sim
        into.steps += max(0, round(seconds / self.model.opt.timestep))
        into.timestep_s = self.model.opt.timestep

    def timed_read(self: TwinCamera) -> np.ndarray:
        t0 = time.perf_counter()
        frame = read_frame(self)
        into.render_s += time.perf_counter() - t0
        into.frames += 1
        return frame

    with (
        mock.patch.object(TwinArm, "_run", timed_run),
        mock.patch.object(TwinCamera, "_read", timed_read),
    ):
        yield


def twin_sort(config: Config) -> TwinSort:
    """One whole sort on the twin (:func:`~mearm.task.rig.run_sort`), timed."""
    from mearm.task.rig import run_sort  # noqa: PLC0415

    out = TwinSort()
    with _timing_twin(out):
        t0 = time.perf_counter()
        report = run_sort(config, echo=None)
        out.sort_s = time.perf_counter() - t0
    out.sorted_text = f"sorted {report.outcome.n_sorted} of {report.outcome.n_objects}"
    return out


def bare_step_seconds(config: Config, steps: int = BARE_STEPS) -> tuple[float, float]:
    """Wall time of ``steps`` bare ``mj_step`` at the home keyframe [s], and the timestep [s].

    MuJoCo's own stepping of the whole scene: no servo model, nothing moving.
    """
    import mujoco  # noqa: PLC0415

    from mearm.sim.twin.twin_bus import TwinArm  # noqa: PLC0415

    twin = TwinArm(config)
    t0 = time.perf_counter()
    mujoco.mj_step(twin.model, twin.data, nstep=steps)
    return time.perf_counter() - t0, float(twin.model.opt.timestep)


def twin_process_seconds(args: Sequence[str], env: dict[str, str]) -> tuple[float, float, int]:
    """CPU [s], wall [s] and exit status of ``python -m mearm.sort ARGS --quiet``."""
    return child_seconds(("-m", "mearm.sort", *args, "--quiet"), env)


@dataclass
class TwinRuns:
    """One config's rounds in the twin section.

    Attributes:
        sorts: Each round's sort in this process.
        bare_rtf: Each round's real-time factor of bare stepping [×].
        process: Each round's whole process: (CPU [s], wall [s], exit status).
    """

    sorts: list[TwinSort] = field(default_factory=list)
    bare_rtf: list[float] = field(default_factory=list)
    process: list[tuple[float, float, int]] = field(default_factory=list)


def twin_rows(
    configs: dict[str, Config], rounds: int, args: Mapping[str, Sequence[str]]
) -> list[Row]:
    """The twin's rows for each named config: best (and median) of ``rounds`` rounds.

    Each round sorts once on every config in turn (interleaved) in this process, times
    bare stepping, and runs the same sort as a whole process (interpreter start, imports,
    the rig, physics, rendering, detection), bytecode cached as an installed package's:
    ``python -m mearm.sort`` with ``args[name]`` (``--config …``, the same config).
    """
    rows = []
    for name, runs in _measure(configs, rounds, args).items():
        rows += _physics_rows(name, runs)
        rows += _sort_rows(name, runs.sorts)
        rows += _process_rows(name, runs, args[name])
        rows += _render_rows(name, runs.sorts, configs[name])
    return rows


def _measure(
    configs: dict[str, Config], rounds: int, args: Mapping[str, Sequence[str]]
) -> dict[str, TwinRuns]:
    """Every config's rounds, interleaved (see :func:`twin_rows`)."""
    runs = {name: TwinRuns() for name in configs}
    with tempfile.TemporaryDirectory(prefix="mearm-pyc-") as cache:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        env["PYTHONPYCACHEPREFIX"] = cache
        for name in configs:
            twin_process_seconds(args[name], env)  # writes the bytecode
        for _ in range(rounds):
            for name, config in configs.items():
                runs[name].sorts.append(twin_sort(config))
                seconds, dt = bare_step_seconds(config)
                runs[name].bare_rtf.append(BARE_STEPS * dt / seconds)
                runs[name].process.append(twin_process_seconds(args[name], env))
    return runs


def _stats(
    values: list[float], best: Callable[[list[float]], float], unit: str
) -> tuple[float, str]:
    """The best value, and a note: ``best of 3, median 8.1×``."""
    if len(values) == 1:
        return values[0], "1 round"
    return best(values), f"best of {len(values)}, median {statistics.median(values):.1f}{unit}"


def _physics_rows(name: str, runs: TwinRuns) -> list[Row]:
    """The physics alone: real-time factor (wall and CPU), steps per second, bare steps."""
    sorts = runs.sorts
    last = sorts[-1]
    rtf, how = _stats([r.sim_s / r.physics_s for r in sorts], max, "×")
    steps_s = max(r.steps / r.physics_s for r in sorts)
    dt_ms = last.timestep_s * 1e3
    cpu_rtf, cpu_how = _stats([r.sim_s / r.physics_cpu_s for r in sorts], max, "×")
    bare, bare_how = _stats(runs.bare_rtf, max, "×")
    bar = f"≥ {PHYSICS_RTF_BAR:g}×"
    physics = Row(
        "twin",
        f"physics ({name}): real-time factor",
        rtf,
        "×",
        f"{dt_ms:g} ms timestep, {steps_s:,.0f} steps/s; {last.sim_s:.1f} s simulated "
        f"in a sort, no rendering; {how}; the bar: {bar}",
    )
    return [
        against(physics, bar, at_least=PHYSICS_RTF_BAR),
        Row(
            "twin",
            f"physics ({name}): real-time factor on the CPU",
            cpu_rtf,
            "×",
            f"simulated s per s of the thread's CPU time, which a busy machine's other "
            f"processes do not take; {cpu_how}",
        ),
        Row(
            "twin",
            f"physics ({name}): steps per second",
            steps_s,
            "steps/s",
            "mj_step and the servo model (speed limit, backlash)",
        ),
        Row(
            "twin",
            f"bare mj_step at rest ({name}): real-time factor",
            bare,
            "×",
            f"{BARE_STEPS} steps at the home keyframe, no servo model; {bare_how}",
        ),
    ]


def _sort_rows(name: str, sorts: list[TwinSort]) -> list[Row]:
    """The whole sort in this process: wall time and real-time factor."""
    last = sorts[-1]
    wall, how = _stats([r.sort_s for r in sorts], min, " s")
    rtf, rtf_how = _stats([r.sim_s / r.sort_s for r in sorts], max, "×")
    return [
        Row(
            "twin",
            f"whole sort ({name}): wall time",
            wall,
            "s",
            f"{last.sim_s:.1f} s simulated, {last.frames} frames rendered, "
            f"{last.sorted_text}; {how}",
        ),
        Row(
            "twin",
            f"whole sort ({name}): real-time factor",
            rtf,
            "×",
            f"with rendering, detection, IK, opening the rig; {rtf_how}",
        ),
    ]


def _process_rows(name: str, runs: TwinRuns, args: Sequence[str]) -> list[Row]:
    """The same sort as a whole process: real-time factor per wall and per CPU second."""
    sim_s = runs.sorts[-1].sim_s
    failed = [r[2] for r in runs.process if r[2] != 0]
    extra = f"; EXIT STATUS {failed}" if failed else ""
    wall, how = _stats([sim_s / r[1] for r in runs.process], max, "×")
    cpu, cpu_how = _stats([sim_s / r[0] for r in runs.process], max, "×")
    bar = f"≥ {PROCESS_RTF_BAR:g}×"
    process = Row(
        "twin",
        f"whole process ({name}): real-time factor",
        wall,
        "×",
        f"python -m mearm.sort {' '.join(args)}: {sim_s:.1f} s simulated "
        f"per s of wall time, interpreter start included; {how}"
        f"{f'; the bar: {bar}' if name == 'sim_mujoco' else ''}{extra}",
    )
    if name == "sim_mujoco":  # the bar is the paper arm's
        process = against(process, bar, at_least=PROCESS_RTF_BAR, valid=not failed)
    return [
        process,
        Row(
            "twin",
            f"whole process ({name}): real-time factor on the CPU",
            cpu,
            "×",
            f"per s of the process's CPU time (user + sys); {cpu_how}",
        ),
    ]


def _render_rows(name: str, sorts: list[TwinSort], config: Config) -> list[Row]:
    """Rendering per frame, and how the fastest sort's wall time divides."""
    render = min((r.render_s / r.frames for r in sorts if r.frames), default=0.0)
    cam = config.camera
    size = f"{cam.width_px}x{cam.height_px}, offscreen"
    best = min(sorts, key=lambda r: r.sort_s)
    parts = (best.physics_s, best.render_s, best.sort_s - best.physics_s - best.render_s)
    return [
        Row("twin", f"render ({name}): per frame", render * 1e3, "ms", size),
        Row(
            "twin",
            f"whole sort ({name}): physics / rendering / rest",
            0.0,
            "",
            " / ".join(f"{100 * part / best.sort_s:.0f} %" for part in parts)
            + " of the fastest sort's wall time",
        ),
    ]


@section("twin")
def bench_twin(options: BenchOptions) -> list[Row]:
    """The MuJoCo twin's real-time factor, physics alone and in a whole sort."""
    from mearm.config import load_config  # noqa: PLC0415

    configs = {name: load_config(name) for name in TWIN_CONFIGS}
    args = {name: ("--config", name) for name in TWIN_CONFIGS}
    return twin_rows(configs, min(options.repeat, TWIN_ROUNDS), args)
