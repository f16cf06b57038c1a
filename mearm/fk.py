"""Forward kinematics: where the tool is for given joint angles (mearm fk).

Example::

    python -m mearm.fk --config configs/lab.yaml --joints 120,93,-132 --json

``--joints`` lists the actuated joints in the config's order and units (deg, or cm for a
prismatic joint); passive joints follow from their couplings. Joints outside their
limits, or that a servo over several joints (the MeArm v1's elbow servo: shoulder +
elbow) cannot be sent to within its pulse range, are refused (exit 2). The JSON's
``joint_units`` gives each joint's unit.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence

from mearm.cli import (
    ArgumentParser,
    add_config_argument,
    config_from_args,
    float_list,
    invoked_as,
    run,
)
from mearm.config.files import unit_warning
from mearm.hardware.mapping import ServoMap
from mearm.ik.result import joint_units
from mearm.kinematics import ArmModel


def _rounded(value: float) -> float:
    """``value`` to 9 decimals, with ``-0.0`` as ``0.0``.

    A cosine of 90° is ±6e-17: rounded, the JSON would print an axis as ``-0.0``.
    """
    return round(value, 9) + 0.0


def main(argv: Sequence[str] | None = None) -> int:
    """Print every joint and the TCP position for the given actuated joints."""
    parser = ArgumentParser(
        prog=invoked_as("python -m mearm.fk"), description=__doc__.splitlines()[0]
    )
    add_config_argument(parser)
    parser.add_argument(
        "--joints",
        type=float_list(None, "--joints"),
        required=True,
        help="the actuated joints in deg (cm if prismatic), in the config's order",
    )
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    config = config_from_args(args)
    model = ArmModel(config.arm)
    chain = model.chain
    if len(args.joints) != chain.m:  # an argument error: its values need no echo
        parser.error(
            f"--joints needs {chain.m} numbers, the actuated joints "
            f"({', '.join(chain.actuated)}), got {len(args.joints)}"
        )
    q = chain.from_named(dict(zip(chain.actuated, args.joints, strict=True)))
    model.check_limits(q)
    found = ServoMap.from_arm(config.arm).outside_pulse_range(args.joints)
    if found is not None:
        raise found.error()  # a pose the servos cannot be sent to, as the planner refuses it
    # an arm in mm or radians: valid, but not the one built; said once the input is taken
    # (bad input is one line)
    warning = unit_warning(config)
    if warning is not None:
        print(f"{parser.prog}: warning: {warning}", file=sys.stderr, flush=True)
    ee_cm = model.fk_cm(q)
    approach = model.approach(q)
    named = chain.named(q)
    if args.json:
        print(
            json.dumps(
                {
                    "joints": {k: _rounded(v) for k, v in named.items()},
                    "joint_units": joint_units(chain.names, chain.scale),
                    "ee_cm": [_rounded(v) for v in ee_cm.tolist()],
                    "approach": [_rounded(v) for v in approach.tolist()],
                }
            )
        )
    else:
        joints = ", ".join(f"{k} {v:.2f} {chain.unit(i)}" for i, (k, v) in enumerate(named.items()))
        x, y, z = ee_cm
        print(f"joints: {joints}")
        print(f"ee = ({x:.2f}, {y:.2f}, {z:.2f}) cm")
    return 0


if __name__ == "__main__":
    run(main)
