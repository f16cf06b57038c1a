"""Exceptions raised by mearm.

Every error the package raises on purpose derives from :class:`MearmError`, so a caller
(and every CLI) can catch one type. Subclasses name the cause and keep the offending
values as attributes; their messages say what was wrong and what is allowed.
"""

from __future__ import annotations

from collections.abc import Sequence


class MearmError(Exception):
    """Base class for all errors raised by mearm."""


class ConfigError(MearmError):
    """A configuration file is missing, malformed or has invalid values.

    Attributes:
        path: The file that was read, or ``None`` for an in-memory mapping.
        problems: One line per bad field: its dotted path, the value, what is allowed.
    """

    def __init__(self, path: str | None, problems: Sequence[str]):
        self.path = path
        self.problems = list(problems)
        where = f"{path}: " if path else ""
        if len(self.problems) == 1:
            super().__init__(f"{where}{self.problems[0]}")
        else:
            lines = "; ".join(self.problems)
            super().__init__(f"{where}{len(self.problems)} problems: {lines}")


class ModelError(MearmError):
    """The robot description (URDF / DH table) is missing or inconsistent."""


class JointLimitError(MearmError):
    """A joint angle is outside its limits.

    Attributes:
        joint: Joint name, e.g. ``"joint2"``.
        value_deg: The offending angle [deg].
        lower_deg: Lower limit [deg].
        upper_deg: Upper limit [deg].
    """

    def __init__(self, joint: str, value_deg: float, lower_deg: float, upper_deg: float):
        self.joint = joint
        self.value_deg = float(value_deg)
        self.lower_deg = float(lower_deg)
        self.upper_deg = float(upper_deg)
        super().__init__(
            f"{joint} = {self.value_deg:.4g} deg is outside its limits "
            f"[{self.lower_deg:.4g}, {self.upper_deg:.4g}] deg"
        )


class InvalidTargetError(MearmError):
    """A target is not three finite numbers."""


class TargetError(MearmError):
    """A Cartesian target cannot be used; raised before anything moves.

    Attributes:
        target_cm: The target (x, y, z) in the base frame [cm].
        reason: Why it was refused.
    """

    def __init__(self, target_cm: Sequence[float], reason: str):
        self.target_cm = tuple(float(v) for v in target_cm)
        self.reason = reason
        x, y, z = self.target_cm
        super().__init__(f"target ({x:.4g}, {y:.4g}, {z:.4g}) cm: {reason}")


class TargetOutsideBoxError(TargetError):
    """The target lies outside the end-effector target box (SPEC §3, Table 3).

    Attributes:
        axis: The violated axis, ``"x"``, ``"y"`` or ``"z"``.
        bounds_cm: The allowed (min, max) on that axis [cm].
    """

    def __init__(self, target_cm: Sequence[float], axis: str, bounds_cm: tuple[float, float]):
        self.axis = axis
        self.bounds_cm = (float(bounds_cm[0]), float(bounds_cm[1]))
        value = float(target_cm["xyz".index(axis)])
        super().__init__(
            target_cm,
            f"{axis} = {value:.4g} is outside the target box {axis} ∈ "
            f"[{self.bounds_cm[0]:.4g}, {self.bounds_cm[1]:.4g}] cm",
        )


class UnreachableTargetError(TargetError):
    """The target is inside the box but the arm cannot reach it within its joint limits."""


class RunLogError(MearmError):
    """A run log cannot be opened, appended to or written in the order asked.

    Attributes:
        path: The log file.
    """

    def __init__(self, path: object, message: str):
        self.path = str(path)
        super().__init__(f"{self.path}: {message}")


class RunLogFormatError(RunLogError):
    """One line of a run log is not a valid record (torn, not JSON, a field missing or wrong).

    :func:`mearm.runlog.read_runlog` returns this (it does not raise it unless asked to)
    together with every record before the bad line.

    Attributes:
        path: The log file.
        line: The bad line's number, counting from 1.
        reason: What is wrong with it.
        text: The start of the bad line (at most 80 characters).
    """

    def __init__(self, path: object, line: int, reason: str, text: str = ""):
        self.line = int(line)
        self.reason = reason
        self.text = text
        super().__init__(path, f"line {self.line}: {reason}")


class AnalysisError(MearmError):
    """The data cannot be analysed as asked (no routes, too few errors to fit, ...)."""


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


class CalibrationError(MearmError):
    """A pixel ↔ table calibration cannot be fitted or used (SPEC §4).

    Attributes:
        reason: What is wrong and what to do.
    """

    def __init__(self, reason: str):
        self.reason = reason
        super().__init__(reason)


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
