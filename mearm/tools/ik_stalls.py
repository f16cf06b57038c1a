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
beside the default. Exit 1 if any solve left the limits.
"""

from __future__ import annotations

import sys
import time
from collections import Counter
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mearm.cli import ArgumentParser, run, seed_value
from mearm.config import Config, load_config
from mearm.hardware.mapping import ServoMap
from mearm.ik import IKTarget, PdPij, make_solver
from mearm.kinematics import ArmModel

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


def measure(config: Config, n: int, seed: int, *, recover: bool | None) -> list[dict[str, object]]:
    """One row per kind of start: stops, their kinds, how solves got there, violations."""
    model = ArmModel(config.arm)
    chain = model.chain
    solver = (
        make_solver(model, config.controller)
        if recover is None
        else PdPij(model, config.controller, recover=recover)
    )
    lo, hi = chain.actuated_lower, chain.actuated_upper
    servos = ServoMap.from_arm(config.arm)
    scale = chain.scale[chain.actuated_index]

    def sendable(q_actuated: np.ndarray) -> bool:
        """Whether every servo can be sent to this pose (model units, actuated joints)."""
        return servos.outside_pulse_range(q_actuated / scale) is None

    box = config.arm.target_box
    with_axis = config.arm.tool.pick_approach is not None
    rows = []
    for start in STARTS:
        rng = np.random.default_rng(seed)
        solved = stopped = violations = 0
        kinds: Counter[str] = Counter()
        methods: Counter[str] = Counter()
        t0 = time.perf_counter()
        while solved < n:
            q_sampled = _sample(rng, lo, hi, 0.25)
            if not sendable(q_sampled):  # a target only a pose the servos cannot take reaches
                continue
            q_target = chain.full(q_sampled)
            p = model.fk_cm(q_target)
            if not (
                box.x_cm.contains(p[0]) and box.y_cm.contains(p[1]) and box.z_cm.contains(p[2])
            ):
                continue
            axis = _xyz(model.approach(q_target)) if with_axis else None
            target = IKTarget(_xyz(p), axis)
            edge = {"home": None, "uniform": 0.0, "near a limit": 0.5}[start]
            q0 = model.home
            while edge is not None:  # a start the servos can be at
                q_start = _sample(rng, lo, hi, edge)
                if sendable(q_start):
                    q0 = chain.full(q_start)
                    break
            result = solver.solve(target, q0)
            solved += 1
            if not result.converged:
                stopped += 1
                failure = getattr(result, "failure", None)
                kinds[getattr(failure, "kind", result.status)] += 1
            methods[str(getattr(result, "method", "direct"))] += 1
            # the solution, not the path: one that swings past a servo's range on the way
            # is sent by the planner as a joint-space move, never as this path
            if not all(chain.within_limits(q, tol=1e-9) for q in result.q_path) or (
                result.converged and not sendable(chain.actuated_of(result.q))
            ):
                violations += 1
        rows.append(
            {
                "start": start, "targets": n, "stopped": stopped, "kinds": dict(kinds),
                "methods": dict(methods), "violations": violations,
                "seconds": time.perf_counter() - t0,
            }
        )  # fmt: skip
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    """Measure and print one table per config."""
    parser = ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "configs",
        nargs="*",
        type=Path,
        help=f"config files or packaged config names (default: {', '.join(CONFIGS)})",
    )
    parser.add_argument("--targets", type=int, default=2000, help="targets per kind of start")
    parser.add_argument(
        "--seed", type=seed_value, default=0, help="seed of the targets (default 0)"
    )
    parser.add_argument("--no-recover", action="store_true", help="PD-PIJ without the recovery")
    args = parser.parse_args(argv)
    if not 1 <= args.targets <= 1_000_000:
        parser.error(f"--targets must be in [1, 1000000], got {args.targets}")
    paths = args.configs or [Path(name) for name in CONFIGS]
    any_violation = False
    for path in paths:
        config = load_config(path)
        solver = config.controller.solver
        label = f"{path.name} ({solver}{', no recovery' if args.no_recover else ''})"
        print(label)
        for row in measure(
            config, args.targets, args.seed, recover=False if args.no_recover else None
        ):
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
