"""Run the paper's 24 demo routes with PD-PIJ and compare with its reported figures.

    mearm reproduce-paper [--config configs/sim.yaml] [--mode paper|coupled] [--json]

From home: pick red1 at z = 12.76, place it in the red bin, pick red2 from there, …, the
reds, then the greens, then the blues (paper §1, §4: the paper's M1…, H1…, B1…); each
route starts where the last ended. Any config with a scene works; the paper's figures
are for the default one.
``--mode`` is ``paper`` unless given. Prints one row per route (object, pick/place,
iterations, initial and final error, the largest distance of the EE path from the
straight start→target segment), the means next to the paper's (paper §3: 82 iterations,
73–93; initial error 24.99 cm; final error 0.0305 cm) and the x, y, z range along all
paths; labelled simulated (ideal kinematics: no servos, no noise) beside the paper's
real-arm figures.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence

import numpy as np

from mearm.cli import ArgumentParser, add_config_argument, config_from_args, run
from mearm.errors import ConfigError, MearmError
from mearm.ik import PdPij, demo_routes, run_routes
from mearm.kinematics import ArmModel

#: The arm the paper's demo and figures are of.
PAPER_ARM = "mearm_paper"

#: The paper's figures for its 24 routes (paper §3).
PAPER = {
    "mean_iterations": 82,
    "min_iterations": 73,
    "max_iterations": 93,
    "mean_initial_error_cm": 24.99,
    "mean_final_error_cm": 0.0305,
    "final_error_range_cm": [0.0297, 0.0315],
    "seconds_per_iteration": 0.072,
}


def reproduce(config, mode: str) -> dict:
    """Solve the demo routes; return rows, summary and the paper's figures."""
    routes = demo_routes(config.arm.tool, config.task)
    if not routes:
        raise ConfigError(
            None, ["task.scene is empty: the demo needs the paper's layout (configs/sim.yaml)"]
        )
    controller = config.controller.updated(mode=mode, solver="pdpij")
    model = ArmModel(config.arm)
    results = run_routes(PdPij(model, controller), model.home, routes)
    rows = [
        {
            "route": i,
            "object": route.name,
            "action": route.action,
            "target_cm": list(route.target_cm),
            "status": r.status,
            "iterations": r.iterations,
            "initial_error_cm": r.initial_error_cm,
            "final_error_cm": r.final_error_cm,
            "path_deviation_cm": r.path_deviation_cm,
            "blocked_steps": r.blocked_steps,
            "fallback_steps": r.fallback_steps,
        }
        for i, (route, r) in enumerate(zip(routes, results, strict=True), start=1)
    ]
    its = np.array([r.iterations for r in results])
    ee = np.concatenate([r.ee_path_cm for r in results])
    summary = {
        "routes": len(results),
        "converged": sum(r.converged for r in results),
        "mean_iterations": float(its.mean()),
        "min_iterations": int(its.min()),
        "max_iterations": int(its.max()),
        "mean_initial_error_cm": float(np.mean([r.initial_error_cm for r in results])),
        "mean_final_error_cm": float(np.mean([r.final_error_cm for r in results])),
        "final_error_range_cm": [
            float(min(r.final_error_cm for r in results)),
            float(max(r.final_error_cm for r in results)),
        ],
        "max_path_deviation_cm": float(max(r.path_deviation_cm for r in results)),
        "mean_path_deviation_cm": float(np.mean([r.path_deviation_cm for r in results])),
        "fallback_steps": int(sum(r.fallback_steps for r in results)),
        "blocked_steps": int(sum(r.blocked_steps for r in results)),
        "xyz_min_cm": ee.min(axis=0).tolist(),
        "xyz_max_cm": ee.max(axis=0).tolist(),
    }
    return {
        "mode": mode,
        "kp": controller.kp,
        "kd": controller.kd,
        "tolerance_cm2": controller.tolerance_cm2,
        "rows": rows,
        "summary": summary,
        "paper": PAPER,
    }


def print_table(report: dict) -> None:
    """Print the routes' table and the means next to the paper's."""
    s, p = report["summary"], report["paper"]
    print(
        f"PD-PIJ on simulated kinematics, {report['mode']} mode: kp = {report['kp']:g}, "
        f"kd = {report['kd']:g}, "
        f"stop when |e|² < {report['tolerance_cm2']:g} cm²; {s['routes']} routes from home"
    )
    print(
        f"{'#':>2}  {'object':<8} {'action':<6} {'target (cm)':<24} {'iter':>5} "
        f"{'e0 (cm)':>8} {'e_end (cm)':>10} {'dev (cm)':>8}  status"
    )
    for r in report["rows"]:
        x, y, z = r["target_cm"]
        target = f"({x:.2f}, {y:.2f}, {z:.2f})"
        print(
            f"{r['route']:>2}  {r['object']:<8} {r['action']:<6} {target:<24} "
            f"{r['iterations']:>5} {r['initial_error_cm']:>8.3f} {r['final_error_cm']:>10.4f} "
            f"{r['path_deviation_cm']:>8.3f}  {r['status']}"
        )
    lo, hi = s["final_error_range_cm"]
    plo, phi = p["final_error_range_cm"]
    print(
        f"mean iterations      {s['mean_iterations']:8.2f} ({s['min_iterations']}–"
        f"{s['max_iterations']})    paper: {p['mean_iterations']} "
        f"({p['min_iterations']}–{p['max_iterations']})"
    )
    print(
        f"mean initial error   {s['mean_initial_error_cm']:8.3f} cm         "
        f"paper: {p['mean_initial_error_cm']} cm"
    )
    print(
        f"mean final error     {s['mean_final_error_cm']:8.4f} cm "
        f"({lo:.4f}–{hi:.4f})  paper: {p['mean_final_error_cm']} cm ({plo}–{phi})"
    )
    print(
        f"path deviation from the straight segment: max {s['max_path_deviation_cm']:.3f} cm, "
        f"mean {s['mean_path_deviation_cm']:.3f} cm"
    )
    for axis, a, b in zip("xyz", s["xyz_min_cm"], s["xyz_max_cm"], strict=True):
        print(f"{axis} along all paths: [{a:.2f}, {b:.2f}] cm")
    print(
        f"converged {s['converged']}/{s['routes']}; limit rule held a joint in "
        f"{s['blocked_steps']} updates; safeguard replaced {s['fallback_steps']} updates"
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Run the demo routes and print the comparison; 0 on success."""
    parser = ArgumentParser(description="The paper's 24 demo routes with PD-PIJ.")
    add_config_argument(parser)
    parser.add_argument(
        "--mode",
        choices=("paper", "coupled"),
        default="paper",
        help="PD-PIJ mode (default: paper, the paper's algorithm)",
    )
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    for text in args.set or ():  # the demo's solver is the paper's: the flags say how
        key = text.partition("=")[0].strip()
        if key in ("controller.mode", "controller.solver"):
            raise MearmError(
                f"--set {key}: the demo runs the paper's PD-PIJ, in the mode --mode names "
                "(paper or coupled); --set changes neither"
            )
    config = config_from_args(args)
    if config.arm.name != PAPER_ARM:
        raise MearmError(
            f"the demo and its figures are the paper's arm's ({PAPER_ARM}); this config's "
            f"arm is {config.arm.name}: give a config of the paper's arm (e.g. --config sim)"
        )
    report = reproduce(config, args.mode)
    if args.json:
        json.dump(report, sys.stdout, indent=1)
        print()
    else:
        print_table(report)
    return 0 if report["summary"]["converged"] == report["summary"]["routes"] else 1


if __name__ == "__main__":
    run(main)
