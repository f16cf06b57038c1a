"""``mearm calibrate-servos``: fit each servo's pulse calibration by jogging it with the keyboard.

    mearm calibrate-servos --config my.yaml [--port /dev/ttyACM0] [--output my.servos.yaml]
        [--actuators shoulder,elbow] [--force]
    mearm calibrate-servos --camera --config my.yaml [--simulate] [--output …] [--force]
    mearm calibrate-servos --simulate --truth --config my.yaml [--output …] [--force]

With ``--camera`` no keys are pressed: the arm visits points over the table by itself and
the calibrated camera's view of the marker on the claw fits every joint servo
(:mod:`mearm.maker.calibrate_by_camera`; docs/servos.md). With ``--simulate --truth``
nothing is measured: the twin's kit's own calibration is written
(:mod:`mearm.maker.servo_truth`), the bound of any fit. The rest of this docstring is
the keyboard procedure.

For each actuator (the actuated joints, the tool actuators, then the gripper) the screen
shows two reference values chosen from its limits (a fifth of the range in from each
end, on a 5° or 0.5 cm grid). Jog the actuator with the keys until it is at the shown
value — by eye, a protractor or a ruler — and press Enter; after the second the zero,
µs per unit and direction are fitted (:mod:`mearm.config.servo_file`) and checked: a
µs per unit more than 30 % off the arm's own, or a shaft more than 12° off the arm's at
the neutral pulse, is refused with the reason, as is anything the config's own checks
refuse; a refused fit is never written, the actuator is done again. Limits (for a servo
that turns a combination: the joint's limits with the other joints at home) that the
fit puts outside the servo's pulse range are narrowed to what it reaches, and said
(:mod:`mearm.config.servo_reach`); by more than a quarter of them, or past the joint's
home, the fit is refused.

A joint servo that turns a combination of joints (its ``drives``: the MeArm's elbow servo
turns the forearm's angle to the table, shoulder + elbow) is calibrated on that
combination: the references are values of it, chosen from the range it takes over the
joints' limits, within what the present calibration's pulse range reaches, and the
screen asks for the combination (``shoulder + elbow = 45 deg``), not for the joint.

Before a joint's references the other joints are moved, if need be, to where both
references keep every joint inside its limits (the screen says so): the MeArm's elbow
servo, asked for ``shoulder + elbow = -45 deg`` with the shoulder at 120°, would put
the elbow past its stop, and then turn the shoulder instead of the forearm.

Keys: ``+``/``-`` or →/← move by the step; ↑/↓ or ``1``/``2``/``3`` set the step (1, 5,
20 µs); Enter or Space records the reference; Backspace goes back to the previous one;
``s`` skips the actuator (its calibration stays as configured); ``q`` stops without
writing anything.

Every pulse sent lies inside the actuator's ``[min_us, max_us]``, whatever keys are
pressed (the keys stop at the ends, and the servo bus refuses anything outside). The
session starts by sending every actuator its home value under the present calibration,
then only changes the actuator being calibrated (and, before a joint's references, the
other joints as above).

The keys are not stopped at the limits: the calibration being measured is what says
where they are, and a fit may need a pulse past them. But under the present calibration
the arm may really be past them (the MeArm v1's base read 180.9° at 544 µs, its limits
[45, 135]°), where the links may collide: a jog that takes an actuator past its limits
prints one line, ``warning: base is at 135.5 deg, past its limits [45, 135] deg: the
links may collide with each other, the base or the table`` (for a servo that turns a
combination, the joint it sits in), once each time it crosses out, and one when it is
back inside; the status line says ``(past the limits: base)`` meanwhile.

On a simulated arm the status line also shows the arm's reading of the actuator
(``simulated arm: 4.00 cm``; on the virtual Uno every actuator's measured pulse under the
present calibration, but a joint past its limits reads its stop), or says there is none
(the kinematic simulator's gripper is only open or closed).

The calibration file is written at the end, atomically, only if at least one actuator
was calibrated and every fit passes its checks again, all together (else exit 1,
nothing written). With ``--simulate`` no one is there to redo a fit: one refused twice
ends the command with exit 1 and nothing written (no partial file). An existing file
is replaced only after a y/N question (or with ``--force``/``--yes``), and only if it
is a servo calibration; the old one is kept as ``<name>.bak``. An ``--output`` that
cannot be written (a folder, a path under a file, a read-only folder) is refused before
anything opens; if the write still fails at the end (a full disk), the fits are printed
as ``--set`` overrides before the error (exit 2). Ctrl-C writes nothing
and leaves the arm where it is (exit 130); ``q`` writes nothing (exit 1). Needs a
terminal: without one, exit 2 before anything opens; a port that cannot be opened, or a
board that does not answer, is exit 2 too (one line), before anything moves.

A config uses the file through ``servo.calibration_file`` (relative to the config's
folder); the command prints that line, and the equivalent ``--set`` overrides.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path

from mearm import interrupts
from mearm.cli import (
    PLAIN_DECIMAL,
    ArgumentParser,
    add_config_argument,
    check_plain_number,
    config_from_args,
    run,
    seed_value,
)
from mearm.config import Config
from mearm.errors import MearmError
from mearm.maker.keyboard_calibration.calibrator import (
    STEPS_US,
    Abandoned,
    Calibrator,
    calibrate_by_keyboard,
)
from mearm.maker.keyboard_calibration.pulse_session import PulseSession, open_arm_bus
from mearm.maker.keyboard_calibration.references import (
    POSE_GRID,
    POSE_INSET,
    REFERENCE_GRID,
    REFERENCE_INSET,
    Actuator,
    actuators_of,
    actuators_of_map,
    joints_overrun,
    pose_overrun,
    pose_settings,
    poses_inside,
    reference_pose,
    reference_values,
    servo_span,
)
from mearm.maker.keyboard_calibration.simulated import (
    READING_ERROR,
    SIM_APPROACH_US,
    SIM_SETTLE_S,
    FitRefused,
    SimulatedCalibrator,
    simulate,
)

__all__ = [
    "Abandoned",
    "Actuator",
    "Calibrator",
    "FitRefused",
    "POSE_GRID",
    "POSE_INSET",
    "PulseSession",
    "READING_ERROR",
    "REFERENCE_GRID",
    "REFERENCE_INSET",
    "SIM_APPROACH_US",
    "SIM_SETTLE_S",
    "STEPS_US",
    "SimulatedCalibrator",
    "actuators_of",
    "actuators_of_map",
    "build_parser",
    "calibrate_by_keyboard",
    "default_output",
    "joints_overrun",
    "main",
    "open_arm_bus",
    "pose_overrun",
    "pose_settings",
    "poses_inside",
    "reading_error",
    "reference_pose",
    "reference_values",
    "run",
    "servo_span",
    "simulate",
]


def default_output(config_path: Path | None) -> Path:
    """``<config>.servos.yaml`` beside the config, or ``servos.yaml`` here."""
    if config_path is None:
        return Path("servos.yaml")
    return config_path.with_name(config_path.stem + ".servos.yaml")


def build_parser() -> ArgumentParser:
    """The command's arguments."""
    parser = ArgumentParser(
        prog="mearm calibrate-servos",
        description=(
            "Fit each servo's zero, µs per degree and direction: jog it with the keyboard "
            "to two reference angles shown on screen. Writes a servo calibration file."
        ),
    )
    add_config_argument(parser)
    parser.add_argument("--port", default=None, help="serial port (default: servo.port)")
    parser.add_argument(
        "--output",
        type=Path,
        default=None,
        help="calibration file to write (default: <config>.servos.yaml beside the config)",
    )
    parser.add_argument(
        "--actuators",
        default=None,
        metavar="NAMES",
        help="comma-separated actuators to calibrate (default: every one)",
    )
    parser.add_argument(
        "--force",
        "--yes",
        action="store_true",
        help="replace an existing calibration file without asking (the old one → .bak)",
    )
    parser.add_argument(
        "--camera",
        action="store_true",
        help="fit every joint servo from where the calibrated camera sees the ArUco marker on "
        "the claw (arm.tool.marker; needs calibration.model: perspective), no keys: the arm "
        "visits points over the table by itself; with --simulate on the twin",
    )
    sim = parser.add_argument_group(
        "simulated (--simulate)",
        "the procedure run against the twin (simulator: mujoco; its twin.kit's servos): "
        "the twin jogs each actuator and reads it, as a maker with a protractor would",
    )
    sim.add_argument(
        "--simulate",
        action="store_true",
        help="run against the MuJoCo twin with no keys (needs simulator: mujoco)",
    )
    sim.add_argument(
        "--reading-error",
        type=reading_error,
        default=READING_ERROR["deg"],
        metavar="DEG",
        help=f"the simulated maker's reading error, one std [deg] (default "
        f"{READING_ERROR['deg']:g}: a protractor by eye)",
    )
    sim.add_argument(
        "--reading-error-cm",
        type=reading_error,
        default=READING_ERROR["cm"],
        metavar="CM",
        help=f"the same for the jaws' opening [cm] (default {READING_ERROR['cm']:g}: a ruler)",
    )
    sim.add_argument(
        "--reading-seed",
        type=seed_value,
        default=0,
        help="seed of the simulated reading errors (default 0)",
    )
    sim.add_argument(
        "--truth",
        action="store_true",
        help="with --simulate, measure nothing: write the twin's kit's true calibration "
        "(each unit's zero, µs per unit, direction and play), what a perfect fit would give",
    )
    return parser


def reading_error(text: str) -> float:
    """An argparse type: a reading error, a finite number in [0, 10]."""
    check_plain_number(text, f"a reading error is a plain decimal number ({PLAIN_DECIMAL})")
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"a reading error is a number, got {text[:40]!r}"
        ) from None
    if not (math.isfinite(value) and 0.0 <= value <= 10.0):
        raise argparse.ArgumentTypeError(f"a reading error lies in [0, 10], got {text[:40]!r}")
    return value


def _chosen(config: Config, names: str | None) -> list[Actuator]:
    every = actuators_of(config)
    if names is None:
        return every
    by_name = {a.name: a for a in every}
    chosen = []
    for name in (n.strip() for n in names.split(",")):
        if name not in by_name:
            raise MearmError(f"--actuators: no actuator {name!r}; this arm's: {', '.join(by_name)}")
        if by_name[name] in chosen:  # twice would fit it twice and write one of them
            raise MearmError(f"--actuators: {name!r} is named twice; name each actuator once")
        chosen.append(by_name[name])
    return chosen


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command (see the module docstring); returns the exit status.

    SIGTERM and SIGHUP stop it as Ctrl-C does: the arm held or parked, nothing written.
    """
    with interrupts.stop_signals_as_ctrl_c():
        return _calibrate(argv)


def _calibrate(argv: Sequence[str] | None) -> int:
    args = build_parser().parse_args(argv)
    config = config_from_args(args)
    output = args.output if args.output is not None else default_output(args.config)
    if args.truth:  # the twin's kit as it is (mearm.maker.servo_truth)
        from mearm.maker.servo_truth import write_truth  # noqa: PLC0415

        return write_truth(config, output, args)
    if args.camera:  # the camera's procedure (mearm.maker.calibrate_by_camera)
        from mearm.maker.calibrate_by_camera import calibrate_by_camera  # noqa: PLC0415

        return calibrate_by_camera(config, output, args)
    actuators = _chosen(config, args.actuators)
    if args.simulate:
        return simulate(config, actuators, output, args)
    return calibrate_by_keyboard(config, actuators, output, args)


if __name__ == "__main__":
    run(main)
