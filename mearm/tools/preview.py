"""Show the bare arm of any config in the meshcat view (issue 6, item 3).

Serves the view on 127.0.0.1, prints its URL and keeps serving until Ctrl-C; or, with
--screenshot, renders it in headless Chromium to a PNG and exits. Joints are named as in
the config's ``arm.joints``; values in the config's units (deg, or cm for a prismatic
joint); passive joints follow their coupling.

Examples::

    mearm preview                                # home pose; open the printed URL
    mearm preview --config configs/sim_5dof.yaml # another arm
    mearm preview --joints shoulder=60,elbow=-100  # others stay at home
    mearm preview --sweep                        # each actuated joint, then the jaws
    mearm preview --sweep shoulder               # only the shoulder
    mearm preview --screenshot arm.png           # render headless and exit (--force: replace)
    mearm preview --collision                    # and the collision model, translucent
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from mearm.cli import (
    PLAIN_DECIMAL,
    PLAIN_INTEGER,
    ArgumentParser,
    add_config_argument,
    check_output_file,
    check_plain_number,
    config_from_args,
    plain_int,
    positive_number,
    refuse_own_inputs,
    refuse_to_replace,
    run,
)
from mearm.config import Config
from mearm.config.files import resolve_config_path, unit_warning
from mearm.hardware.mapping import ServoMap
from mearm.kinematics import ArmModel
from mearm.sim.table_collision import collision_model
from mearm.view import ArmView, find_browser

#: The --sweep argument meaning every actuated joint, then the gripper.
SWEEP_ALL = "all"
#: --step-deg, --rate-hz and --size when not given.
DEFAULT_STEP = 1.0
DEFAULT_RATE_HZ = 50.0
DEFAULT_SIZE = (1280, 800)


def _named_values(text: str) -> dict[str, float]:
    """``shoulder=60,elbow=-100`` → ``{"shoulder": 60.0, "elbow": -100.0}``."""
    out: dict[str, float] = {}
    for item in text.split(","):
        name, sep, value = item.partition("=")
        check_plain_number(
            value, f"--joints must be NAME=VALUE pairs with plain decimal values ({PLAIN_DECIMAL})"
        )
        try:
            number = float(value)
        except ValueError:
            number = float("nan")
        if not sep or not name.strip() or not np.isfinite(number):
            raise argparse.ArgumentTypeError(
                f"--joints must be NAME=VALUE pairs with finite values, e.g. "
                f"shoulder=60,elbow=-100; got {text!r}"
            )
        if name.strip() in out:  # which of the two was meant is not ours to guess
            raise argparse.ArgumentTypeError(
                f"--joints names {name.strip()!r} twice; give each joint once, got {text!r}"
            )
        out[name.strip()] = number
    return out


def _png_path(text: str) -> Path:
    """--screenshot's value; an empty one is refused (``Path('')`` is the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("the value is empty: give the path of a .png file")
    return Path(text)


def _window_size(text: str) -> tuple[int, int]:
    check_plain_number(text, f"--size must be WxH in plain integers ({PLAIN_INTEGER})")
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--size must be WxH, e.g. 1280x800, got {text!r}"
        ) from None
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise argparse.ArgumentTypeError(f"--size sides must be in [16, 8192] px, got {text!r}")
    return w, h


def sweep_poses_deg(
    start: Sequence[float],
    lower: Sequence[float],
    upper: Sequence[float],
    joints: Sequence[int],
    step: float,
) -> Iterator[np.ndarray]:
    """Actuated poses (config units: deg or cm) sweeping joints through their limits.

    Each joint goes from its start to its lower limit, up to its upper limit and back to
    the start, in steps of at most ``step``; the others stay at the start.
    """
    start_values = np.asarray(start, dtype=float)
    for j in joints:
        legs = [
            (start_values[j], lower[j]),
            (lower[j], upper[j]),
            (upper[j], start_values[j]),
        ]
        for a, b in legs:
            n = max(1, int(np.ceil(abs(b - a) / step)))
            for value in np.linspace(a, b, n + 1)[1:]:
                pose = start_values.copy()
                pose[j] = value
                yield pose


def sweep_openings_cm(open_cm: float, closed_cm: float, step_cm: float) -> Iterator[float]:
    """Gripper openings [cm]: open to closed and back, steps of at most ``step_cm``."""
    n = max(1, int(np.ceil(abs(open_cm - closed_cm) / step_cm)))
    for a, b in ((open_cm, closed_cm), (closed_cm, open_cm)):
        yield from (float(v) for v in np.linspace(a, b, n + 1)[1:])


def _parser() -> ArgumentParser:
    """The command line of :func:`main`."""
    parser = ArgumentParser(description=__doc__.splitlines()[0])
    add_config_argument(parser)
    parser.add_argument(
        "--joints",
        type=_named_values,
        metavar="NAME=VALUE,...",
        help="actuated joints [deg, or cm if prismatic]; those not named stay at home",
    )
    parser.add_argument(
        "--sweep",
        nargs="?",
        const=SWEEP_ALL,
        metavar="JOINT",
        help="sweep each actuated joint through its limits and open and close the jaws "
        "(or sweep only JOINT, an actuated joint's name)",
    )
    parser.add_argument(
        "--step-deg",
        type=positive_number(0.01, 360.0),
        default=None,
        help=f"with --sweep: its step [deg, or cm if prismatic], 0.01 … 360 (default "
        f"{DEFAULT_STEP:g})",
    )
    parser.add_argument(
        "--rate-hz",
        type=positive_number(0.1, 1000.0),
        default=None,
        help=f"with --sweep: its frame rate [Hz] (default {DEFAULT_RATE_HZ:g})",
    )
    parser.add_argument(
        "--screenshot", type=_png_path, metavar="OUT.png", help="render to a PNG, exit"
    )
    parser.add_argument(
        "--force", action="store_true", help="with --screenshot: replace the file if it exists"
    )
    parser.add_argument(
        "--size",
        type=_window_size,
        default=None,
        help=f"with --screenshot: the PNG's size WxH (default {DEFAULT_SIZE[0]}x{DEFAULT_SIZE[1]})",
    )
    parser.add_argument(
        "--hold", action="store_true", help="with --screenshot: keep serving after it"
    )
    parser.add_argument(
        "--collision",
        action="store_true",
        help="also draw the collision model the sort plans with (the arm's and the bins' "
        "shapes, translucent), moving with the arm",
    )
    parser.add_argument(
        "--port",
        type=plain_int,
        default=None,
        help="web port (default: 7000 or the next free; 0: any)",
    )
    return parser


def _check_joint_names(
    parser: ArgumentParser, args: argparse.Namespace, actuated: list[str]
) -> None:
    """Exit 2 (``parser.error``) on a --sweep or --joints name the arm does not actuate."""
    if args.sweep is not None and args.sweep not in (SWEEP_ALL, *actuated):
        parser.error(
            f"--sweep: unknown joint {args.sweep!r}; this arm's actuated joints: "
            f"{', '.join(actuated)}"
        )
    unknown = [n for n in args.joints or {} if n not in actuated]
    if unknown:
        parser.error(
            f"--joints: unknown joint(s) {', '.join(map(repr, unknown))}; this arm's "
            f"actuated joints: {', '.join(actuated)}"
        )


def _check_needed_flags(parser: ArgumentParser, args: argparse.Namespace) -> None:
    """Exit 2 on a flag that would do nothing: the one it works with was not given.

    ``--size 640x480`` without ``--screenshot`` would otherwise be dropped in silence
    while the user looks for its effect in the browser (as the sort refuses ``--hold``
    without ``--view``).
    """
    shot, sweep = "--screenshot", "--sweep"
    for flag, given, needs, needed, does in (
        ("--size", args.size is not None, shot, args.screenshot, "sizes the --screenshot PNG"),
        ("--force", args.force, shot, args.screenshot, "replaces the --screenshot file"),
        ("--hold", args.hold, shot, args.screenshot, "keeps serving after --screenshot"),
        ("--step-deg", args.step_deg is not None, sweep, args.sweep, "is the --sweep's step"),
        ("--rate-hz", args.rate_hz is not None, sweep, args.sweep, "paces the --sweep"),
    ):
        if given and needed is None:
            parser.error(f"{flag} {does}: use it with {needs}")


def _check_screenshot(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse, before the view starts, a --screenshot file that cannot be written (exit 2).

    Named as the flag: the view's own check would name its parameter (``out_png``).
    """
    shot = args.screenshot
    if shot.suffix.lower() != ".png" or shot.exists() and not shot.is_file():
        parser.error(f"--screenshot {shot}: must be a .png file (not a folder or a device)")
    # missing folders are made as the PNG is written, as by every command that writes;
    # a path under a file, or a folder that takes no file (/proc, read-only), is refused
    check_output_file(shot, "--screenshot")
    config_file = resolve_config_path(args.config) if args.config is not None else None
    refuse_own_inputs([("--screenshot", shot)], [("--config", config_file)])
    refuse_to_replace(shot, "--screenshot", args.force)


def _start_pose(config: Config, model: ArmModel, q: np.ndarray) -> list[float]:
    """The actuated joints of pose ``q`` in config units, once the arm can take it.

    Refused as ``mearm fk`` and the planner refuse it: joints out of their limits, or a
    servo over several joints (the MeArm v1's elbow servo: shoulder + elbow) that cannot
    be sent there, which was drawn as if the arm could take it.
    """
    model.check_limits(q)
    chain = model.chain
    start = chain.actuated_of(q) / chain.scale[chain.actuated_index]
    found = ServoMap.from_arm(config.arm).outside_pulse_range(start)
    if found is not None:
        raise found.error()
    return [float(v) for v in start]


def main(argv: Sequence[str] | None = None) -> int:
    """Serve (or render) the bare arm; see the module docstring."""
    parser = _parser()
    args = parser.parse_args(argv)
    _check_needed_flags(parser, args)
    browser = None
    if args.screenshot is not None:
        _check_screenshot(parser, args)
        browser = find_browser()  # none installed: exit 2 before anything is served
    config = config_from_args(args)
    warning = unit_warning(config)  # (as fk, ik and urdf say it: an arm drawn as given)
    if warning is not None:
        print(f"{parser.prog}: warning: {warning}", file=sys.stderr, flush=True)
    model = ArmModel(config.arm)
    chain = model.chain
    actuated = list(chain.actuated)
    _check_joint_names(parser, args, actuated)
    start_named = config.arm.home() | (args.joints or {})
    q_start = chain.from_named(start_named)  # unknown names: exit 2 before serving
    start = _start_pose(config, model, q_start)  # refused: exit 2 before serving
    scale = chain.scale[chain.actuated_index]
    lower, upper = chain.actuated_lower / scale, chain.actuated_upper / scale
    everything = args.sweep == SWEEP_ALL
    joints = range(chain.m) if everything else [actuated.index(args.sweep)] if args.sweep else []
    gripper = config.arm.tool.gripper

    def sweep(*, pace: bool) -> None:
        period = 1.0 / (args.rate_hz or DEFAULT_RATE_HZ)
        deadline = time.monotonic()

        def wait() -> None:
            nonlocal deadline
            if pace:
                deadline += period
                time.sleep(max(0.0, deadline - time.monotonic()))

        for pose in sweep_poses_deg(start, lower, upper, joints, args.step_deg or DEFAULT_STEP):
            q = chain.full(pose * scale)
            model.check_limits(q)
            view.show_joints(q)
            wait()
        if everything:
            step_cm = max(0.05, (gripper.open_cm - gripper.closed_cm) / 40)
            for opening in sweep_openings_cm(gripper.open_cm, gripper.closed_cm, step_cm):
                view.show_joints(q_start, opening)
                wait()

    collision = None
    if args.collision:
        collision = collision_model(config, model, clearance_cm=config.task.clearance_cm)

    with ArmView(model, config, port=args.port) as view:
        view.show_joints(q_start, gripper.open_cm)
        if collision is not None:
            view.show_collision(collision, track_world=True)  # the jaws follow the sweep
        if args.screenshot is not None:
            if args.sweep:
                sweep(pace=False)
            w, h = args.size or DEFAULT_SIZE
            out = view.screenshot(args.screenshot, width_px=w, height_px=h, browser=browser)
            print(f"wrote {out}", flush=True)
            if not args.hold:
                return 0
        print(f"meshcat view: {view.url}  (Ctrl-C to stop)", flush=True)
        while True:
            if args.sweep:
                sweep(pace=True)
            else:
                time.sleep(3600)


if __name__ == "__main__":
    run(main, sys.argv[1:])
