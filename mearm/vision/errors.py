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


class TrackingError(MearmError):
    """Frames given to the tracker out of the order they were taken.

    Attributes:
        t_s: The frame's time [s].
        last_s: The time of the frame before it [s].
    """

    def __init__(self, t_s: float, last_s: float | None):
        self.t_s = t_s
        self.last_s = last_s
        super().__init__(
            f"tracker: frame time {t_s!r} s is not finite or earlier than the last frame's "
            f"({last_s!r} s); give frames in the order they were taken, each at the time it "
            "was taken (read time minus camera.latency_s)"
        )


class SampleError(MearmError):
    """A colour sample that cannot teach a class (``mearm learn-colours``).

    Attributes:
        sample: The sample as given, ``CLASS=U,V``.
        reason: What is wrong with it and what to do.
    """

    def __init__(self, sample: str, reason: str):
        self.sample = sample
        self.reason = reason
        super().__init__(f"sample {sample}: {reason}")
