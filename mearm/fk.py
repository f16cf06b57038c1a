"""``python -m mearm.fk``: forward kinematics of a joint pose.

Example::

    python -m mearm.fk --config configs/lab.yaml --joints 120,93,-132 --json
"""

from __future__ import annotations

import json
from collections.abc import Sequence

import numpy as np

from mearm.cli import ArgumentParser, add_config_argument, config_from_args, float_list, run
from mearm.kinematics import ArmModel, couple


def main(argv: Sequence[str] | None = None) -> int:
    """Print the EE position for the given θ1, θ2, θ3 (θ4 from the coupling)."""
    parser = ArgumentParser(prog="python -m mearm.fk", description=__doc__.splitlines()[0])
    add_config_argument(parser)
    parser.add_argument(
        "--joints",
        type=float_list(3, "--joints"),
        required=True,
        help="θ1,θ2,θ3 in degrees (θ4 = −(θ2+θ3) is filled in)",
    )
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    config = config_from_args(args)
    model = ArmModel(config.robot)
    q_deg = couple(args.joints)
    model.check_limits(np.radians(q_deg))
    ee_cm = model.fk_cm(np.radians(q_deg))
    if args.json:
        print(
            json.dumps(
                {
                    "joints_deg": [round(v, 9) for v in q_deg.tolist()],
                    "ee_cm": [round(v, 9) for v in ee_cm.tolist()],
                }
            )
        )
    else:
        joints = ", ".join(f"{v:.2f}" for v in q_deg)
        x, y, z = ee_cm
        print(f"joints (θ1..θ4) = ({joints}) deg")
        print(f"ee = ({x:.2f}, {y:.2f}, {z:.2f}) cm")
    return 0


if __name__ == "__main__":
    run(main)
