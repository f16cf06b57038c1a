"""The ``ik`` section: PD-PIJ beside the NumPy port of the paper and mink on the demo routes."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from mearm.tools.benchmarks.bench_base import BenchOptions, Row, best_seconds, section
from mearm.tools.benchmarks.ik_peers import PEER_TARGETS, ik_peer_rows

if TYPE_CHECKING:
    from mearm.config import Config

#: The solvers on the demo routes, as the rows name them, in the order they are listed.
DEMO_SOLVERS = ("paper", "coupled", "numpy port", "mink")


@section("ik")
def bench_ik(options: BenchOptions) -> list[Row]:
    """PD-PIJ vs the NumPy port of the paper vs mink on the 24 demo routes."""
    import pinocchio as pin  # noqa: PLC0415

    from mearm.config import Config  # noqa: PLC0415

    config = Config()
    seconds, iterations, n = _demo_route_seconds(config, options.repeat)
    per_it = {k: seconds[k] / iterations[k] for k in DEMO_SOLVERS}
    per_route = {k: seconds[k] / n for k in seconds}
    note = f"{n} demo routes, each timed alone, best of {options.repeat} rounds"
    rows = []
    for key in DEMO_SOLVERS:
        label = f"PD-PIJ {key}" if key in ("paper", "coupled") else key
        rows.append(Row("ik", f"{label}: per iteration", per_it[key] * 1e6, "µs", note))
        rows.append(Row("ik", f"{label}: per route", per_route[key] * 1e3, "ms", note))
        rows.append(Row("ik", f"{label}: iterations per route", iterations[key] / n, "", ""))
    rows += _ratio_rows(per_it, per_route)
    rows.append(Row("ik", "pinocchio", 0.0, "", f"pin {pin.__version__}"))
    n_targets = PEER_TARGETS if options.ik_targets is None else options.ik_targets
    return ik_peer_rows(config, options, n_targets) + rows


def _demo_route_seconds(
    config: Config, repeat: int
) -> tuple[dict[str, float], dict[str, int], int]:
    """Per solver: the demo routes' summed best times [s] and iterations; the route count.

    Each solver's own chain of routes fixes where each route starts; then every route
    is timed on its own (best of many tries) and the bests are summed.
    """
    from mearm.ik import PdPij, demo_routes, run_routes  # noqa: PLC0415
    from mearm.ik.mink_solver import MinkSolver  # noqa: PLC0415
    from mearm.ik.paper_port import numpy_port_solve  # noqa: PLC0415
    from mearm.kinematics import ArmModel  # noqa: PLC0415

    model = ArmModel(config.arm)
    routes = demo_routes(config.arm.tool, config.task)
    home = model.home
    solvers = {
        "paper": PdPij(model, config.controller.updated(mode="paper")),
        "coupled": PdPij(model, config.controller.updated(mode="coupled")),
        "mink": MinkSolver(model, config.controller),
    }
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

    calls: dict[str, Callable[[], object]] = {}
    for i, route in enumerate(routes):
        for key, solver in solvers.items():
            calls[f"{key}/{i}"] = functools.partial(solver.solve, route.target_cm, starts[key][i])
        calls[f"numpy port/{i}"] = functools.partial(port, starts["paper"][i], route.target_cm)
    tries = {"paper": 4, "coupled": 4, "mink": 2, "numpy port": 2}
    best = best_seconds(calls, repeat, {k: tries[k.split("/")[0]] for k in calls}, "ik demo routes")
    seconds = {key: sum(best[f"{key}/{i}"] for i in range(len(routes))) for key in tries}
    return seconds, iterations, len(routes)


def _ratio_rows(per_it: dict[str, float], per_route: dict[str, float]) -> list[Row]:
    """The NumPy port and mink over each PD-PIJ mode; the paper's MATLAB over PD-PIJ."""
    rows = []
    for key in ("paper", "coupled"):
        same = "same algorithm, iteration for iteration" if key == "paper" else ""
        rows += [
            Row(
                "ik",
                f"numpy port / PD-PIJ {key}, per iteration",
                per_it["numpy port"] / per_it[key],
                "×",
                same,
            ),
            Row(
                "ik",
                f"numpy port / PD-PIJ {key}, per route",
                per_route["numpy port"] / per_route[key],
                "×",
                "",
            ),
            Row("ik", f"mink / PD-PIJ {key}, per route", per_route["mink"] / per_route[key], "×"),
        ]
    rows.append(
        Row(
            "ik",
            "paper (MATLAB R2018a, i5-2410M) / PD-PIJ paper, per iteration",
            0.072 / per_it["paper"],
            "×",
            "paper §3: 0.072 s per iteration",
        )
    )
    return rows
