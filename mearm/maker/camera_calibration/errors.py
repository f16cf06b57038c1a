"""The camera's servo calibration's own error."""

from __future__ import annotations

from mearm.errors import MearmError


class CameraCalibrationFailed(MearmError):
    """The procedure ended without a calibration (exit 1); the message says why."""
