r"""``mearm calibrate-servos --simulate --truth``: the twin's kit's own calibration, written.

The twin knows each unit of its kit (:mod:`mearm.sim.twin.servo_kit`): its zero, µs per
degree, backlash and dead band. A fit — by keyboard or by the camera — can at best find
the first two and the play; this writes them exactly, as the same servo calibration file
the procedures write (:func:`~mearm.maker.servo_output.write_calibration`), as
``mearm render-calibration --truth`` writes the camera's truth. A sort run with it shows
what no calibration removes: each servo's dead band, the play the bus compensates only
on the way it moved (a load can pull a joint through its play), the looks' noise.

Each servo's entry is :func:`~mearm.sim.twin.servo_kit.unit_calibration` of its unit and
the nominal calibration its unit deviates from; its play is the unit's backlash in its
own pulses, the pulse a value needs reached rising less falling:
:math:`b\,k_u` (b its backlash [unit], :math:`k_u` its true µs per unit), positive
whatever its direction. No points (nothing was measured), residual 0.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mearm.config import Config
from mearm.config.servo_file import (
    ActuatorFit,
    fitted_servo,
    recorded_fit,
    replaced_calibration,
    servo_of,
)
from mearm.errors import MearmError
from mearm.maker.servo_output import check_output, write_calibration
from mearm.sim.twin.servo_kit import unit_calibration
from mearm.sim.twin.servo_model import ServoModel
from mearm.sim.twin.twin_bus import TwinArm

__all__ = ["check_truth_inputs", "true_fit", "truth_fits", "write_truth"]


def check_truth_inputs(config: Config, args: argparse.Namespace) -> None:
    """Refuse ``--truth`` where there is no kit to read.

    Raises:
        MearmError: ``--truth`` without ``--simulate``, with ``--camera`` or
            ``--actuators``, on a config that is not the MuJoCo twin, or one whose
            ``twin.kit`` is null (its servos are the nominal ones: nothing to write).
    """
    if not args.simulate:
        raise MearmError(
            "--truth writes the twin's kit's own calibration: it needs --simulate (a real "
            "arm's servos are known only by measuring them)"
        )
    if args.camera or args.actuators is not None:
        raise MearmError(
            "--truth writes every servo of the kit: leave out --camera and --actuators"
        )
    if config.simulator != "mujoco":
        raise MearmError(
            f"--truth reads the MuJoCo twin's kit: the config's simulator is "
            f"{config.simulator!r}; use one with simulator: mujoco"
        )
    if config.twin.kit is None:
        raise MearmError(
            "--truth: the config has no twin.kit (its servos are nominal, the arm's own "
            "calibration is their truth); add one, e.g. --set twin.kit.seed=32"
        )


def true_fit(config: Config, servo: ServoModel) -> ActuatorFit:
    """One servo's true calibration as the file's entry (module docstring).

    Raises:
        MearmError: the servo is nominal (no kit's unit).
        ServoCalibrationError: a true value the servo's calibration refuses (a kit far
            beyond the ranges as published), or limits it would narrow too far.
    """
    if servo.unit is None:
        raise MearmError(f"--truth: the twin's servo {servo.name!r} is nominal, not a kit's unit")
    a = servo.physical
    zero, direction, k = unit_calibration(servo.unit, a.zero_us, a.direction, a.us_per_unit)
    play_us = servo.backlash / servo.scale * k
    template = servo_of(config.arm, servo.name)
    fitted = fitted_servo(template, servo.name, zero, direction * k, play_us=play_us)
    nominal = (replaced_calibration(config) or config).arm
    return recorded_fit(config, ActuatorFit(servo.name, a.unit, fitted, (), 0.0), nominal)


def truth_fits(config: Config) -> list[ActuatorFit]:
    """Every servo of the twin's kit (joints, then the gripper), as the file's entries."""
    return [true_fit(config, s) for s in TwinArm(config).servos]


def write_truth(config: Config, output: Path, args: argparse.Namespace) -> int:
    """``--truth``: check, write the file as the procedures do; the exit status.

    Raises:
        MearmError: bad input (:func:`check_truth_inputs`, an existing output without
            ``--force``), before anything is written.
    """
    check_truth_inputs(config, args)
    check_output(output, force=bool(args.force))
    kit = config.twin.kit
    assert kit is not None  # checked above
    trial = f" trial {config.servo.error_model.seed}" if kit.per_trial else ""
    board = (
        f"simulated: the MuJoCo twin, kit seed {kit.seed} spread {kit.spread:g}{trial}; "
        "the kit's true calibration (--truth)"
    )
    return write_calibration(config, truth_fits(config), board, "", output, force=bool(args.force))
