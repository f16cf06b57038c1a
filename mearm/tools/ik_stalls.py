"""How often the default IK solve stops short of the target, per arm and kind of start.

Targets are the TCP of random joint poses within the limits (each joint within 0.5° of a
limit with probability 1/4), kept when inside the target box; an arm that picks with an
approach axis gets the sampled pose's axis too. Starts: home, uniform in the limits, and
near the limits (each joint within 0.5° of one with probability 1/2). Targets and starts
are poses every servo can be sent to (the MeArm v1's elbow servo turns shoulder + elbow,
whose pulse range is narrower than the two joints' limits). Every pose of every path is
checked against the limits, and every solution against the servos' pulse ranges.

    mearm ik-stalls [--targets 2000] [--seed 0] [--no-recover] [CONFIG ...]

``--no-recover`` runs PD-PIJ without the stall recovery (as before it existed), to set
beside the default, whatever solver the config names: its table says so (``mink.yaml
(pdpij, no recovery, in place of the config's mink)``). Every config is loaded, and its
solver built, before any is measured: a bad one is refused (exit 2) before the first
table. Exit 1 if any solve left the limits.
"""

from __future__ import annotations

import sys
import time
from collections import Counter
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mearm.cli import ArgumentParser, plain_int, run, seed_value
from mearm.config import Config, load_config
from mearm.hardware.mapping import ServoMap
from mearm.ik import IKResult, IKSolver, IKTarget, PdPij, make_solver
from mearm.kinematics import ArmModel, Chain

CONFIGS = ("sim", "sim_mearm_v1", "sim_5dof")
STARTS = ("home", "uniform", "near a limit")


def _xyz(v: np.ndarray) -> tuple[float, float, float]:
    """A 3-vector as a tuple of floats."""
    return (float(v[0]), float(v[1]), float(v[2]))


def _sample(rng: np.random.Generator, lo: np.ndarray, hi: np.ndarray, p_edge: float) -> np.ndarray:
    q = rng.uniform(lo, hi)
    for i in range(len(q)):
        if rng.random() < p_edge:
            off = rng.uniform(0.0, np.radians(0.5))
            q[i] = lo[i] + off if rng.random() < 0.5 else hi[i] - off
    return q


def sendable(servos: ServoMap, chain: Chain, q_actuated: np.ndarray) -> bool:
    """Whether every servo can be sent to this pose (model units, actuated joints)."""
    return servos.outside_pulse_range(q_actuated / chain.scale[chain.actuated_index]) is None


def draw_target(
    rng: np.random.Generator, model: ArmModel, servos: ServoMap
) -> tuple[np.ndarray, IKTarget]:
    """A target in the box, reached by a random pose every servo can be sent to.

    A target that only a pose past a servo's pulse range reaches (the MeArm v1's elbow
    servo turns shoulder + elbow) is one no sort is given: it is not drawn. An arm that
    picks with an approach axis gets the pose's axis too.

    Returns:
        The pose (every joint, model units, (n,)) and its target.
    """
    chain = model.chain
    box = model.arm.target_box
    with_axis = model.arm.tool.pick_approach is not None
    while True:
        q_sampled = _sample(rng, chain.actuated_lower, chain.actuated_upper, 0.25)
        if not sendable(servos, chain, q_sampled):
            continue
        q = chain.full(q_sampled)
        p = model.fk_cm(q)
        if box.x_cm.contains(p[0]) and box.y_cm.contains(p[1]) and box.z_cm.contains(p[2]):
            return q, IKTarget(_xyz(p), _xyz(model.approach(q)) if with_axis else None)


def draw_start(
    rng: np.random.Generator, model: ArmModel, servos: ServoMap, p_edge: float | None
) -> np.ndarray:
    """A start every servo can be at (every joint, model units, (n,)).

    ``p_edge``: each joint's chance to be within 0.5° of a limit; ``None``: home.
    """
    chain = model.chain
    while p_edge is not None:
        q_start = _sample(rng, chain.actuated_lower, chain.actuated_upper, p_edge)
        if sendable(servos, chain, q_start):
            return chain.full(q_start)
    return model.home


def violates(result: IKResult, chain: Chain, servos: ServoMap) -> bool:
    """Whether a solve left the limits on its path, or converged where a servo cannot go.

    The solution, not the path: one that swings past a servo's range on the way is sent
    by the planner as a joint-space move, never as this path.
    """
    return not all(chain.within_limits(q, tol=1e-9) for q in result.q_path) or (
        result.converged and not sendable(servos, chain, chain.actuated_of(result.q))
    )


def make_stalls_solver(config: Config, *, recover: bool | None) -> IKSolver:
    """The solver measured: the config's when ``recover`` is None, else PD-PIJ's.

    PD-PIJ with ``recover`` false runs without the stall recovery, whatever the config's
    ``controller.solver``.

    Raises:
        MearmError: the config's solver cannot be built here (``analytic`` for an arm
            without a closed form, ``mink`` without its QP backend).
    """
    model = ArmModel(config.arm)
    if recover is None:
        return make_solver(model, config.controller)
    return PdPij(model, config.controller, recover=recover)


def measure(
    config: Config, n: int, seed: int, *, recover: bool | None, solver: IKSolver | None = None
) -> list[dict[str, object]]:
    """One row per kind of start: stops, their kinds, how solves got there, violations.

    ``solver``: the one :func:`make_stalls_solver` builds for ``config`` and ``recover``,
    when it was built already.
    """
    solver = solver or make_stalls_solver(config, recover=recover)
    model = solver.model
    chain = model.chain
    servos = ServoMap.from_arm(config.arm)
    rows = []
    for start in STARTS:
        rng = np.random.default_rng(seed)
        stopped = violations = 0
        kinds: Counter[str] = Counter()
        methods: Counter[str] = Counter()
        t0 = time.perf_counter()
        for _ in range(n):
            _, target = draw_target(rng, model, servos)
            edge = {"home": None, "uniform": 0.0, "near a limit": 0.5}[start]
            result = solver.solve(target, draw_start(rng, model, servos, edge))
            if not result.converged:
                stopped += 1
                failure = getattr(result, "failure", None)
                kinds[getattr(failure, "kind", result.status)] += 1
            methods[str(getattr(result, "method", "direct"))] += 1
            violations += violates(result, chain, servos)
        rows.append(
            {
                "start": start, "targets": n, "stopped": stopped, "kinds": dict(kinds),
                "methods": dict(methods), "violations": violations,
                "seconds": time.perf_counter() - t0,
            }
        )  # fmt: skip
    return rows


def run_label(config_solver: str, *, no_recover: bool) -> str:
    """What ran, for a config's table: its solver, or PD-PIJ without the recovery.

    ``--no-recover`` runs PD-PIJ whatever the config names; a mink config's table read
    ``(mink, no recovery)``, a solver that was not run and has no recovery to go without.
    """
    if not no_recover:
        return config_solver
    if config_solver == "pdpij":
        return "pdpij, no recovery"
    return f"pdpij, no recovery, in place of the config's {config_solver}"


def main(argv: Sequence[str] | None = None) -> int:
    """Measure and print one table per config."""
    parser = ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "configs",
        nargs="*",
        type=Path,
        help=f"config files or packaged config names (default: {', '.join(CONFIGS)})",
    )
    parser.add_argument("--targets", type=plain_int, default=2000, help="targets per kind of start")
    parser.add_argument(
        "--seed", type=seed_value, default=0, help="seed of the targets (default 0)"
    )
    parser.add_argument(
        "--no-recover",
        action="store_true",
        help="run PD-PIJ without the stall recovery, whatever solver a config names (its "
        "table says so)",
    )
    args = parser.parse_args(argv)
    if not 1 <= args.targets <= 1_000_000:
        parser.error(f"--targets must be in [1, 1000000], got {args.targets}")
    paths = args.configs or [Path(name) for name in CONFIGS]
    recover = False if args.no_recover else None
    # every config loaded and its solver built before any is measured: a bad one named
    # last is refused at once, not after the tables of those before it
    runs = []
    for path in paths:
        config = load_config(path)
        runs.append((path, config, make_stalls_solver(config, recover=recover)))
    any_violation = False
    for path, config, solver in runs:
        print(f"{path.name} ({run_label(config.controller.solver, no_recover=args.no_recover)})")
        for row in measure(config, args.targets, args.seed, recover=recover, solver=solver):
            share = 100.0 * int(row["stopped"]) / int(row["targets"])  # type: ignore[call-overload]
            print(
                f"  start {row['start']:<13} {row['targets']} targets: stopped {row['stopped']} "
                f"({share:.2f} %) {row['kinds'] or ''}  how: {row['methods']}  "
                f"limit violations {row['violations']}  [{row['seconds']:.1f} s]"
            )
            any_violation |= bool(row["violations"])
        sys.stdout.flush()
    return 1 if any_violation else 0


if __name__ == "__main__":
    run(main)
