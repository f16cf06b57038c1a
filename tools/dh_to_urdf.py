"""Write the arm's URDF generated from the DH table of a config.

python tools/dh_to_urdf.py [--config configs/lab.yaml] [--output robot_description/mearm.urdf]
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from mearm.cli import ArgumentParser, add_config_argument, config_from_args, run
from mearm.exceptions import MearmError
from mearm.kinematics import ArmModel, dh_to_urdf

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_OUTPUT = ROOT / "robot_description" / "mearm.urdf"


def main(argv: Sequence[str] | None = None) -> int:
    parser = ArgumentParser(prog="dh_to_urdf.py", description="DH table → URDF (metres, radians).")
    add_config_argument(parser)
    parser.add_argument("--output", type=Path, default=DEFAULT_OUTPUT, help="URDF to write")
    args = parser.parse_args(argv)
    config = config_from_args(args)
    text = dh_to_urdf(config.robot)
    ArmModel(config.robot)  # Pinocchio must accept what we write
    try:
        args.output.parent.mkdir(parents=True, exist_ok=True)
        tmp = args.output.with_suffix(args.output.suffix + ".tmp")
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(args.output)
    except OSError as exc:
        raise MearmError(f"cannot write {args.output}: {exc}") from None
    print(f"wrote {args.output}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    run(main)
