"""``mearm``: one command, a subcommand per job.

    mearm sort --config configs/sim.yaml [--set arm.joints.base.home=100]
    mearm --help

Each subcommand is the same program as its module or tool (``mearm sort`` is
``python -m mearm.sort``, ``mearm urdf`` is ``python tools/dh_to_urdf.py``) and takes the
same arguments; ``mearm SUBCOMMAND --help`` lists them.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from mearm.cli import EXIT_BAD_INPUT, run

#: subcommand → (where its ``main`` lives, one line of help). ``tools/X.py`` entries are
#: scripts of the source checkout.
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "sort": ("mearm.sort", "sort the objects on the table into their class's bins"),
    "detect": ("mearm.detect", "detect the objects in a frame (image file or camera)"),
    "fk": ("mearm.fk", "forward kinematics: joints → TCP position"),
    "ik": ("mearm.ik.__main__", "inverse kinematics: solve one target from a start pose"),
    "urdf": ("tools/dh_to_urdf.py", "write the URDF of an arm description"),
    "preview": ("tools/preview.py", "show the arm in the meshcat 3-D view"),
    "calibrate-camera": ("tools/calibrate_camera.py", "fit pixel → table from markers or points"),
    "calibrate-intrinsics": (
        "tools/calibrate_intrinsics.py",
        "fit camera matrix and lens distortion from ChArUco board views",
    ),
    "charuco-board": ("tools/charuco_board.py", "write the printable ChArUco calibration board"),
    "experiment": ("mearm.experiment", "repeated sorting trials into one run log"),
    "analyze": ("mearm.analyze", "tables, fits and plots from a run log"),
    "bench": ("tools/bench.py", "benchmarks, side by side with the peers"),
    "render-calibration": (
        "tools/render_calibration.py",
        "render the twin camera's ChArUco views and marker sheet",
    ),
    "check-camera": ("tools/check_camera.py", "check the camera calibration with the arm"),
}

_ROOT = Path(__file__).resolve().parent.parent


def _usage() -> str:
    width = max(map(len, SUBCOMMANDS))
    rows = "\n".join(f"  {name:<{width}}  {text}" for name, (_, text) in SUBCOMMANDS.items())
    return (
        "usage: mearm SUBCOMMAND [ARGS ...]\n\n"
        "A vision-guided colour-sorting robot arm, for any hobby arm described as data.\n\n"
        f"subcommands:\n{rows}\n\n"
        "Every subcommand that reads a config takes --config FILE and --set KEY=VALUE.\n"
        "mearm SUBCOMMAND --help shows its arguments."
    )


def _load(target: str, name: str) -> Callable[[Sequence[str] | None], int]:
    if target.endswith(".py"):
        path = _ROOT / target
        if not path.is_file():
            print(
                f"mearm {name}: needs the source checkout ({target} is not installed)",
                file=sys.stderr,
            )
            sys.exit(EXIT_BAD_INPUT)
        spec = importlib.util.spec_from_file_location(f"mearm_tool_{path.stem}", path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        # registered first, as an import would: dataclasses and pickling look it up there
        sys.modules[spec.name] = module
        spec.loader.exec_module(module)
    else:
        module = importlib.import_module(target)
    main: Callable[[Sequence[str] | None], int] = module.main
    return main


def main(argv: Sequence[str] | None = None) -> None:
    """Dispatch to a subcommand (exit 2 with the list on an unknown one)."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args:
        print(_usage())
        print(
            "mearm: error: no subcommand given (usage: mearm SUBCOMMAND [ARGS ...]; "
            "mearm --help lists them)",
            file=sys.stderr,
        )
        sys.exit(EXIT_BAD_INPUT)
    if args[0] in ("-h", "--help", "help"):
        print(_usage())
        sys.exit(0)
    if args[0] == "--version":
        from mearm import __version__

        print(f"mearm {__version__}")
        sys.exit(0)
    name, rest = args[0], args[1:]
    if name not in SUBCOMMANDS:
        print(
            f"mearm: error: unknown subcommand {name!r} (choose from {', '.join(SUBCOMMANDS)})",
            file=sys.stderr,
        )
        sys.exit(EXIT_BAD_INPUT)
    sys.argv = [f"mearm {name}", *rest]
    run(_load(SUBCOMMANDS[name][0], name), rest)


if __name__ == "__main__":
    main()
