"""The project's benchmarks: timings, measured in one run, printed (never asserted).

    mearm bench [--only SECTION ...] [--repeat N] [--json]

Each part of the project registers a section with ``@section("name")``: a function that
takes the parsed :class:`BenchOptions` and returns :class:`Row` s. ``--only`` runs the
named sections; without it every section runs. Timings are the best of ``--repeat``
rounds (the least disturbed by other processes), and the sections being compared are
measured interleaved within each round so that a busy machine slows all of them alike.

Sections:
    ik: PD-PIJ per iteration and per route (``paper`` and ``coupled`` modes) on the
        paper's 24 demo routes, next to a plain NumPy port of the paper's loop
        (:mod:`mearm.ik.reference`) and to the mink cross-check, with ratios.
    vision: ms per 640x480 frame with 12 objects, OpenCV detector next to a plain
        NumPy/SciPy port of the same recipe (:mod:`mearm.vision.bench`) and the paper's
        0.263 s; detection accuracy on rendered scenes; calibration recovery.
    twin: the MuJoCo physical twin's real-time factor (simulated seconds per wall
        second) on ``configs/sim_mujoco.yaml`` and ``configs/sim_5dof_mujoco.yaml``: its
        physics alone during a whole sort, MuJoCo's bare stepping at rest, and the whole
        sort with the rendered camera. A sort takes seconds: at most
        :data:`TWIN_ROUNDS` rounds.
"""

from __future__ import annotations

import functools
import json
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

import numpy as np

from mearm.cli import ArgumentParser, run

if TYPE_CHECKING:
    from mearm.config import Config


@dataclass(frozen=True)
class BenchOptions:
    """What every section gets: how many rounds to run."""

    repeat: int


@dataclass(frozen=True)
class Row:
    """One measured figure."""

    section: str
    name: str
    value: float
    unit: str
    note: str = ""


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
    fns: dict[str, Callable[[], object]], repeat: int, inner: dict[str, int] | None = None
) -> dict[str, float]:
    """Best wall time of each callable [s] over ``repeat`` interleaved rounds.

    In each round callable ``key`` is timed ``inner[key]`` times (default 1): fast ones
    get more tries, so that the best of them escapes other processes' bursts as well as
    the best of one slow call averages over them.
    """
    inner = inner or {}
    best = dict.fromkeys(fns, float("inf"))
    for _ in range(repeat):
        for key, fn in fns.items():
            for _ in range(inner.get(key, 1)):
                t0 = time.perf_counter()
                fn()
                best[key] = min(best[key], time.perf_counter() - t0)
    return best


def machine() -> str:
    """CPU model (as ``lscpu`` prints it), Python and NumPy versions, current load."""
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
    return f"{cpu}; Python {platform.python_version()}; NumPy {np.__version__}{load}"


# --------------------------------------------------------------------------- ik


@section("ik")
def bench_ik(options: BenchOptions) -> list[Row]:
    """PD-PIJ vs the NumPy port of the paper vs mink on the 24 demo routes."""
    import pinocchio as pin  # noqa: PLC0415

    from mearm.config import Config  # noqa: PLC0415
    from mearm.ik import PdPij, demo_routes, run_routes  # noqa: PLC0415
    from mearm.ik.mink_solver import MinkSolver  # noqa: PLC0415
    from mearm.ik.reference import numpy_port_solve  # noqa: PLC0415
    from mearm.kinematics import ArmModel  # noqa: PLC0415

    config = Config()
    model = ArmModel(config.arm)
    routes = demo_routes(config)
    home = model.home

    solvers = {
        "paper": PdPij(model, config.controller.updated(mode="paper")),
        "coupled": PdPij(model, config.controller.updated(mode="coupled")),
        "mink": MinkSolver(model, config.controller),
    }
    # Each solver's own chain of routes fixes where each route starts; then every route
    # is timed on its own (best of many tries) and the bests are summed.
    starts, iterations = {}, {}
    for key, solver in solvers.items():
        results = run_routes(solver, home, routes)
        starts[key] = [home] + [r.q for r in results[:-1]]
        iterations[key] = sum(r.iterations for r in results)
    starts["numpy port"] = starts["paper"]  # the same algorithm: the same chain
    port_iterations = 0
    for q, route in zip(starts["paper"], routes, strict=True):
        _, q_path, _ = numpy_port_solve(q, route.target_cm, config.arm, config.controller)
        port_iterations += len(q_path) - 1
    iterations["numpy port"] = port_iterations

    def port(q: np.ndarray, target: tuple[float, float, float]) -> object:
        return numpy_port_solve(q, target, config.arm, config.controller)

    one_step = {
        key: PdPij(model, config.controller.updated(mode=key, max_iterations=1))
        for key in ("paper", "coupled")
    }
    calls: dict[str, Callable[[], object]] = {}
    for i, route in enumerate(routes):
        for key, solver in solvers.items():
            calls[f"{key}/{i}"] = functools.partial(solver.solve, starts[key][i], route.target_cm)
        calls[f"numpy port/{i}"] = functools.partial(port, starts["paper"][i], route.target_cm)
        for key in ("paper", "coupled"):  # a 1-iteration solve: the cost per solve
            calls[f"{key} x1/{i}"] = functools.partial(
                one_step[key].solve, starts[key][i], route.target_cm
            )
    tries = {"paper": 4, "coupled": 4, "mink": 2, "numpy port": 2, "paper x1": 4, "coupled x1": 4}
    best = best_seconds(calls, options.repeat, {k: tries[k.split("/")[0]] for k in calls})
    seconds = {key: sum(best[f"{key}/{i}"] for i in range(len(routes))) for key in tries}

    n = len(routes)
    per_it = {k: seconds[k] / iterations[k] for k in ("paper", "coupled", "numpy port", "mink")}
    per_route = {k: seconds[k] / n for k in seconds}
    # route time = per-solve cost (target check, first FK, record) + n × loop iteration
    loop_it = {
        k: (seconds[k] - seconds[f"{k} x1"]) / (iterations[k] - n) for k in ("paper", "coupled")
    }
    note = f"{n} demo routes, each timed alone, best of {options.repeat} rounds"
    rows = []
    for key in ("paper", "coupled", "numpy port", "mink"):
        label = f"PD-PIJ {key}" if key in ("paper", "coupled") else key
        rows.append(Row("ik", f"{label}: per iteration", per_it[key] * 1e6, "µs", note))
        rows.append(Row("ik", f"{label}: per route", per_route[key] * 1e3, "ms", note))
        rows.append(Row("ik", f"{label}: iterations per route", iterations[key] / n, "", ""))
    for key in ("paper", "coupled"):
        rows.append(
            Row(
                "ik",
                f"PD-PIJ {key}: cost per solve",
                per_route[f"{key} x1"] * 1e6,
                "µs",
                "a 1-iteration solve: target check, start check, 2 FK, 1 SVD, record",
            )
        )
        rows.append(Row("ik", f"PD-PIJ {key}: per further iteration", loop_it[key] * 1e6, "µs", ""))
    for key in ("paper", "coupled"):
        same = "same algorithm, iteration for iteration" if key == "paper" else ""
        rows.append(
            Row(
                "ik",
                f"numpy port / PD-PIJ {key}, per iteration",
                per_it["numpy port"] / per_it[key],
                "×",
                same,
            )
        )
        rows.append(
            Row(
                "ik",
                f"numpy port / PD-PIJ {key}, per further iteration",
                per_it["numpy port"] / loop_it[key],
                "×",
                "the loop alone, without the per-solve cost",
            )
        )
        rows.append(
            Row(
                "ik",
                f"numpy port / PD-PIJ {key}, per route",
                per_route["numpy port"] / per_route[key],
                "×",
                "",
            )
        )
        rows.append(
            Row("ik", f"mink / PD-PIJ {key}, per route", per_route["mink"] / per_route[key], "×")
        )
    rows.append(
        Row(
            "ik",
            "paper (MATLAB R2018a, i5-2410M) / PD-PIJ paper, per iteration",
            0.072 / per_it["paper"],
            "×",
            "paper §3: 0.072 s per iteration",
        )
    )
    rows.append(Row("ik", "pinocchio", 0.0, "", f"pin {pin.__version__}"))
    return rows


# --------------------------------------------------------------------------- vision


@section("vision")
def bench_vision(options: BenchOptions) -> list[Row]:
    """Detector ms per 640x480 frame vs a NumPy/SciPy port of the recipe; accuracy."""
    from mearm.vision.bench import (  # noqa: PLC0415
        run_calibration_study,
        run_vision_accuracy,
        run_vision_bench,
    )

    rows = run_vision_bench(max(20, 10 * options.repeat))
    rows += run_vision_accuracy() + run_calibration_study()
    return [Row(**r) for r in rows]


# --------------------------------------------------------------------------- twin

#: The twin's configs, by the name the rows show.
TWIN_CONFIGS = ("sim_mujoco", "sim_5dof_mujoco")
#: Most rounds the twin section runs, whatever ``--repeat`` says: each is a whole sort
#: per config (about 10 s on the paper arm).
TWIN_ROUNDS = 3
#: Steps of bare ``mj_step`` timed at the home keyframe per round.
BARE_STEPS = 2000


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

    from mearm.sim.twin_bus import TwinArm  # noqa: PLC0415
    from mearm.sim.twin_camera import TwinCamera  # noqa: PLC0415

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
    out.sorted_text = f"sorted {report.outcome.n_sorted} of {report.outcome.n_seen}"
    return out


def bare_step_seconds(config: Config, steps: int = BARE_STEPS) -> tuple[float, float]:
    """Wall time of ``steps`` bare ``mj_step`` at the home keyframe [s], and the timestep [s].

    MuJoCo's own stepping of the whole scene: no servo model, nothing moving.
    """
    import mujoco  # noqa: PLC0415

    from mearm.sim.twin_bus import TwinArm  # noqa: PLC0415

    twin = TwinArm(config)
    t0 = time.perf_counter()
    mujoco.mj_step(twin.model, twin.data, nstep=steps)
    return time.perf_counter() - t0, float(twin.model.opt.timestep)


def twin_rows(configs: dict[str, Config], rounds: int) -> list[Row]:
    """The twin's rows for each named config: best (and median) of ``rounds`` rounds.

    Each round sorts once on every config in turn (interleaved) and times bare stepping.
    """
    sorts: dict[str, list[TwinSort]] = {name: [] for name in configs}
    bare: dict[str, list[float]] = {name: [] for name in configs}
    for _ in range(rounds):
        for name, config in configs.items():
            sorts[name].append(twin_sort(config))
            seconds, dt = bare_step_seconds(config)
            bare[name].append(BARE_STEPS * dt / seconds)

    def stats(
        values: list[float], best: Callable[[list[float]], float], unit: str
    ) -> tuple[float, str]:
        """The best value, and a note: ``best of 3, median 8.1×``."""
        if len(values) == 1:
            return values[0], "1 round"
        return best(values), f"best of {len(values)}, median {statistics.median(values):.1f}{unit}"

    rows = []
    for name, runs in sorts.items():
        last = runs[-1]
        rtf, how = stats([r.sim_s / r.physics_s for r in runs], max, "×")
        steps_s = max(r.steps / r.physics_s for r in runs)
        dt_ms = last.timestep_s * 1e3
        rows.append(
            Row(
                "twin",
                f"physics ({name}): real-time factor",
                rtf,
                "×",
                f"{dt_ms:g} ms timestep, {steps_s:,.0f} steps/s; {last.sim_s:.1f} s simulated "
                f"in a sort, no rendering; {how}; the bar: ≥ 10×",
            )
        )
        value, how = stats([r.sim_s / r.physics_cpu_s for r in runs], max, "×")
        rows.append(
            Row(
                "twin",
                f"physics ({name}): real-time factor on the CPU",
                value,
                "×",
                f"simulated s per s of the thread's CPU time, which a busy machine's other "
                f"processes do not take; {how}",
            )
        )
        rows.append(
            Row(
                "twin",
                f"physics ({name}): steps per second",
                steps_s,
                "steps/s",
                "mj_step and the servo model (speed limit, backlash)",
            )
        )
        value, how = stats(bare[name], max, "×")
        rows.append(
            Row(
                "twin",
                f"bare mj_step at rest ({name}): real-time factor",
                value,
                "×",
                f"{BARE_STEPS} steps at the home keyframe, no servo model; {how}",
            )
        )
        value, how = stats([r.sort_s for r in runs], min, " s")
        rows.append(
            Row(
                "twin",
                f"whole sort ({name}): wall time",
                value,
                "s",
                f"{last.sim_s:.1f} s simulated, {last.frames} frames rendered, "
                f"{last.sorted_text}; {how}",
            )
        )
        value, how = stats([r.sim_s / r.sort_s for r in runs], max, "×")
        rows.append(
            Row(
                "twin",
                f"whole sort ({name}): real-time factor",
                value,
                "×",
                f"with rendering, detection, IK, opening the rig; {how}",
            )
        )
        render = min((r.render_s / r.frames for r in runs if r.frames), default=0.0)
        cam = configs[name].camera
        size = f"{cam.width_px}x{cam.height_px}, offscreen"
        rows.append(Row("twin", f"render ({name}): per frame", render * 1e3, "ms", size))
        best = min(runs, key=lambda r: r.sort_s)
        rows.append(
            Row(
                "twin",
                f"whole sort ({name}): physics / rendering / rest",
                0.0,
                "",
                " / ".join(
                    f"{100 * part / best.sort_s:.0f} %"
                    for part in (
                        best.physics_s,
                        best.render_s,
                        best.sort_s - best.physics_s - best.render_s,
                    )
                )
                + " of the fastest sort's wall time",
            )
        )
    return rows


@section("twin")
def bench_twin(options: BenchOptions) -> list[Row]:
    """The MuJoCo twin's real-time factor, physics alone and in a whole sort."""
    from mearm.config import load_config  # noqa: PLC0415

    configs = {name: load_config(name) for name in TWIN_CONFIGS}
    return twin_rows(configs, min(options.repeat, TWIN_ROUNDS))


# --------------------------------------------------------------------------- main


def main(argv: Sequence[str] | None = None) -> int:
    """Run the chosen sections and print their rows; 0 on success."""
    parser = ArgumentParser(description="The project's benchmarks.")
    parser.add_argument(
        "--only",
        action="append",
        choices=sorted(SECTIONS),
        help="run only this section (repeatable); default: all",
    )
    parser.add_argument(
        "--repeat", type=int, default=5, help="rounds; the best is kept (default 5)"
    )
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error(f"--repeat must be at least 1, got {args.repeat}")
    options = BenchOptions(repeat=args.repeat)
    rows: list[Row] = []
    for name in args.only or list(SECTIONS):
        rows += SECTIONS[name](options)
    if args.json:
        json.dump({"machine": machine(), "rows": [asdict(r) for r in rows]}, sys.stdout, indent=1)
        print()
        return 0
    print(f"machine: {machine()}")
    for row in rows:
        value = f"{row.value:12.3f} {row.unit}" if row.unit else f"{row.value:12.2f}"
        if row.unit == "" and row.value == 0.0:
            value = ""
        note = f"  ({row.note})" if row.note else ""
        print(f"[{row.section}] {row.name:<58} {value}{note}")
    return 0


if __name__ == "__main__":
    run(main)
