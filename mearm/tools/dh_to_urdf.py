"""Write the URDF of an arm description (by default: every reference arm).

    mearm urdf     # robot_description/<arm>.urdf for each reference arm (configs/arms/)
    mearm urdf --config configs/lab.yaml [--output arm.urdf] [--set key=value ...]

Without ``--output`` the file goes to ``robot_description/``: the checkout's, when mearm
runs from a source checkout (that is where the reference arms' URDFs are kept), else
the one in the current folder. There, ``<arm>.urdf`` of a reference arm is that arm's
own: a config that changes the arm and keeps its name is refused (exit 2), so that the
reference file is not replaced by another arm's; give ``--output`` or a name of its own.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from mearm.cli import ArgumentParser, add_config_argument, config_from_args, run, write_text_atomic
from mearm.config import ArmDescription
from mearm.config.compose import reference_arm
from mearm.data import arm_names, shown_path, source_checkout
from mearm.errors import MearmError
from mearm.kinematics import ArmModel, generate_urdf


def output_folder() -> Path:
    """Where URDFs go without ``--output``: the checkout's robot_description/, else ./."""
    checkout = source_checkout()
    return (checkout if checkout is not None else Path()) / "robot_description"


def _reference_urdf(name: str) -> str:
    return generate_urdf(ArmDescription.model_validate(reference_arm(name)))


def main(argv: Sequence[str] | None = None) -> int:
    """Write the URDF(s); 0 on success."""
    folder = shown_path(output_folder())
    parser = ArgumentParser(
        description="Arm description → URDF (metres, radians). Without --config or --set: "
        f"every reference arm's URDF, into {folder}/."
    )
    add_config_argument(parser)
    parser.add_argument(
        "--output",
        type=Path,
        help=f"URDF to write (with --config; default: {folder}/<arm name>.urdf)",
    )
    args = parser.parse_args(argv)
    if args.output is not None and args.output.exists() and not args.output.is_file():
        parser.error(f"--output {args.output}: exists and is not a regular file")
    if args.config is None and not args.set:
        if args.output is not None:
            parser.error("--output needs --config (without it every reference arm is written)")
        arms = [ArmDescription.model_validate(reference_arm(name)) for name in arm_names()]
    else:
        arms = [config_from_args(args).arm]
    for arm in arms:
        ArmModel(arm)  # Pinocchio must accept what we write
        urdf = generate_urdf(arm)
        output = args.output or output_folder() / f"{arm.name}.urdf"
        if args.output is None and arm.name in arm_names() and urdf != _reference_urdf(arm.name):
            raise MearmError(
                f"{output} is the URDF of the reference arm {arm.name!r} "
                f"(configs/arms/{arm.name}.yaml), and this config changes that arm: give "
                "--output FILE, or the arm a name of its own (--set arm.name=my_arm)"
            )
        write_text_atomic(output, urdf)
        print(f"wrote {output}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    run(main)
