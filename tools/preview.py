"""Show the bare arm in the meshcat view (issue 6, item 3).

Serves the view on 127.0.0.1, prints its URL and keeps serving until Ctrl-C; or, with
--screenshot, renders it in headless Chromium to a PNG and exits.

Examples::

    python tools/preview.py                          # home pose; open the printed URL
    python tools/preview.py --joints 90,60,-100      # θ1,θ2,θ3 [deg]; θ4 = −(θ2+θ3)
    python tools/preview.py --sweep                  # each joint through its limits, looping
    python tools/preview.py --sweep joint2           # only joint 2
    python tools/preview.py --screenshot arm.png     # render headless and exit
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from mearm.cli import ArgumentParser, add_config_argument, config_from_args, float_list, run
from mearm.config import ACTUATED_JOINTS
from mearm.kinematics import ArmModel, couple
from mearm.view import ArmView


def _window_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--size must be WxH, e.g. 1280x800, got {text!r}"
        ) from None
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise argparse.ArgumentTypeError(f"--size sides must be in [16, 8192] px, got {text!r}")
    return w, h


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return value


def sweep_poses_deg(
    start_deg: Sequence[float],
    lower_deg: Sequence[float],
    upper_deg: Sequence[float],
    joints: Sequence[int],
    step_deg: float,
) -> Iterator[np.ndarray]:
    """(θ1, θ2, θ3) poses [deg] sweeping each joint in ``joints`` through its limits.

    Each joint goes from its start to its lower limit, up to its upper limit and back to
    the start, in steps of at most ``step_deg``; the others stay at the start.
    """
    start = np.asarray(start_deg, dtype=float)
    for j in joints:
        legs = [(start[j], lower_deg[j]), (lower_deg[j], upper_deg[j]), (upper_deg[j], start[j])]
        for a, b in legs:
            n = max(1, int(np.ceil(abs(b - a) / step_deg)))
            for value in np.linspace(a, b, n + 1)[1:]:
                pose = start.copy()
                pose[j] = value
                yield pose


def main(argv: Sequence[str] | None = None) -> int:
    """Serve (or render) the bare arm; see the module docstring."""
    parser = ArgumentParser(prog="python tools/preview.py", description=__doc__.splitlines()[0])
    add_config_argument(parser)
    parser.add_argument(
        "--joints",
        type=float_list(3, "--joints"),
        help="θ1,θ2,θ3 in degrees (θ4 = −(θ2+θ3) is filled in); default: home",
    )
    parser.add_argument(
        "--sweep",
        nargs="?",
        const="all",
        choices=["all", *ACTUATED_JOINTS],
        metavar="JOINT",
        help="sweep each joint (or only JOINT: joint1, joint2, joint3) through its limits",
    )
    parser.add_argument("--step-deg", type=_positive, default=1.0, help="sweep step [deg]")
    parser.add_argument("--rate-hz", type=_positive, default=50.0, help="sweep frame rate [Hz]")
    parser.add_argument("--screenshot", type=Path, metavar="OUT.png", help="render to a PNG, exit")
    parser.add_argument("--size", type=_window_size, default=(1280, 800), help="PNG size WxH")
    parser.add_argument("--hold", action="store_true", help="keep serving after --screenshot")
    parser.add_argument(
        "--port", type=int, default=None, help="web port (default: 7000 or the next free; 0: any)"
    )
    args = parser.parse_args(argv)

    config = config_from_args(args)
    model = ArmModel(config.robot)
    start_deg = np.asarray(args.joints if args.joints is not None else config.robot.home_deg)
    model.check_limits(np.radians(couple(start_deg)))  # bad joints: exit 2 before serving
    limits = config.robot.joint_limits_deg.as_list()[:3]
    lower, upper = [r.min for r in limits], [r.max for r in limits]
    joints = range(3) if args.sweep in (None, "all") else [ACTUATED_JOINTS.index(args.sweep)]

    def sweep(pace: bool) -> None:
        period = 1.0 / args.rate_hz
        deadline = time.monotonic()
        for pose in sweep_poses_deg(start_deg, lower, upper, joints, args.step_deg):
            q = np.radians(couple(pose))
            model.check_limits(q)
            view.show_joints(q)
            if pace:
                deadline += period
                time.sleep(max(0.0, deadline - time.monotonic()))

    with ArmView(model, config, port=args.port) as view:
        view.show_joints(np.radians(couple(start_deg)))
        if args.screenshot is not None:
            if args.sweep:
                sweep(pace=False)
            w, h = args.size
            out = view.screenshot(args.screenshot, width_px=w, height_px=h)
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
