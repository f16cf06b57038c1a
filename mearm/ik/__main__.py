r"""``python -m mearm.ik``: solve one IK target from a start pose.

Example::

    python -m mearm.ik --config configs/lab.yaml --start 120,93,-132 \
        --target -10.99,49.70,12.76 --mode paper --json

Exit status: 0 converged, 1 not converged (stalled / max_iterations), 2 bad input (a
target outside the box or out of reach, a start outside the limits, a bad option).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence

import numpy as np

from mearm.cli import (
    EXIT_FAILURE,
    EXIT_OK,
    ArgumentParser,
    add_config_argument,
    config_from_args,
    float_list,
    run,
)
from mearm.ik.factory import solve_ik
from mearm.kinematics import ArmModel


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a positive number (cm²), got {text!r}")
    return value


def main(argv: Sequence[str] | None = None) -> int:
    """Solve, print the result; see the module docstring."""
    parser = ArgumentParser(prog="python -m mearm.ik", description=__doc__.splitlines()[0])
    add_config_argument(parser)
    parser.add_argument(
        "--start",
        type=float_list(3, "--start"),
        default=None,
        help="θ1,θ2,θ3 in degrees (θ4 = −(θ2+θ3)); default: the config's home",
    )
    parser.add_argument(
        "--target", type=float_list(3, "--target"), required=True, help="x,y,z in cm"
    )
    parser.add_argument("--mode", choices=("paper", "coupled"), help="PD-PIJ mode")
    parser.add_argument("--solver", choices=("pdpij", "mink", "analytic"), help="solver")
    parser.add_argument(
        "--tolerance", type=_positive, metavar="CM2", help="stop when |e|² < CM2 [cm²]"
    )
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    config = config_from_args(args)
    changes = {
        key: value
        for key, value in (
            ("mode", args.mode),
            ("solver", args.solver),
            ("tolerance_cm2", args.tolerance),
        )
        if value is not None
    }
    controller = config.controller.updated(**changes)
    model = ArmModel(config.robot)
    start_deg = args.start if args.start is not None else config.robot.home_deg
    result = solve_ik(model, np.radians(start_deg), args.target, controller)
    if args.json:
        print(json.dumps(result.summary()))
    else:
        joints = ", ".join(f"{v:.3f}" for v in result.q_deg)
        x, y, z = result.ee_cm
        print(f"{result.solver}: {result.status} after {result.iterations} iterations")
        print(f"error {result.initial_error_cm:.4f} -> {result.final_error_cm:.4f} cm")
        print(f"joints (θ1..θ4) = ({joints}) deg")
        print(f"ee = ({x:.3f}, {y:.3f}, {z:.3f}) cm")
    return EXIT_OK if result.converged else EXIT_FAILURE


if __name__ == "__main__":
    run(main)
