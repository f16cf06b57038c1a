"""The virtual Uno's own servos: how its simulated servos turn a pulse into a value.

A simulated board stands for a physical one, whose servos turn as they are built, not as
the host believes: the host makes its pulses by its present map (a servo calibration file
fitted to the board, or the one ``calibrate-servos`` or ``servo.calibrate_at_start`` fits
during the run), the servos turn by theirs. Read back through the host's map, the pulses
would always land where the host intended, and a calibration done on the virtual Uno
could never find an error.

The rig's servos are the arm's calibration before the config's servo calibration file
(each actuator's ``replaces``: :func:`~mearm.config.servo_file.replaced_calibration`, as
the twin's kit of servos takes them); without a file, the config's own. ``twin.kit`` is
the MuJoCo twin's (its units' backlash and dead band have no place in the kinematic arm
the virtual Uno drives), so it draws nothing here.
"""

from __future__ import annotations

import logging

from mearm.config import ArmDescription, Config
from mearm.hardware import ServoMap

log = logging.getLogger(__name__)


def own_servo_map(config: Config) -> ServoMap:
    """The virtual Uno's servos: the config's calibration before its servo calibration file.

    Raises:
        ServoCalibrationError, ConfigError: as :func:`own_arm`.
    """
    return ServoMap.from_arm(own_arm(config))


def own_arm(config: Config) -> ArmDescription:
    """The rig's arm: the config's before its servo calibration file, limits too.

    A file that records no replaced calibration (one written before ``replaces`` was) is
    taken as the rig's own, with a warning: nothing says what it replaced.

    Raises:
        ServoCalibrationError, ConfigError: the file cannot be read again, or the
            calibration it replaced does not fit the config
            (:func:`~mearm.config.servo_file.replaced_calibration`).
    """
    if config.servo.calibration_file is None:
        return config.arm
    # imported only for a config that names such a file, as the config's loader does
    from mearm.config.servo_file import replaced_calibration  # noqa: PLC0415

    nominal = replaced_calibration(config)
    if nominal is None:
        log.warning(
            "%s records no replaced calibration: the virtual Uno's servos turn by the "
            "calibration it gives",
            config.servo.calibration_file,
        )
    return (nominal or config).arm
