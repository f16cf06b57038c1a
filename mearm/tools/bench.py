"""The project's benchmarks: timings, measured in one run, printed (never asserted).

    mearm bench [--only SECTION ...] [--repeat N] [--json] [--out FILE]

Each part of the project registers a section with ``@section("name")``: a function that
takes the parsed :class:`BenchOptions` and returns :class:`Row` s. ``--only`` runs the
named sections; without it every section runs. Timings are the best of ``--repeat``
rounds (the least disturbed by other processes), and the sections being compared are
measured interleaved within each round so that a busy machine slows all of them alike.

Sections:
    ik: the peers on the same 500 seeded reachable targets, each held to |e| < 0.01 cm
        from home: Robotics Toolbox's C++ ``ik_LM`` on the same 3-joint kinematics
        (skipped, in one line, without the ``bench`` extra), the fastest solve mearm
        ships for the arm (:func:`mearm.ik.fastest_solver`) from home (the peer's start,
        beside its target ≤ 0.25×) and from a new start each call, the batch solve
        (:func:`mearm.ik.batch.solve_batch`), the generic solve,
        PD-PIJ (µs per iteration and fixed cost per solve) and the NumPy port of the
        paper's loop (:mod:`mearm.ik.paper_port`), with ratios. Then PD-PIJ per iteration
        and per route (``paper`` and ``coupled`` modes) on the paper's 24 demo routes,
        next to the NumPy port and the mink cross-check.
    vision: ms per 640x480 frame with 12 objects, OpenCV detector next to a plain
        NumPy/SciPy port of the same recipe (:mod:`mearm.tools.vision_bench`) and the paper's
        0.263 s; detection accuracy on rendered scenes; calibration recovery.
    sort-cpu: CPU time (user + sys, median of 3) of the 12-object simulated sort as a
        child process, interpreter start included, with and without the bytecode cache,
        beside its peer, importing its dependencies (numpy, cv2, pinocchio, yaml,
        pydantic), and the ratio with its target (≤ 2×); the sort's imports, a bare
        interpreter and the 5-DOF arm's sort (its start-up check solves in a batch).
    motion: the predicted motion time of the paper's 12-object scene (servo speed limits,
        gripper settings and settling) in the paper's colour order and nearest-first,
        beside the paper's ≈ 144 s.
    twin: the MuJoCo physical twin's real-time factor (simulated seconds per wall
        second) on ``configs/sim_mujoco.yaml`` and ``configs/sim_5dof_mujoco.yaml``: its
        physics alone during a whole sort, MuJoCo's bare stepping at rest, and the whole
        sort with the rendered camera. A sort takes seconds: at most
        :data:`TWIN_ROUNDS` rounds.
"""

from __future__ import annotations

import functools
import itertools
import json
import os
import platform
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mearm.cli import ArgumentParser, run, write_text_atomic

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
    from mearm.ik.paper_port import numpy_port_solve  # noqa: PLC0415
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

    calls: dict[str, Callable[[], object]] = {}
    for i, route in enumerate(routes):
        for key, solver in solvers.items():
            calls[f"{key}/{i}"] = functools.partial(solver.solve, route.target_cm, starts[key][i])
        calls[f"numpy port/{i}"] = functools.partial(port, starts["paper"][i], route.target_cm)
    tries = {"paper": 4, "coupled": 4, "mink": 2, "numpy port": 2}
    best = best_seconds(
        calls, options.repeat, {k: tries[k.split("/")[0]] for k in calls}, "ik demo routes"
    )
    seconds = {key: sum(best[f"{key}/{i}"] for i in range(len(routes))) for key in tries}

    n = len(routes)
    per_it = {k: seconds[k] / iterations[k] for k in ("paper", "coupled", "numpy port", "mink")}
    per_route = {k: seconds[k] / n for k in seconds}
    note = f"{n} demo routes, each timed alone, best of {options.repeat} rounds"
    rows = []
    for key in ("paper", "coupled", "numpy port", "mink"):
        label = f"PD-PIJ {key}" if key in ("paper", "coupled") else key
        rows.append(Row("ik", f"{label}: per iteration", per_it[key] * 1e6, "µs", note))
        rows.append(Row("ik", f"{label}: per route", per_route[key] * 1e3, "ms", note))
        rows.append(Row("ik", f"{label}: iterations per route", iterations[key] / n, "", ""))
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
    return ik_peer_rows(config, options) + rows


#: Targets of the peer comparison, their seed and the tolerance every solver is held to.
PEER_TARGETS = 500
PEER_SEED = 16
PEER_TOLERANCE_CM = 0.01
#: Targets the NumPy port of the paper's loop solves (about 5 ms each): the first ones.
PORT_TARGETS = 50


def reachable_targets(config: Config, n: int, seed: int) -> np.ndarray:
    """``n`` targets uniform in the arm's target box that the arm reaches, (n, 3) [cm].

    Reachable: the closed form solves it within the limits, or, for an arm without one,
    it is the TCP of joints drawn uniformly within the limits (kept when in the box).
    """
    from mearm.kinematics import ArmModel, closed_form_for  # noqa: PLC0415
    from mearm.kinematics.errors import UnreachableTargetError  # noqa: PLC0415

    rng = np.random.default_rng(seed)
    box = config.arm.target_box
    lo = np.array([box.x_cm.min, box.y_cm.min, box.z_cm.min])
    hi = np.array([box.x_cm.max, box.y_cm.max, box.z_cm.max])
    closed_form = closed_form_for(config.arm)
    model = ArmModel(config.arm)
    chain = model.chain
    out: list[np.ndarray] = []
    while len(out) < n:
        if closed_form is not None:
            t = rng.uniform(lo, hi)
            try:
                closed_form.solve(t)
            except UnreachableTargetError:
                continue
        else:
            t = model.fk_cm(chain.full(rng.uniform(chain.actuated_lower, chain.actuated_upper)))
            if np.any(t < lo) or np.any(t > hi):
                continue
        out.append(t)
    return np.array(out)


def rtb_ets(config: Config) -> tuple[Any, str]:
    r"""The arm's TCP position kinematics as a Robotics Toolbox ETS, and a note.

    ``(None, why)`` when ``roboticstoolbox-python`` is not installed (the ``bench``
    extra) or the arm has no 3-joint ETS here: only the ``planar_wrist`` arms, whose
    levelled wrist makes the TCP offset a constant along the yawed radial direction,

    .. math:: R_z(q_0)\,t_z(d_1)\,t_x(a_1 + a_4 + t_x)\,R_x(\alpha_1)\,t_y(t_y)\,
              R_z(q_1)\,t_x(a_2)\,R_z(q_2)\,t_x(a_3)

    in centimetres: the same map from the 3 actuated joints to the TCP position, with
    the same limits (the bench checks FK against mearm's on random joints).
    """
    try:
        import roboticstoolbox as rtb  # noqa: PLC0415
    except ImportError:
        return None, "roboticstoolbox-python not installed (pip install 'mearm[bench]')"
    arm = config.arm
    if arm.closed_form != "planar_wrist":
        return None, f"no 3-joint ETS for arm {arm.name!r} (only planar_wrist arms)"
    from mearm.kinematics import Chain  # noqa: PLC0415

    chain = Chain.from_description(arm)
    lo, hi = chain.actuated_lower, chain.actuated_upper
    base, shoulder, elbow, wrist = (j.dh for j in arm.joints)
    tx, ty, _ = arm.tool.tcp_cm
    ET = rtb.ET
    ets = (
        ET.Rz(qlim=[lo[0], hi[0]])
        * ET.tz(base.d_cm)
        * ET.tx(base.a_cm + wrist.a_cm + tx)
        * ET.Rx(np.radians(base.alpha_deg))
        * ET.ty(ty)
        * ET.Rz(qlim=[lo[1], hi[1]])
        * ET.tx(shoulder.a_cm)
        * ET.Rz(qlim=[lo[2], hi[2]])
        * ET.tx(elbow.a_cm)
    )
    return ets, f"roboticstoolbox-python {rtb.__version__}, ETS built once"


def ik_peer_rows(config: Config, options: BenchOptions, n_targets: int = PEER_TARGETS) -> list[Row]:
    """The fastest solve mearm ships, its generic solve and PD-PIJ next to RTB ``ik_LM``.

    Every solver starts from home and is held to |e| < :data:`PEER_TOLERANCE_CM` on the
    same :data:`PEER_TARGETS` seeded reachable targets; a solve counts as a success when
    an independent FK (Pinocchio) of its joints is that close and they are within the
    limits. Rounds are interleaved; each solver's best round is kept.
    """
    from tqdm import tqdm  # noqa: PLC0415

    from mearm.ik import NewtonIK, PdPij, fastest_solver  # noqa: PLC0415
    from mearm.ik.batch import solve_batch  # noqa: PLC0415
    from mearm.ik.paper_port import numpy_port_solve  # noqa: PLC0415
    from mearm.kinematics import ArmModel  # noqa: PLC0415

    model = ArmModel(config.arm)
    chain = model.chain
    home = model.home
    targets = reachable_targets(config, n_targets, PEER_SEED)
    n = len(targets)
    n_port = min(PORT_TARGETS, n)
    tol2 = PEER_TOLERANCE_CM**2
    # PD-PIJ stops when |e|² < tolerance: just under 0.01² so that |e| < 0.01 cm
    controller = config.controller.updated(tolerance_cm2=tol2 * (1 - 1e-9))
    pdpij = PdPij(model, controller)
    fast = fastest_solver(model)
    newton = NewtonIK(model, tolerance_cm=PEER_TOLERANCE_CM)
    closed = fast.closed_form is not None
    port_controller = controller.updated(mode="paper")
    port_targets = targets[:n_port]
    # a solve that starts at its own target: no iteration, the fixed cost alone
    on_target = [(q, model.fk_cm(q)) for q in (fast.solve(t).q for t in targets)]
    # each solve from the one before's solution: a new start every call, as in a sort
    chained = list(zip(targets, [home] + [np.array(q) for q, _ in on_target[:-1]], strict=True))

    runs: dict[str, Callable[[], list[Any]]] = {
        "fastest": lambda: [fast.solve(t, home) for t in targets],
        "fastest chained": lambda: [fast.solve(t, q) for t, q in chained],
        "batch": lambda: [solve_batch(model, targets, tolerance_cm=PEER_TOLERANCE_CM)],
        "generic": lambda: [newton.solve(t) for t in targets],
        "PD-PIJ": lambda: [pdpij.solve(t, home) for t in targets],
        "PD-PIJ at target": lambda: [pdpij.solve(t, q) for q, t in on_target],
        "numpy port": lambda: [
            numpy_port_solve(home, t, config.arm, port_controller) for t in port_targets
        ],
    }
    ets, rtb_note = rtb_ets(config)
    if ets is not None:
        rng = np.random.default_rng(0)
        for q in rng.uniform(chain.actuated_lower, chain.actuated_upper, (20, chain.m)):
            gap = float(np.abs(ets.fkine(q).t - model.fk_cm(chain.full(q))).max())
            if not gap < 1e-9:
                ets, rtb_note = (
                    None,
                    f"its ETS is not this arm's kinematics (FK off by {gap:.3g} cm)",
                )
                break
    if ets is not None:
        q0 = chain.actuated_of(home)
        poses = []
        for t in targets:
            T = np.eye(4)
            T[:3, 3] = t
            poses.append(T)
        mask = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
        # ik_LM stops when E = ½ eᵀ W e < tol: ½ · 0.01² for |e| < 0.01 cm
        ik_lm = ets.ik_LM
        runs["RTB ik_LM"] = lambda: [
            ik_lm(T, q0=q0, tol=0.5 * tol2 * (1 - 1e-9), mask=mask, joint_limits=True)
            for T in poses
        ]

    best = dict.fromkeys(runs, float("inf"))
    out: dict[str, list[Any]] = {}
    with tqdm(
        total=options.repeat * len(runs), desc="ik peers", unit="run", file=sys.stderr, disable=None
    ) as bar:
        for _ in range(options.repeat):
            for key, fn in runs.items():
                t0 = time.perf_counter()
                out[key] = fn()
                best[key] = min(best[key], time.perf_counter() - t0)
                bar.update()

    def reached(q_act: np.ndarray, t: np.ndarray) -> bool:
        q = chain.full(q_act)
        return bool(
            chain.within_limits(q) and np.linalg.norm(model.fk_cm(q) - t) < PEER_TOLERANCE_CM
        )

    act = chain.actuated_of
    success = {
        "fastest": sum(
            r.converged and reached(act(r.q), t)
            for r, t in zip(out["fastest"], targets, strict=True)
        ),
        "fastest chained": sum(
            r.converged and reached(act(r.q), t)
            for r, t in zip(out["fastest chained"], targets, strict=True)
        ),
        "batch": sum(
            bool(ok) and reached(act(q), t)
            for q, ok, t in zip(out["batch"][0].q, out["batch"][0].reached, targets, strict=True)
        ),
        "generic": sum(
            r.converged and reached(act(r.q), t)
            for r, t in zip(out["generic"], targets, strict=True)
        ),
        "PD-PIJ": sum(
            r.converged and reached(act(r.q), t)
            for r, t in zip(out["PD-PIJ"], targets, strict=True)
        ),
        "numpy port": sum(
            r[0] == "converged" and reached(act(r[1][-1]), t)
            for r, t in zip(out["numpy port"], port_targets, strict=True)
        ),
    }
    if ets is not None:
        success["RTB ik_LM"] = sum(
            bool(s.success) and reached(np.asarray(s.q), t)
            for s, t in zip(out["RTB ik_LM"], targets, strict=True)
        )
    pd_iterations = sum(r.iterations + r.search_iterations for r in out["PD-PIJ"])
    port_iterations = sum(len(r[1]) - 1 for r in out["numpy port"])
    per_solve = {k: best[k] / (n_port if k == "numpy port" else n) for k in runs}
    fixed = per_solve["PD-PIJ at target"]
    pd_per_it = (best["PD-PIJ"] - n * fixed) / pd_iterations
    note = (
        f"{n} seeded reachable targets (seed {PEER_SEED}), from home, |e| < "
        f"{PEER_TOLERANCE_CM} cm; best of {options.repeat} interleaved rounds"
    )
    rows = [Row("ik", "peers: setting", 0.0, "", note)]

    def solve_row(key: str, label: str, extra: str = "") -> None:
        count = n if key != "numpy port" else n_port
        text = f"success {success[key]}/{count}" + (f"; {extra}" if extra else "")
        rows.append(Row("ik", f"{label}: per solve", per_solve[key] * 1e6, "µs", text))

    if ets is not None:
        solve_row("RTB ik_LM", "RTB ik_LM (C++)", rtb_note)
    else:
        rows.append(Row("ik", "RTB ik_LM (C++)", 0.0, "", f"skipped: {rtb_note}"))
    kind = "closed form" if closed else fast.name
    solve_row("fastest", f"mearm fastest ({kind})", "fastest_solver(model).solve(target, home)")
    solve_row(
        "fastest chained",
        f"mearm fastest ({kind}), a new start each",
        "each from the one before's solution: every start checked",
    )
    solve_row(
        "batch",
        f"mearm batch ({'closed form' if closed else 'Gauss-Newton on arrays'})",
        f"solve_batch(model, targets): all {n} in one call, per target",
    )
    solve_row("generic", f"mearm generic ({newton.name})", "NewtonIK, for arms without one")
    solve_row("PD-PIJ", f"PD-PIJ {controller.mode}", "the route generator, the paper's loop")
    rows.append(Row("ik", f"PD-PIJ {controller.mode}: iterations per solve", pd_iterations / n, ""))
    rows.append(
        Row(
            "ik",
            f"PD-PIJ {controller.mode}: fixed cost per solve",
            fixed * 1e6,
            "µs",
            "a converged solve started on its target: checks, 1 FK, the record",
        )
    )
    rows.append(
        Row(
            "ik",
            f"PD-PIJ {controller.mode}: per iteration",
            pd_per_it * 1e6,
            "µs",
            "(solve − fixed cost) / iterations",
        )
    )
    solve_row(
        "numpy port",
        "numpy port (paper mode)",
        f"the first {n_port} targets, {port_iterations / n_port:.1f} iterations each",
    )
    if ets is not None:
        rtb = per_solve["RTB ik_LM"]
        for key, label, target in (
            ("fastest", "mearm fastest", "target ≤ 0.25×, the same start (home)"),
            ("fastest chained", "mearm fastest, a new start each", ""),
            ("batch", "mearm batch", ""),
            ("generic", "mearm generic", ""),
            ("PD-PIJ", "PD-PIJ", ""),
            ("numpy port", "numpy port", ""),
        ):
            rows.append(
                Row("ik", f"{label} / RTB ik_LM, per solve", per_solve[key] / rtb, "×", target)
            )
    rows.append(
        Row(
            "ik",
            "PD-PIJ / mearm fastest, per solve",
            per_solve["PD-PIJ"] / per_solve["fastest"],
            "×",
        )
    )
    return rows


# --------------------------------------------------------------------------- vision


@section("vision")
def bench_vision(options: BenchOptions) -> list[Row]:
    """Detector ms per 640x480 frame vs a NumPy/SciPy port of the recipe; accuracy."""
    from mearm.tools.vision_bench import (  # noqa: PLC0415
        run_calibration_study,
        run_detection_peers,
        run_vision_accuracy,
        run_vision_bench,
    )

    rows = run_vision_bench(max(20, 10 * options.repeat))
    rows += run_detection_peers(max(20, 10 * options.repeat))
    rows += run_vision_accuracy() + run_calibration_study()
    return [Row(**r) for r in rows]


# --------------------------------------------------------------------------- sort-cpu

#: Runs of each command in the ``sort-cpu`` section (the median is reported).
SORT_CPU_RUNS = 3
SORT_ARGV = ("-m", "mearm.sort", "--config", "sim", "--quiet")


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


#: The sort's dependencies, imported alone: its peer in the ``sort-cpu`` section.
DEPS_ARGV = ("-c", "import numpy, cv2, pinocchio, yaml, pydantic")
#: The sort's CPU over its dependencies' import must stay at or below this [×].
SORT_OVER_DEPS_TARGET = 2.0


@section("sort-cpu")
def bench_sort_cpu(options: BenchOptions) -> list[Row]:
    """CPU time of the 12-object simulated sort, interpreter start included, beside its peer.

    The peer is importing the sort's dependencies (numpy, cv2, pinocchio, yaml, pydantic)
    in a bare interpreter: the sort can cost no less, and the ratio says what mearm adds.
    Every command runs :data:`SORT_CPU_RUNS` times, interleaved; medians are reported.
    """
    with tempfile.TemporaryDirectory(prefix="mearm-pyc-") as cache:
        cached = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        cached["PYTHONPYCACHEPREFIX"] = cache
        uncached = {k: v for k, v in cached.items() if k != "PYTHONPYCACHEPREFIX"}
        uncached["PYTHONDONTWRITEBYTECODE"] = "1"
        five_dof = (*SORT_ARGV[:3], "sim_5dof", *SORT_ARGV[4:])
        kinds = {
            "sim sort, 12 objects: CPU": (SORT_ARGV, cached),
            "sim sort, 12 objects, no bytecode cache: CPU": (SORT_ARGV, uncached),
            "peer: import numpy, cv2, pinocchio, yaml, pydantic: CPU": (
                DEPS_ARGV,
                cached,
            ),
            "imports of the sort (python -c 'import mearm.sort'): CPU": (
                ("-c", "import mearm.sort"),
                cached,
            ),
            "bare interpreter (python -c pass): CPU": (("-c", "pass"), cached),
            "sim_5dof sort, 9 objects: CPU": (five_dof, cached),
        }
        child_seconds(SORT_ARGV, cached)  # writes the bytecode
        child_seconds(five_dof, cached)
        runs: dict[str, list[tuple[float, float, int]]] = {k: [] for k in kinds}
        for _ in range(SORT_CPU_RUNS):
            for key, (argv, env) in kinds.items():
                runs[key].append(child_seconds(argv, env))
    note = f"median of {SORT_CPU_RUNS} runs, user + sys of the child process"
    rows = []
    cpu: dict[str, float] = {}
    for key, measured in runs.items():
        failed = [r[2] for r in measured if r[2] != 0]
        extra = f"; EXIT STATUS {failed}" if failed else ""
        target = "; target ≤ 1.0 s" if key == "sim sort, 12 objects: CPU" else ""
        cpu[key] = statistics.median(r[0] for r in measured)
        rows.append(Row("sort-cpu", key, cpu[key], "s", f"{note}{target}{extra}"))
    sort_s = cpu["sim sort, 12 objects: CPU"]
    deps_s = cpu["peer: import numpy, cv2, pinocchio, yaml, pydantic: CPU"]
    imports_s = cpu["imports of the sort (python -c 'import mearm.sort'): CPU"]
    rows += [
        Row(
            "sort-cpu",
            "sim sort CPU / its dependencies' import CPU",
            sort_s / deps_s,
            "×",
            f"same run; target ≤ {SORT_OVER_DEPS_TARGET:g}×",
        ),
        Row(
            "sort-cpu",
            "import mearm.sort beyond its dependencies: CPU",
            imports_s - deps_s,
            "s",
            "mearm's own modules and what they import besides the five",
        ),
        Row(
            "sort-cpu",
            "the sort beyond its imports: CPU",
            sort_s - imports_s,
            "s",
            "loading the config, the start-up checks, the rig, 12 picks and places",
        ),
    ]
    wall = statistics.median(r[1] for r in runs["sim sort, 12 objects: CPU"])
    rows.append(Row("sort-cpu", "sim sort, 12 objects: wall", wall, "s", "median, same runs"))
    return rows


# --------------------------------------------------------------------------- collision


def collision_routes(
    config: Config, collision: Any
) -> list[tuple[np.ndarray, str | None, Any, list]]:
    """The scene's picks and places planned one after another, as the sorter plans them.

    Each entry: the route's joint path (checked, detoured where needed), the object the
    jaws close on (picks), the held object (places) and the objects on the table then.
    """
    from mearm.sim.kinematic.world import World  # noqa: PLC0415
    from mearm.task.plan import Planner  # noqa: PLC0415
    from mearm.task.route import Route  # noqa: PLC0415

    model = collision.model
    planner = Planner(config, model, collision)
    on_table = list(World.from_config(config).table_objects())
    order = sorted(on_table, key=lambda o: config.task.class_names.index(o.color))
    g = config.arm.tool.gripper
    q = model.home
    out: list[tuple[np.ndarray, str | None, Any, list]] = []
    for obj in order:
        cls = config.task.class_named(obj.color)
        objects = [(o.id, o.color, o.x_cm, o.y_cm) for o in on_table]
        collision.set_world(objects, opening_cm=g.open_cm, held=None)
        target = planner.pick_target(cls, obj.x_cm, obj.y_cm)
        pick = planner.plan(Route(obj.id, obj.color, "pick", 1, target), q, target=obj.id)
        assert pick.planned and pick.plan is not None, pick.failure
        out.append((pick.plan.q_path, obj.id, None, objects))
        on_table = [o for o in on_table if o is not obj]
        objects = [(o.id, o.color, o.x_cm, o.y_cm) for o in on_table]
        held = (obj.id, obj.color)
        collision.set_world(objects, opening_cm=cls.diameter_cm, held=held)
        place = planner.plan(
            Route(obj.id, obj.color, "place", 1, planner.place_target(cls)), pick.plan.q
        )
        assert place.planned and place.plan is not None, place.failure
        out.append((place.plan.q_path, None, held, objects))
        q = place.plan.q
    return out


@section("collision")
def bench_collision(options: BenchOptions) -> list[Row]:
    """A collision check per pose and per route, beside the IK solve of the same route."""
    import pinocchio as pin  # noqa: PLC0415

    from mearm.config import load_config  # noqa: PLC0415
    from mearm.ik import make_solver  # noqa: PLC0415
    from mearm.kinematics import ArmModel  # noqa: PLC0415
    from mearm.kinematics.collision import CollisionModel  # noqa: PLC0415

    config = load_config("sim_mujoco")  # the paper's arm, jaws down, its 12-object scene
    model = ArmModel(config.arm)
    collision = CollisionModel(config, model, clearance_cm=config.task.clearance_cm)
    solver = make_solver(model, config.controller)
    routes = collision_routes(config, collision)
    g = config.arm.tool.gripper

    def world(k: int) -> None:
        _, _, held, objects = routes[k]
        opening = g.open_cm if held is None else config.task.class_named(held[1]).diameter_cm
        collision.set_world(objects, opening_cm=opening, held=held)

    checks = poses = 0
    for k, (path, target, _, _) in enumerate(routes):
        world(k)
        before = collision.checks
        assert collision.first_contact(path, target=target) is None
        checks += collision.checks - before
        poses += len(path)
    calls: dict[str, Callable[[], object]] = {}
    for k, (path, target, _, _) in enumerate(routes):
        calls[f"route/{k}"] = functools.partial(_checked_route, world, k, collision, path, target)
        calls[f"ik/{k}"] = functools.partial(solver.solve, model.fk_cm(path[-1]), path[0])
    world(0)
    path0 = routes[0][0]
    two_poses = itertools.cycle([path0[len(path0) // 2], path0[len(path0) // 3]])
    q_mid = path0[len(path0) // 2]

    def pose() -> object:  # two poses in turn: a repeated pose is not checked again
        return collision.gap(next(two_poses), target=routes[0][1])

    calls["pose"] = pose
    geom, gdata = collision.geometry, collision.gdata
    calls["all pairs"] = functools.partial(
        pin.computeDistances, model.model, collision.data, geom, gdata, q_mid
    )
    worlds = itertools.cycle([0, 1])
    calls["world"] = lambda: world(next(worlds))  # two worlds in turn: a new one each call
    best = best_seconds(
        calls, options.repeat, {"pose": 50, "all pairs": 50, "world": 10}, "collision"
    )
    n = len(routes)
    route_s = sum(best[f"route/{k}"] for k in range(n)) / n
    ik_s = sum(best[f"ik/{k}"] for k in range(n)) / n
    note = (
        f"{n} routes of the paper's twin scene (configs/sim_mujoco.yaml), "
        f"best of {options.repeat} rounds"
    )
    pairs = len(geom.collisionPairs)
    return [
        Row(
            "collision",
            "check of one pose (the pairs that count, min distance)",
            best["pose"] * 1e6,
            "µs",
            note,
        ),
        Row(
            "collision",
            f"peer: pin.computeDistances alone, the pairs switched on of {pairs}",
            best["all pairs"] * 1e6,
            "µs",
            "same pose",
        ),
        Row(
            "collision",
            "one pose / computeDistances alone",
            best["pose"] / best["all pairs"],
            "×",
            "the check adds the joints' kinematics and the jaws' target",
        ),
        Row(
            "collision",
            "check of one route (conservative advancement)",
            route_s * 1e3,
            "ms",
            f"{checks / n:.1f} checks a route, {poses / n:.1f} poses in its path",
        ),
        Row("collision", "the same route's IK solve (PD-PIJ)", ik_s * 1e3, "ms", ""),
        Row("collision", "route check / IK solve", route_s / ik_s, "×", ""),
        Row(
            "collision",
            "world update (objects, jaws, held object)",
            best["world"] * 1e6,
            "µs",
            "the objects' places moved, the pairs of those gone switched off",
        ),
    ]


def _checked_route(
    world: Callable[[int], None], k: int, collision: Any, path: np.ndarray, target: str | None
) -> object:
    world(k)
    return collision.first_contact(path, target=target)


# --------------------------------------------------------------------------- motion

#: The paper's motion time for its 12 objects: about 6 s per pick or place motion, 24 of
#: them [s].
PAPER_MOTION_S = 144.0


@section("motion")
def bench_motion(options: BenchOptions) -> list[Row]:
    """The predicted motion time of the paper's scene in each object order (simulated)."""
    from mearm.config import load_config  # noqa: PLC0415
    from mearm.task.rig import run_sort  # noqa: PLC0415

    rows = []
    for order in ("class", "nearest"):
        config = load_config("sim", overrides=[f"task.order={order}"])
        report = run_sort(config, echo=None)
        motion = report.motion
        assert motion is not None  # the sort ran to its summary
        done = f"sorted {report.outcome.n_sorted} of {report.outcome.n_seen}"
        if not report.complete:
            done = f"INCOMPLETE: {done}"
        note = (
            f"arm {motion.arm_s:.2f} s at the servos' speed limits + gripper and tool "
            f"{motion.tool_s:.2f} s ({motion.tool_moves} settings); {done}"
        )
        label = "the paper's colour order" if order == "class" else "nearest object first"
        rows.append(Row("motion", f"paper scene, {label}: motion", motion.total_s, "s", note))
        rows.append(
            Row(
                "motion",
                f"paper scene, {label}: ÷ the paper's ≈ {PAPER_MOTION_S:g} s",
                motion.total_s / PAPER_MOTION_S,
                "x",
                "target ≤ 0.25 (36 s)",
            )
        )
    return rows


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
    out.sorted_text = f"sorted {report.outcome.n_sorted} of {report.outcome.n_seen}"
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


def twin_rows(
    configs: dict[str, Config], rounds: int, args: Mapping[str, Sequence[str]]
) -> list[Row]:
    """The twin's rows for each named config: best (and median) of ``rounds`` rounds.

    Each round sorts once on every config in turn (interleaved) in this process, times
    bare stepping, and runs the same sort as a whole process (interpreter start, imports,
    the rig, physics, rendering, detection), bytecode cached as an installed package's:
    ``python -m mearm.sort`` with ``args[name]`` (``--config …``, the same config).
    """
    sorts: dict[str, list[TwinSort]] = {name: [] for name in configs}
    bare: dict[str, list[float]] = {name: [] for name in configs}
    process: dict[str, list[tuple[float, float, int]]] = {name: [] for name in configs}
    with tempfile.TemporaryDirectory(prefix="mearm-pyc-") as cache:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        env["PYTHONPYCACHEPREFIX"] = cache
        for name in configs:
            twin_process_seconds(args[name], env)  # writes the bytecode
        for _ in range(rounds):
            for name, config in configs.items():
                sorts[name].append(twin_sort(config))
                seconds, dt = bare_step_seconds(config)
                bare[name].append(BARE_STEPS * dt / seconds)
                process[name].append(twin_process_seconds(args[name], env))

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
                f"in a sort, no rendering; {how}; the bar: ≥ 50×",
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
        failed = [r[2] for r in process[name] if r[2] != 0]
        extra = f"; EXIT STATUS {failed}" if failed else ""
        value, how = stats([last.sim_s / r[1] for r in process[name]], max, "×")
        rows.append(
            Row(
                "twin",
                f"whole process ({name}): real-time factor",
                value,
                "×",
                f"python -m mearm.sort {' '.join(args[name])}: {last.sim_s:.1f} s simulated "
                f"per s of wall time, interpreter start included; {how}"
                f"{'; the bar: ≥ 15×' if name == 'sim_mujoco' else ''}{extra}",
            )
        )
        value, how = stats([last.sim_s / r[0] for r in process[name]], max, "×")
        rows.append(
            Row(
                "twin",
                f"whole process ({name}): real-time factor on the CPU",
                value,
                "×",
                f"per s of the process's CPU time (user + sys); {how}",
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
    args = {name: ("--config", name) for name in TWIN_CONFIGS}
    return twin_rows(configs, min(options.repeat, TWIN_ROUNDS), args)


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
    parser.add_argument("--json", action="store_true", help="print JSON instead of the table")
    parser.add_argument(
        "--out", type=Path, metavar="FILE", help="also write the rows as JSON to FILE"
    )
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error(f"--repeat must be at least 1, got {args.repeat}")
    if args.out is not None:  # checked before the sections run, not after minutes of work
        folder = args.out.parent
        if not folder.is_dir():
            parser.error(f"--out {args.out}: no such directory {str(folder)!r}")
        if args.out.is_dir():
            parser.error(f"--out {args.out}: is a directory; give a file name, e.g. bench.json")
        try:  # a file can be made there (root passes os.access where nothing can be made)
            tempfile.TemporaryFile(dir=folder).close()
        except OSError as exc:
            parser.error(f"--out {args.out}: directory {str(folder)!r} is not writable ({exc})")
    options = BenchOptions(repeat=args.repeat)
    rows: list[Row] = []
    for name in args.only or list(SECTIONS):
        rows += SECTIONS[name](options)
    machine_text = machine()
    result = {"machine": machine_text, "rows": [asdict(r) for r in rows]}
    if args.out is not None:  # whole or not at all: a run cut short leaves the old file
        write_text_atomic(args.out, json.dumps(result, indent=1) + "\n")
    if args.json:
        json.dump(result, sys.stdout, indent=1)
        print()
        return 0
    print("\n".join(table(machine_text, rows)))
    return 0


def table(machine_text: str, rows: Sequence[Row]) -> list[str]:
    """The bench's printed lines: the machine, then one line per row."""
    lines = [f"machine: {machine_text}"]
    for row in rows:
        value = f"{row.value:12.3f} {row.unit}" if row.unit else f"{row.value:12.2f}"
        if row.unit == "" and row.value == 0.0:
            value = ""
        note = f"  ({row.note})" if row.note else ""
        lines.append(f"[{row.section}] {row.name:<58} {value}{note}")
    return lines


if __name__ == "__main__":
    run(main)
