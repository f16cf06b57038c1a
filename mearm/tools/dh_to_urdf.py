"""Write the URDF of an arm description (by default: every reference arm).

    mearm urdf     # robot_description/<arm>.urdf for each reference arm (configs/arms/)
    mearm urdf --config configs/lab.yaml [--output arm.urdf] [--force] [--set key=value ...]

Without ``--output`` the file goes to the source checkout's ``robot_description/`` (that
is where the reference arms' URDFs are kept); an installed wheel has no checkout, so
there ``--output`` is required. ``<arm>.urdf`` of a reference arm is that arm's own: it
is rewritten only with that arm's URDF (regenerating it), never with another arm's, even
with ``--force`` and by whatever path it is named; give another ``--output`` or the arm
a name of its own. Any other file that is there is replaced only with ``--force``, and
never one the config is read from.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

from mearm.cli import (
    ArgumentParser,
    add_config_argument,
    check_closed_form,
    check_output_file,
    config_from_args,
    refuse_own_inputs,
    refuse_to_replace,
    run,
    write_text_atomic,
)
from mearm.config import ArmDescription, Config
from mearm.config.compose import EXTENDS_KEY, MAX_EXTENDS, USE_KEY, reference_arm
from mearm.config.files import read_yaml, resolve_config_path, unit_warning
from mearm.data import (
    URDF_DIR,
    arm_names,
    packaged_arm,
    packaged_config,
    shown_path,
    source_checkout,
)
from mearm.errors import MearmError
from mearm.fileio import file_identity
from mearm.kinematics import ArmModel, generate_urdf

#: What a URDF file's name ends with (``--output`` must).
URDF_SUFFIX = ".urdf"


def output_folder() -> Path | None:
    """Where URDFs go without ``--output``: the checkout's robot_description/.

    ``None`` from an installed wheel: its only such folder is the package's own copy
    of the reference URDFs, in site-packages, which is no place to write.
    """
    checkout = source_checkout()
    return None if checkout is None else checkout / "robot_description"


def _output_value(text: str) -> Path:
    """``--output``'s value; an empty one is refused (``Path('')`` is the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError(
            f"the value is empty: give the path of a {URDF_SUFFIX} file to write"
        )
    return Path(text)


def _reference_urdf(name: str) -> str:
    return generate_urdf(ArmDescription.model_validate(reference_arm(name)))


def _shipped_reference(path: Path) -> str | None:
    """The reference arm whose shipped URDF ``path`` names (by any path or link), else None."""
    here = file_identity(path)
    try:
        target = path.resolve()
    except (OSError, RuntimeError):  # a loop of links: the write says so
        return None
    for name in arm_names():
        shipped = URDF_DIR / f"{name}{URDF_SUFFIX}"
        if target == shipped.resolve() or (here is not None and here == file_identity(shipped)):
            return name
    return None


def _config_inputs(config_arg: Path | None, config: Config) -> list[tuple[str, Path | None]]:
    """The files this run reads: the config, what it ``extends`` and ``use``s, its calibrations.

    Called once the config has loaded, so the chain it walks is known to be sound.
    """
    if config_arg is None:
        return []
    path: Path | None = resolve_config_path(config_arg)
    inputs: list[tuple[str, Path | None]] = [("--config", path)]
    for _ in range(MAX_EXTENDS + 1):
        if path is None:
            break
        data = read_yaml(path)
        if not isinstance(data, Mapping):
            break
        arm = data.get("arm")
        if isinstance(arm, Mapping) and isinstance(arm.get(USE_KEY), str):
            inputs.append((f"arm.{USE_KEY}", packaged_arm(arm[USE_KEY])))
        name = data.get(EXTENDS_KEY)
        if not isinstance(name, str):
            break
        given = path.parent / name
        path = given if given.is_file() else packaged_config(name)
        inputs.append((EXTENDS_KEY, path))
    inputs.append(("servo.calibration_file", _as_path(config.servo.calibration_file)))
    if config.calibration.model == "perspective":  # else the files are not read
        for key in ("intrinsics_file", "extrinsics_file"):
            inputs.append((f"calibration.{key}", _as_path(getattr(config.calibration, key))))
    return inputs


def _as_path(value: object) -> Path | None:
    return Path(value) if isinstance(value, str | Path) and str(value) else None


def _check_output(output: Path, name: str, urdf: str, *, given: bool, force: bool) -> None:
    """Refuse (exit 2) replacing a reference arm's URDF with another's, or any file unforced.

    A shipped reference URDF may only be regenerated (the reference arm's URDF as the
    generator writes it now: the documented ``python tools/dh_to_urdf.py``), with or
    without --force; any other existing file needs --force.
    """
    reference = _shipped_reference(output)
    if reference is None and not given and name in arm_names():
        reference = name  # the default folder is where the reference URDFs are kept
    if reference is not None:
        if urdf == _reference_urdf(reference):
            return
        if not given:
            raise MearmError(
                f"{output} is the URDF of the reference arm {reference!r} "
                f"(configs/arms/{reference}.yaml), and this config changes that arm: give "
                "--output FILE, or the arm a name of its own (--set arm.name=my_arm)"
            )
        raise MearmError(
            f"--output {output}: is the URDF of the reference arm {reference!r} "
            f"(configs/arms/{reference}.yaml), and this config's arm is not that arm: "
            "write elsewhere (not even --force replaces a reference arm's URDF)"
        )
    refuse_to_replace(output, "--output" if given else "the default output", force)


def _warn_units(prog: str, config: Config) -> None:
    """Say on stderr, in the words of a sort's config check, when the arm's units look wrong.

    An 80 cm link or an alpha of 1.5708° is a valid arm (so the URDF is written, exit 0),
    but most likely a hobby arm's 8 cm written in mm, or 90° written in radians
    (:func:`~mearm.config.files.unit_warning`, as ``mearm fk`` and ``mearm ik`` say it);
    a URDF ten times too large, or of a chain that folds the wrong way, is not found by
    looking at it.
    """
    warning = unit_warning(config)
    if warning is not None:
        print(
            f"{prog}: warning: {warning}; the URDF is written with the arm as given",
            file=sys.stderr,
            flush=True,
        )


def main(argv: Sequence[str] | None = None) -> int:
    """Write the URDF(s); 0 on success."""
    default_folder = output_folder()
    folder = (
        f"{shown_path(default_folder)}/<arm name>.urdf"
        if default_folder is not None
        else "none: an installed mearm has no source checkout, so give --output"
    )
    parser = ArgumentParser(
        description="Arm description → URDF (metres, radians). Without --config or --set: "
        "every reference arm's URDF, into the source checkout's robot_description/."
    )
    add_config_argument(parser)
    parser.add_argument(
        "--output",
        type=_output_value,
        help=f"URDF file to write, ending in {URDF_SUFFIX} (with --config; default: {folder})",
    )
    parser.add_argument(
        "--force",
        action="store_true",
        help="replace an existing output file (never the config, nor a reference arm's "
        "URDF with another arm's)",
    )
    args = parser.parse_args(argv)
    if args.output is not None and args.output.exists() and not args.output.is_file():
        parser.error(f"--output {args.output}: exists and is not a regular file")
    every = args.config is None and not args.set
    if every and args.output is not None:
        parser.error("--output needs --config (without it every reference arm is written)")
    if args.output is None and default_folder is None:
        parser.error(
            "no source checkout to write robot_description/ into (mearm is installed from "
            f"a wheel; the reference arms' URDFs ship in {shown_path(URDF_DIR)}): "
            + ("give --config and --output FILE" if every else "give --output FILE")
        )
    inputs: list[tuple[str, Path | None]] = []
    if every:
        arms = [ArmDescription.model_validate(reference_arm(name)) for name in arm_names()]
    else:
        config = config_from_args(args)
        check_closed_form(config)  # every command that plans would stop on it
        arms = [config.arm]
        inputs = _config_inputs(args.config, config)
        if args.output is not None:
            if args.output.suffix.lower() != URDF_SUFFIX:
                parser.error(
                    f"--output {args.output}: a URDF file's name ends in {URDF_SUFFIX} "
                    f"(got {args.output.suffix or 'no suffix'}), e.g. {config.arm.name}.urdf"
                )
            check_output_file(args.output, "--output")
    jobs = []
    for arm in arms:
        ArmModel(arm)  # Pinocchio must accept what we write
        urdf = generate_urdf(arm)
        given = args.output is not None
        output = args.output or (default_folder or Path()) / f"{arm.name}{URDF_SUFFIX}"
        refuse_own_inputs([("--output" if given else "the default output", output)], inputs)
        _check_output(output, arm.name, urdf, given=given, force=args.force)
        jobs.append((output, urdf))
    if not every:  # every check passed: the warning is the only line on stderr
        _warn_units(parser.prog, config)
    for output, urdf in jobs:  # every check passed: nothing is half done
        write_text_atomic(output, urdf)
        print(f"wrote {output}")
    return 0


if __name__ == "__main__":
    run(main)
