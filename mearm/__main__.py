"""``mearm``: one command, a subcommand per job.

    mearm sort --config sim [--set arm.joints.base.home=100]
    mearm --help

Each subcommand is the ``main`` of one module of the package (``mearm sort`` is
``python -m mearm.sort``, ``mearm urdf`` is :mod:`mearm.tools.dh_to_urdf`, which the
checkout's ``python tools/dh_to_urdf.py`` also runs) and takes the same arguments;
``mearm SUBCOMMAND --help`` lists them. Every one of them ships in the wheel.
``mearm --help`` lists them by what you want to do (:data:`GROUPS`).
"""

from __future__ import annotations

import gc
import importlib
import sys
import textwrap
from collections.abc import Callable, Sequence

from mearm import interrupts
from mearm.cli import EXIT_BAD_INPUT, one_line, run
from mearm.data import config_names, doc_page

#: The groups ``mearm --help`` shows, in order: a title (what you want to do), then each
#: subcommand → (the module whose ``main(argv) -> int`` it runs, one line of help). A new
#: command is one more entry in its group.
GROUPS: dict[str, dict[str, tuple[str, str]]] = {
    "start here: from a new kit to a working rig": {
        "init-config": (
            "mearm.maker.init_config",
            "write a starter config and its wiring, or a twin of your config",
        ),
        "find-port": ("mearm.maker.find_port", "list the serial ports and name the mearm board"),
        "flash": ("mearm.maker.flash", "build the Uno firmware and upload it with avrdude"),
        "find-camera": ("mearm.maker.find_camera", "list the cameras with a snapshot of each"),
        "jog": ("mearm.maker.jog", "move the arm with the keyboard, joint by joint or in x/y/z"),
    },
    "sort and see": {
        "sort": ("mearm.sort", "sort the objects on the table into their class's bins"),
        "detect": ("mearm.detect", "detect the objects in a frame (image file or camera)"),
        "preview": ("mearm.tools.preview", "show the arm in the meshcat 3-D view"),
        "fk": ("mearm.fk", "forward kinematics: joints → TCP position"),
        "ik": ("mearm.ik.__main__", "inverse kinematics: solve one target from a start pose"),
        "urdf": ("mearm.tools.dh_to_urdf", "write the URDF of an arm description"),
    },
    "calibrate": {
        "calibrate-servos": (
            "mearm.maker.calibrate_servos",
            "fit each servo's zero, µs per degree and direction with the keyboard",
        ),
        "aruco-sheet": ("mearm.tools.aruco_sheet", "write a printable sheet of ArUco markers"),
        "calibrate-camera": (
            "mearm.tools.calibrate_camera",
            "fit pixel → table from markers or points",
        ),
        "charuco-board": (
            "mearm.tools.charuco_board",
            "write the printable ChArUco calibration board",
        ),
        "calibrate-intrinsics": (
            "mearm.tools.calibrate_intrinsics",
            "fit camera matrix and lens distortion from ChArUco board views",
        ),
        "check-camera": ("mearm.tools.check_camera", "check the camera calibration with the arm"),
        "learn-colours": (
            "mearm.maker.learn_colours",
            "teach each class its colour from clicks on the camera's own frames",
        ),
    },
    "the twin and experiments": {
        "twin-scenes": (
            "mearm.tools.twin_scenes",
            "sort seeded random scenes in the physical twin and count what lands",
        ),
        "experiment": ("mearm.experiment", "repeated sorting trials into one run log"),
        "analyze": ("mearm.analyze", "tables, fits and plots from a run log"),
        "reproduce-paper": (
            "mearm.tools.reproduce_paper",
            "run the paper's 24 demo routes and compare with its figures",
        ),
        "render-calibration": (
            "mearm.tools.render_calibration",
            "render the twin camera's ChArUco views and marker sheet",
        ),
    },
    "data and learning": {
        "dataset": (
            "mearm.dataset.__main__",
            "check or show a LeRobot dataset recorded by --record",
        ),
        "eval-policy": (
            "mearm.tools.eval_policy",
            "score a policy over seeded twin episodes (lerobot-eval's figures)",
        ),
    },
    "measure and develop": {
        "bench": ("mearm.tools.bench", "benchmarks, side by side with the peers"),
        "vision-bench": (
            "mearm.tools.vision_bench",
            "the detector's timings and accuracy beside its peers",
        ),
        "camera-accuracy": (
            "mearm.tools.camera_accuracy",
            "score where the twin's calibrated camera sees objects",
        ),
        "shape-sweep": (
            "mearm.tools.shape_sweep",
            "how well the detector tells the shapes apart at every size and yaw",
        ),
        "conveyor-sweep": (
            "mearm.tools.conveyor_sweep",
            "conveyor belt sorts per speed and the tracking error at the grip",
        ),
        "servo-steps": (
            "mearm.tools.servo_steps",
            "the twin's servo step responses: a CSV and a plot",
        ),
        "ik-stalls": ("mearm.tools.ik_stalls", "how often the IK stops short, per arm and start"),
        "quantization": (
            "mearm.tools.quantization",
            "the TCP error of whole-degree and whole-µs servo commands, per arm",
        ),
        "virtual-uno-pulses": (
            "mearm.tools.virtual_uno_pulses",
            "measure how closely the virtual Uno's pins follow the commands",
        ),
        "config-docs": (
            "mearm.tools.config_docs",
            "write docs/configuration.md from the config schema",
        ),
    },
}

#: Every subcommand → (its module, its line of help), the groups flattened.
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    name: entry for group in GROUPS.values() for name, entry in group.items()
}


def _usage() -> str:
    width = max(map(len, SUBCOMMANDS))
    groups = "\n\n".join(
        f"{title}:\n"
        + "\n".join(f"  {name:<{width}}  {text}" for name, (_, text) in commands.items())
        for title, commands in GROUPS.items()
    )
    return (
        "usage: mearm SUBCOMMAND [ARGS ...]\n\n"
        "A vision-guided colour-sorting robot arm, for any hobby arm described as data.\n"
        "First time? mearm sort --config sim (a simulated sort), then "
        f"{doc_page('maker-path.md')}.\n\n"
        f"{groups}\n\n"
        + textwrap.fill(
            "Every subcommand that reads a config takes --config FILE and --set KEY=VALUE "
            "(but calibrate-camera, which writes its FILE, and eval-policy, whose "
            "environment takes --env-option); FILE may also name a config shipped with "
            f"mearm: {', '.join(config_names())}.",
            width=88,
            break_on_hyphens=False,
        )
        + "\nmearm SUBCOMMAND --help shows its arguments."
    )


def _load(target: str) -> Callable[[Sequence[str] | None], int]:
    """The subcommand's ``main``, its module imported with the collector paused.

    A subcommand's imports make tens of thousands of objects that live as long as the
    process (pydantic's schemas, the arm's tables); collecting them frees nothing. They
    are made with the collector paused and then set aside (``gc.freeze``), as
    ``python -m mearm.sort`` does for itself (docs/benchmarks.md).
    """
    paused = gc.isenabled()
    if paused:
        gc.disable()
    try:
        main: Callable[[Sequence[str] | None], int] = importlib.import_module(target).main
    finally:
        if paused:
            gc.freeze()
            gc.enable()
    interrupts.raise_swallowed_ctrl_c()  # C code's initialisation may swallow a Ctrl-C
    return main


def _own(argv: Sequence[str] | None) -> int:
    """What the dispatcher answers itself: no subcommand, help, the version, a bad name."""
    args = list(argv or ())
    if not args:
        print(_usage())
        print(
            "mearm: error: no subcommand given (usage: mearm SUBCOMMAND [ARGS ...]; "
            "mearm --help lists them)",
            file=sys.stderr,
        )
        return EXIT_BAD_INPUT
    if args[0] == "--version":
        from mearm import __version__

        print(f"mearm {__version__}")
        return 0
    if args[0] in ("-h", "--help", "help"):
        print(_usage())
        return 0
    said = one_line(f"unknown subcommand {args[0]!r} (choose from {', '.join(SUBCOMMANDS)})")
    print(f"mearm: error: {said}", file=sys.stderr)
    return EXIT_BAD_INPUT


def main(argv: Sequence[str] | None = None) -> None:
    """Dispatch to a subcommand (exit 2 with the list on an unknown one).

    ``mearm help NAME`` is ``mearm NAME --help``. What the dispatcher prints itself runs
    under the same guard as a subcommand (:func:`mearm.cli.run`): ``mearm --help | head``
    ends quietly. The subcommand's module is imported under that guard too: its imports
    are most of a command's first half second, and a Ctrl-C there is one line and exit
    130 like one later on, not a traceback.
    """
    args = list(sys.argv[1:] if argv is None else argv)
    if args[:1] == ["help"] and len(args) > 1:
        args = [args[1], "--help"] if args[1] in SUBCOMMANDS else args[1:]
    if not args or args[0] not in SUBCOMMANDS:
        run(_own, args)
    name, rest = args[0], args[1:]
    sys.argv = [f"mearm {name}", *rest]
    target = SUBCOMMANDS[name][0]
    run(lambda given: _load(target)(given), rest)  # its module imported inside the guard


if __name__ == "__main__":
    main()
