"""Errors of the configuration's parts that are not plain values: calibrations, the port.

A calibration (a servo's angle ↔ pulse, a camera's pixel ↔ table) is data in its own
file that a config includes; :class:`CalibrationError` is raised where one cannot be
fitted, read or used, here for the servos and in :mod:`mearm.vision` for the camera.
A bad value in a config file is a :class:`~mearm.errors.ConfigError`.
"""

from __future__ import annotations

from collections.abc import Sequence

from mearm.errors import MearmError


class CalibrationError(MearmError):
    """A pixel ↔ table calibration cannot be fitted or used (paper §4).

    Attributes:
        reason: What is wrong and what to do.
    """

    def __init__(self, reason: str):
        self.reason = reason
        super().__init__(reason)


class ServoCalibrationError(CalibrationError):
    """A servo calibration cannot be fitted, read, written or applied (names what and why)."""


class SerialPortError(MearmError, ValueError):
    """``servo.port`` is neither a device path nor a URL of an allowed scheme.

    pyserial's ``serial_for_url`` opens more than serial ports: ``spy://`` writes (and
    truncates) a log file named in the URL, ``hwgrep://`` opens whichever device matches
    a pattern. Only device paths and the schemes in ``allowed`` are opened. A
    ``ValueError`` too, so a pydantic validator may raise it as it is.

    Attributes:
        port: The value given.
        reason: What is wrong with it.
        allowed: The URL schemes accepted besides device paths.
    """

    def __init__(self, port: object, reason: str, allowed: Sequence[str]):
        self.port = port
        self.reason = reason
        self.allowed = tuple(allowed)
        urls = ", ".join(f"{s}://" for s in self.allowed)
        super().__init__(
            f"servo.port {port!r}: {reason}; give a device path (e.g. /dev/ttyACM0, "
            f"/dev/ttyUSB0, COM3) or a URL of {urls}"
        )
