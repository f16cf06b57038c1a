r"""Inverse kinematics: solve one target position from a start pose (mearm ik).

Example::

    python -m mearm.ik --config configs/lab.yaml --start 120,93,-132 \
        --target -10.99,49.70,12.76 --mode paper --json

``--start`` lists the actuated joints in the config's order and units (deg, or cm for a
prismatic joint); passive joints follow from their couplings. ``--approach`` asks the
tool's approach axis to point along a base-frame direction (``pick``: the arm's
``tool.pick_approach``); an arm with three actuated joints or fewer needs them all to
place the TCP, so its approach follows from the target and ``--approach`` is refused.

Exit status: 0 converged, 1 not converged (stalled / max_iterations) or converged to a
pose a servo over several joints cannot be sent to (the MeArm v1's elbow servo turns
shoulder + elbow: its pulse range bounds the sum; ``failure_kind`` ``limit``, as the sort
planner refuses it), 2 bad input (a target outside the box or out of reach, a start
outside the limits or the servos' pulse ranges, a bad option).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence

import numpy as np

from mearm.cli import (
    EXIT_FAILURE,
    EXIT_OK,
    ArgumentParser,
    add_config_argument,
    check_closed_form,
    config_from_args,
    float_list,
    invoked_as,
    positive_number,
    run,
)
from mearm.config import ArmDescription
from mearm.config.files import unit_warning
from mearm.config.sections import TOLERANCE_CM2_RANGE
from mearm.hardware.mapping import ServoMap
from mearm.ik.factory import solve_ik
from mearm.ik.failure import IKFailure
from mearm.ik.result import IKResult
from mearm.ik.target import IKTarget
from mearm.kinematics import ArmModel, Chain
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
        "--target",
        type=float_list(3, "--target"),
        required=True,
        help="x,y,z in cm",
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
        type=positive_number(*TOLERANCE_CM2_RANGE, "cm²"),  # controller.tolerance_cm2's
        metavar="CM2",
        help="stop when |e|² < CM2 [cm²]",
    )
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    config = config_from_args(args)
    check_closed_form(config)
    if args.solver == "analytic" and config.arm.closed_form is None:
        parser.error(
            f"--solver analytic: arm {config.arm.name!r} has no closed form "
            "(arm.closed_form is null); choose --solver pdpij or --solver mink"
        )
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
    servos = ServoMap.from_arm(config.arm)
    q_start = _start_pose(args.start, model, servos)
    target = _target(args.target, args.approach, config.arm, chain)
    result = solve_ik(model, controller, target, q_start)
    # an arm in mm or radians: valid, but not the one built; said once the input is taken
    # (bad input is one line: the closed form's error above leads with the same words)
    warning = unit_warning(config)
    if warning is not None:
        print(f"{parser.prog}: warning: {warning}", file=sys.stderr, flush=True)
    failure = result.failure
    unsendable = False
    if result.converged:
        found = servos.outside_pulse_range(result.q_config[chain.actuated_index])
        if found is not None:  # what the sort planner refuses before sending (task/plan.py)
            unsendable = True
            failure = IKFailure("limit", f"the solution cannot be sent: {found.error()}")
    if args.json:
        summary = result.summary()
        if failure is not None:
            summary.update(failure_kind=failure.kind, failure=failure.message)
        print(json.dumps(summary))
    else:
        _print_text(result, failure, chain, unsendable=unsendable)
    if result.converged and not unsendable:
        return EXIT_OK
    # as every command that did not do its job: the last line says why (stderr)
    why = f"failure ({failure.kind}): {failure.message}" if failure else str(result.status)
    print(f"{parser.prog}: {why}", file=sys.stderr)
    return EXIT_FAILURE


def _start_pose(start: list[float] | None, model: ArmModel, servos: ServoMap) -> np.ndarray:
    """``--start`` as every joint [model units]; home without one.

    Raises:
        InvalidJointsError: not one number per actuated joint.
        JointLimitError: a joint outside its limits, or (PulseRangeError) a pose a servo
            over several joints cannot be sent to.
    """
    chain = model.chain
    if start is None:
        return model.home
    if len(start) != chain.m:
        raise InvalidJointsError(
            start,
            f"--start needs {chain.m} numbers, the actuated joints "
            f"({', '.join(chain.actuated)}), got {len(start)}",
        )
    q_start = chain.from_named(dict(zip(chain.actuated, start, strict=True)))
    model.check_limits(q_start)
    found = servos.outside_pulse_range(start)
    if found is not None:
        raise found.error()  # the arm cannot be at this start: its servo cannot be sent
    return q_start


def _target(position: list[float], text: str | None, arm: ArmDescription, chain: Chain) -> IKTarget:
    """The target: ``--target`` and ``--approach`` (``pick``: the arm's pick approach).

    Raises:
        InvalidTargetError: an approach that is not three plain numbers or not a finite
            non-zero vector, ``pick`` on an arm without a pick approach, or any approach
            for an arm whose every actuated joint is needed to place the TCP.
    """
    approach: tuple[float, ...] | None = None
    if text == "pick":
        approach = arm.tool.pick_approach
        if approach is None:
            raise InvalidTargetError(f"--approach pick: arm {arm.name!r} has no tool.pick_approach")
    elif text is not None:
        try:
            approach = tuple(float_list(3, "--approach")(text))
        except argparse.ArgumentTypeError as exc:
            raise InvalidTargetError(str(exc)) from None
    target = IKTarget(tuple(position), approach)  # type: ignore[arg-type]
    if target.approach is not None and chain.m <= 3:
        # the solve would stop on the target with the approach off, "singular"
        raise InvalidTargetError(
            f"--approach: arm {arm.name!r} has {chain.m} actuated joints "
            f"({', '.join(chain.actuated)}), all needed to place the TCP, so its approach "
            "axis follows from the target and cannot be chosen; leave --approach out (an "
            "arm orients its approach with more than 3 actuated joints)"
        )
    return target


def _print_text(
    result: IKResult, failure: IKFailure | None, chain: Chain, *, unsendable: bool
) -> None:
    """The result for people: status, failure, errors, joints, TCP."""
    units = [chain.unit(i) for i in range(chain.n)]
    joints = ", ".join(
        f"{name} {v:.3f} {u}" for (name, v), u in zip(result.joints.items(), units, strict=True)
    )
    x, y, z = result.ee_cm
    plural = "" if result.iterations == 1 else "s"
    but = ", to a pose its servos cannot be sent to" if unsendable else ""
    print(f"{result.solver}: {result.status} after {result.iterations} iteration{plural}{but}")
    if result.recovered_from is not None:
        print(
            f"recovered ({result.method.replace('_', ' ')}): PD-PIJ alone "
            f"{result.recovered_from.replace('_', ' ')}; {result.search_iterations} "
            "updates searched, not in the path"
        )
    if failure is not None:
        print(f"failure ({failure.kind}): {failure.message}")
    print(f"error {result.initial_error_cm:.4f} -> {result.final_error_cm:.4f} cm")
    if result.final_approach_error_deg is not None:
        print(f"approach error {result.final_approach_error_deg:.3f} deg")
    print(f"joints: {joints}")
    print(f"ee = ({x:.3f}, {y:.3f}, {z:.3f}) cm")


if __name__ == "__main__":
    run(main)
