"""The project's benchmarks: timings, measured in one run, printed (never asserted).

    python tools/bench.py [--only SECTION ...] [--repeat N] [--json]

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
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

import numpy as np

from mearm.cli import ArgumentParser, run


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
    from mearm.ik import MinkSolver, PdPij, demo_routes, run_routes  # noqa: PLC0415
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
            calls[f"{key}/{i}"] = lambda s=solver, q=starts[key][i], t=route.target_cm: s.solve(
                q, t
            )
        calls[f"numpy port/{i}"] = lambda q=starts["paper"][i], t=route.target_cm: port(q, t)
        for key in ("paper", "coupled"):  # a 1-iteration solve: the cost per solve
            calls[f"{key} x1/{i}"] = lambda s=one_step[key], q=starts[key][i], t=route.target_cm: (
                s.solve(q, t)
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


# --------------------------------------------------------------------------- main


def main(argv: Sequence[str] | None = None) -> int:
    parser = ArgumentParser(prog="bench.py", description="The project's benchmarks.")
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
