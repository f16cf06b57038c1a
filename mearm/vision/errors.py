"""Errors of the camera and its pictures.

A camera calibration that cannot be fitted or used is a
:class:`~mearm.config.errors.CalibrationError`.
"""

from __future__ import annotations

from mearm.errors import MearmError


class ImageError(MearmError):
    """An image cannot be used: missing, unreadable, or not an 8-bit BGR frame.

    Attributes:
        source: Where the image came from (a path, or a description such as ``"frame"``).
        reason: What is wrong with it.
    """

    def __init__(self, source: str, reason: str):
        self.source = source
        self.reason = reason
        super().__init__(f"{source}: {reason}")


class CameraError(MearmError):
    """A camera source cannot be opened or stopped delivering frames.

    Attributes:
        source: The source, e.g. ``"device 0"``, ``"folder frames/"``, ``"sim"``.
        reason: What went wrong and what to check.
    """

    def __init__(self, source: str, reason: str):
        self.source = source
        self.reason = reason
        super().__init__(f"camera ({source}): {reason}")
