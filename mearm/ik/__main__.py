r"""Inverse kinematics: solve one target position from a start pose (mearm ik).

Example::

    python -m mearm.ik --config configs/lab.yaml --start 120,93,-132 \
        --target -10.99,49.70,12.76 --mode paper --json

``--start`` lists the actuated joints in the config's order and units (deg, or cm for a
prismatic joint); passive joints follow from their couplings. ``--approach`` asks the
tool's approach axis to point along a base-frame direction (``pick``: the arm's
``tool.pick_approach``).

Exit status: 0 converged, 1 not converged (stalled / max_iterations), 2 bad input (a
target outside the box or out of reach, a start outside the limits, a bad option).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence

from mearm.cli import (
    EXIT_FAILURE,
    EXIT_OK,
    ArgumentParser,
    add_config_argument,
    config_from_args,
    float_list,
    invoked_as,
    positive_number,
    run,
)
from mearm.ik.factory import solve_ik
from mearm.ik.target import IKTarget
from mearm.kinematics import ArmModel
from mearm.kinematics.errors import InvalidJointsError, InvalidTargetError


def main(argv: Sequence[str] | None = None) -> int:
    """Solve, print the result; see the module docstring."""
    parser = ArgumentParser(
        prog=invoked_as("python -m mearm.ik"), description=__doc__.splitlines()[0]
    )
    add_config_argument(parser)
    parser.add_argument(
        "--start",
        type=float_list(None, "--start"),
        default=None,
        help="the actuated joints in deg (cm if prismatic); default: the config's home",
    )
    parser.add_argument(
        "--target", type=float_list(3, "--target"), required=True, help="x,y,z in cm"
    )
    parser.add_argument(
        "--approach",
        default=None,
        help="ax,ay,az: direction of the tool's approach axis, or 'pick' for the arm's",
    )
    parser.add_argument("--mode", choices=("paper", "coupled"), help="PD-PIJ mode")
    parser.add_argument("--solver", choices=("pdpij", "mink", "analytic"), help="solver")
    parser.add_argument(
        "--tolerance",
        type=positive_number(0.0, float("inf"), "cm²"),  # the range: controller.tolerance_cm2
        metavar="CM2",
        help="stop when |e|² < CM2 [cm²]",
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
    model = ArmModel(config.arm)
    chain = model.chain
    if args.start is None:
        q_start = model.home
    else:
        if len(args.start) != chain.m:
            raise InvalidJointsError(
                args.start,
                f"--start needs {chain.m} numbers, the actuated joints "
                f"({', '.join(chain.actuated)}), got {len(args.start)}",
            )
        q_start = chain.from_named(dict(zip(chain.actuated, args.start, strict=True)))
    approach: tuple[float, ...] | None = None
    if args.approach == "pick":
        approach = config.arm.tool.pick_approach
        if approach is None:
            raise InvalidTargetError(
                f"--approach pick: arm {config.arm.name!r} has no tool.pick_approach"
            )
    elif args.approach is not None:
        try:
            approach = tuple(float_list(3, "--approach")(args.approach))
        except argparse.ArgumentTypeError as exc:
            raise InvalidTargetError(str(exc)) from None
    target = IKTarget(tuple(args.target), approach)  # type: ignore[arg-type]
    result = solve_ik(model, controller, target, q_start)
    if args.json:
        print(json.dumps(result.summary()))
    else:
        units = [chain.unit(i) for i in range(chain.n)]
        joints = ", ".join(
            f"{name} {v:.3f} {u}" for (name, v), u in zip(result.joints.items(), units, strict=True)
        )
        x, y, z = result.ee_cm
        plural = "" if result.iterations == 1 else "s"
        print(f"{result.solver}: {result.status} after {result.iterations} iteration{plural}")
        if result.recovered_from is not None:
            print(
                f"recovered ({result.method.replace('_', ' ')}): PD-PIJ alone "
                f"{result.recovered_from.replace('_', ' ')}; {result.search_iterations} "
                "updates searched, not in the path"
            )
        if result.failure is not None:
            print(f"failure ({result.failure.kind}): {result.failure.message}")
        print(f"error {result.initial_error_cm:.4f} -> {result.final_error_cm:.4f} cm")
        if result.final_approach_error_deg is not None:
            print(f"approach error {result.final_approach_error_deg:.3f} deg")
        print(f"joints: {joints}")
        print(f"ee = ({x:.3f}, {y:.3f}, {z:.3f}) cm")
    return EXIT_OK if result.converged else EXIT_FAILURE


if __name__ == "__main__":
    run(main)
