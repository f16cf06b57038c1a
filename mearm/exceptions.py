"""Exceptions raised by mearm.

Every error the package raises on purpose derives from :class:`MearmError`, so a caller
(and every CLI) can catch one type. Subclasses name the cause and keep the offending
values as attributes; their messages say what was wrong and what is allowed.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence


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


class CollisionError(MearmError):
    """A motion would bring the arm's body too close to something; nothing of it was sent.

    Too close: within ``task.clearance_cm`` of a bin or an object, or touching the table
    (:mod:`mearm.kinematics.collision`).
    """


class JointLimitError(MearmError):
    """A joint angle is outside its limits.

    Attributes:
        joint: Joint name, e.g. ``"shoulder"``.
        value_deg: The offending value [deg, or cm for a prismatic joint].
        lower_deg: Lower limit [same unit].
        upper_deg: Upper limit [same unit].
        unit: ``deg`` or ``cm``.
    """

    def __init__(
        self, joint: str, value_deg: float, lower_deg: float, upper_deg: float, unit: str = "deg"
    ):
        self.joint = joint
        self.value_deg = float(value_deg)
        self.lower_deg = float(lower_deg)
        self.upper_deg = float(upper_deg)
        self.unit = unit
        super().__init__(
            f"{joint} = {self.value_deg:.4g} {unit} is outside its limits "
            f"[{self.lower_deg:.4g}, {self.upper_deg:.4g}] {unit}"
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
    """The target lies outside the end-effector target box (paper §3, Table 3).

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


class JointLimitTargetError(UnreachableTargetError):
    """The links reach the target, but only with a joint outside its limits.

    Attributes:
        joint: The joint that would leave its limits.
        value: The value it would need [deg, or cm for a prismatic joint].
        lower: Its lower limit [same unit].
        upper: Its upper limit [same unit].
        unit: ``deg`` or ``cm``.
    """

    def __init__(
        self,
        target_cm: Sequence[float],
        joint: str,
        value: float,
        lower: float,
        upper: float,
        unit: str = "deg",
    ):
        self.joint = joint
        self.value = float(value)
        self.lower = float(lower)
        self.upper = float(upper)
        self.unit = unit
        super().__init__(
            target_cm,
            f"needs {joint} = {self.value:.2f} {unit}, outside its limits "
            f"[{self.lower:g}, {self.upper:g}] {unit}",
        )


class SingularTargetError(UnreachableTargetError):
    """The target sits where the arm is singular (on the base axis: the base is undefined).

    Belongs in :mod:`mearm.exceptions` beside :class:`UnreachableTargetError`.
    """


class RunLogError(MearmError):
    """A run log cannot be opened, appended to or written in the order asked.

    Attributes:
        path: The log file.
    """

    def __init__(self, path: object, message: str):
        self.path = str(path)
        super().__init__(f"{self.path}: {message}")


class RepeatedTrialError(RunLogError):
    """A trial number is complete more than once in one log: two runs pooled in one file.

    Attributes:
        path: The log file.
        lines: Per repeated trial number, the header lines of its complete attempts.
    """

    def __init__(self, path: object, lines: Mapping[int, Sequence[int]]):
        self.lines = {k: tuple(v) for k, v in lines.items()}
        numbers = sorted(self.lines)
        shown = ", ".join(map(str, numbers[:10])) + (" …" if len(numbers) > 10 else "")
        first = numbers[0]
        where = " and ".join(map(str, self.lines[first]))
        super().__init__(
            path,
            f"trial{'s' if len(numbers) > 1 else ''} {shown} "
            f"{'are' if len(numbers) > 1 else 'is'} complete more than once (trial {first} "
            f"at lines {where}): the file holds two runs of the same trials; analyse "
            "each run's log on its own",
        )


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
    """A pixel ↔ table calibration cannot be fitted or used (paper §4).

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


class ViewError(MearmError):
    """The meshcat view cannot be started, updated or rendered."""


class ViewPortError(ViewError):
    """The view's web port cannot be used.

    Attributes:
        port: The port asked for.
        reason: Why it cannot be used (usually "Address already in use").
    """

    def __init__(self, port: int, reason: str):
        self.port = port
        self.reason = reason
        super().__init__(
            f"port {port} on 127.0.0.1: {reason}; choose another port or leave it unset "
            "to take the first free one from 7000"
        )


class ViewInputError(ViewError):
    """A value given to the view has the wrong shape, type or range.

    Attributes:
        argument: The argument's name, e.g. ``"q_rad"``.
        value: A short repr of the value given.
        allowed: What is allowed.
    """

    def __init__(self, argument: str, value: object, allowed: str):
        self.argument = argument
        text = repr(value)
        self.value = text if len(text) <= 80 else text[:77] + "..."
        self.allowed = allowed
        super().__init__(f"{argument} = {self.value}: expected {allowed}")


class BrowserNotFoundError(ViewError):
    """No Chromium-family browser to render the view headlessly.

    Attributes:
        candidates: The executable names looked up on PATH.
    """

    def __init__(self, candidates: tuple[str, ...]):
        self.candidates = tuple(candidates)
        super().__init__(
            f"no headless browser found (looked for {', '.join(self.candidates)} on PATH, "
            "and $MEARM_CHROMIUM); install one, e.g. `apt-get install chromium`"
        )


# --------------------------------------------------------------------------- servo I/O
# Raised by mearm.hardware. Every fault carries ``last_state``: the last pose the board
# acknowledged (a ``mearm.hardware.ArmState``, or ``None`` before the first move), so a
# caller always knows where the arm was last told to be.


class WorldError(MearmError):
    """An impossible change of the simulated world, e.g. releasing when nothing is held."""


class InvalidCommandError(MearmError):
    """An arm command is malformed.

    It must name exactly the arm's actuated joints and tool actuators, with finite
    values, and its gripper flag must be a bool.
    """


class PulseRangeError(JointLimitError):
    """A joint angle needs a servo pulse outside its channel's [min_us, max_us].

    The inherited ``lower_deg``/``upper_deg`` are the angles the pulse range allows.

    Attributes:
        channel: Servo channel of the joint.
        pulse_us: The pulse the angle maps to [µs].
        min_us: Lowest allowed pulse [µs].
        max_us: Highest allowed pulse [µs].
    """

    def __init__(
        self,
        joint: str,
        value_deg: float,
        lower_deg: float,
        upper_deg: float,
        *,
        channel: int,
        pulse_us: float,
        min_us: float,
        max_us: float,
        unit: str = "deg",
    ):
        self.joint = joint
        self.value_deg = float(value_deg)
        self.lower_deg = float(lower_deg)
        self.upper_deg = float(upper_deg)
        self.channel = channel
        self.pulse_us = float(pulse_us)
        self.min_us = float(min_us)
        self.max_us = float(max_us)
        self.unit = unit
        MearmError.__init__(
            self,
            f"{joint} = {self.value_deg:.4g} {unit} needs a {self.pulse_us:.1f} µs pulse on "
            f"channel {channel}, outside its [{self.min_us:g}, {self.max_us:g}] µs: the "
            f"pulse range allows {joint} in [{self.lower_deg:.4g}, {self.upper_deg:.4g}] {unit} "
            "(its servo calibration in arm: in the config)",
        )


class ServoError(MearmError):
    """The servo link or board failed.

    Attributes:
        last_state: The last pose the board acknowledged (``mearm.hardware.ArmState``),
            or ``None`` if no move was acknowledged yet.
    """

    def __init__(self, message: str, *, last_state: object | None = None):
        self.last_state = last_state
        pose = "none (no move acknowledged yet)" if last_state is None else str(last_state)
        super().__init__(f"{message}; last acknowledged pose: {pose}")


class ServoNotConnectedError(ServoError):
    """A command was given to a servo bus that is not connected (call ``connect()``)."""


class ServoFaultedError(ServoError):
    """The bus refuses to send: an earlier fault stopped it. Close it and connect again.

    Attributes:
        fault: The error that stopped the bus.
    """

    def __init__(self, fault: ServoError):
        self.fault = fault
        super().__init__(
            f"servo bus stopped after an earlier fault ({type(fault).__name__}); nothing is "
            "sent after a fault: close the bus and connect again",
            last_state=fault.last_state,
        )


class HandshakeError(ServoError):
    """The board answered, but this backend cannot drive it.

    Its firmware, protocol version, servo count or pulse range does not fit the config.
    """


class LinkError(ServoError):
    """The serial link cannot be opened or was lost.

    Attributes:
        port: The serial port or URL.
    """

    def __init__(self, port: str, message: str, *, last_state: object | None = None):
        self.port = port
        super().__init__(f"{port}: {message}", last_state=last_state)


class LinkDroppedError(LinkError):
    """The link was lost while talking to the board (cable pulled, board power lost)."""


class BannerTimeoutError(LinkError):
    """The board did not print its banner after the port was opened (and reset it).

    Attributes:
        timeout_s: How long we waited [s].
        received: Every byte received meanwhile.
    """

    def __init__(self, port: str, timeout_s: float, received: bytes):
        self.timeout_s = float(timeout_s)
        self.received = bytes(received)
        seen = f"received {self.received[:60]!r}" if received else "received nothing"
        super().__init__(
            port,
            f"no banner within {self.timeout_s:g} s ({seen}). Is tools/arduino/mearm_servo "
            "flashed, is this the right port, and is servo.baud the sketch's baud rate? "
            "Raise servo.banner_timeout_s if the board is slow to boot",
        )


class NoAckError(LinkError):
    """The board did not acknowledge a command in time.

    Attributes:
        frame: The unacknowledged command as sent.
        timeout_s: The acknowledgement timeout [s].
        garbage: Unparseable bytes received while waiting.
    """

    def __init__(
        self,
        port: str,
        frame: bytes,
        timeout_s: float,
        garbage: bytes = b"",
        *,
        last_state: object | None = None,
    ):
        self.frame = bytes(frame)
        self.timeout_s = float(timeout_s)
        self.garbage = bytes(garbage)
        extra = (
            f"; received only garbage {self.garbage[:60]!r}: check servo.baud and the firmware"
            if garbage
            else ""
        )
        super().__init__(
            port,
            f"no acknowledgement of {self.frame!r} within {self.timeout_s:g} s{extra}",
            last_state=last_state,
        )


class GarbledReplyError(ServoError):
    """Every try of a command got a corrupted or unintelligible reply.

    Attributes:
        frame: The command as sent.
        attempts: How many times it was sent.
        reply: The last bad reply.
    """

    def __init__(
        self,
        frame: bytes,
        attempts: int,
        reply: bytes,
        reason: str = "garbled reply",
        *,
        last_state: object | None = None,
    ):
        self.frame = bytes(frame)
        self.attempts = int(attempts)
        self.reply = bytes(reply)
        super().__init__(
            f"{reason} on all {self.attempts} tries of {self.frame!r} (last reply "
            f"{self.reply!r}); electrical noise on the link? (servo.retries sets the tries)",
            last_state=last_state,
        )


class ChecksumError(GarbledReplyError):
    """A command failed its checksum on every try (at the board or in its reply)."""


class BoardError(ServoError):
    """The board refused a command with a numbered error (tools/arduino/PROTOCOL.md).

    Attributes:
        code: The error number.
        reason: What the number means.
        detail: Extra text the board sent.
        frame: The refused command as sent.
    """

    def __init__(
        self,
        code: int,
        reason: str,
        detail: str,
        frame: bytes,
        *,
        last_state: object | None = None,
    ):
        self.code = int(code)
        self.reason = reason
        self.detail = detail
        self.frame = bytes(frame)
        more = f" ({detail})" if detail else ""
        super().__init__(
            f"board error {self.code}: {reason}{more} for {self.frame!r}",
            last_state=last_state,
        )


class BoardResetError(ServoError):
    """The board printed its boot banner mid-session: it restarted and stopped its pulses.

    Usually a brown-out: the servos drew the board's supply down. Power them separately.
    """


# (end of servo I/O errors)


class InvalidJointsError(MearmError):
    """A joint vector cannot be used as a start: wrong length, not finite, or uncoupled.

    Attributes:
        joints: The values given (as floats where possible).
        reason: What is wrong and what is allowed.
    """

    def __init__(self, joints: Sequence[float], reason: str):
        self.joints = tuple(joints)
        self.reason = reason
        super().__init__(f"joints {list(self.joints)!r}: {reason}")


class QPSolverError(MearmError):
    """The QP backend asked for the mink cross-check is not installed.

    Attributes:
        name: The backend asked for.
        available: The installed qpsolvers backends.
    """

    def __init__(self, name: str, available: Sequence[str]):
        self.name = name
        self.available = list(available)
        super().__init__(
            f"QP solver {name!r} is not installed; available: {self.available} "
            "(set controller.qp_solver)"
        )


class InputFileError(MearmError):
    """An input file cannot be read safely: missing, not a regular file, too large, not text.

    Attributes:
        path: The file.
        reason: What is wrong with it and what to do.
    """

    def __init__(self, path: object, reason: str):
        self.path = str(path)
        self.reason = reason
        super().__init__(f"{self.path}: {reason}")


__all__ = [
    "AnalysisError",
    "BannerTimeoutError",
    "BoardError",
    "BoardResetError",
    "BrowserNotFoundError",
    "CalibrationError",
    "CameraError",
    "ChecksumError",
    "CollisionError",
    "ConfigError",
    "GarbledReplyError",
    "HandshakeError",
    "ImageError",
    "InputFileError",
    "InvalidCommandError",
    "InvalidJointsError",
    "InvalidTargetError",
    "JointLimitError",
    "LinkDroppedError",
    "LinkError",
    "MearmError",
    "ModelError",
    "NoAckError",
    "PulseRangeError",
    "QPSolverError",
    "RunLogError",
    "RunLogFormatError",
    "RepeatedTrialError",
    "ServoError",
    "ServoFaultedError",
    "ServoNotConnectedError",
    "TargetError",
    "TargetOutsideBoxError",
    "UnreachableTargetError",
    "JointLimitTargetError",
    "SingularTargetError",
    "ViewError",
    "ViewInputError",
    "ViewPortError",
    "WorldError",
]


# --------------------------------------------------------------------------- serial safety


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


class MoveNotConfirmedError(ServoError):
    """The board answered, but did not confirm the move: it did not reach the pulses sent.

    Attributes:
        port: The serial port or URL.
        expected_us: Channel → the pulse commanded [µs].
        reported_us: Channel → the pulse the board reported [µs]; empty if it was
            still moving when the time ran out.
        reason: What did not match.
    """

    def __init__(
        self,
        port: str,
        reason: str,
        expected_us: dict[int, int],
        reported_us: dict[int, int],
        *,
        last_state: object | None = None,
    ):
        self.port = port
        self.reason = reason
        self.expected_us = dict(expected_us)
        self.reported_us = dict(reported_us)
        super().__init__(f"{port}: move not confirmed: {reason}", last_state=last_state)


class UnsolicitedBytesError(ServoError):
    """The board sent bytes no query asked for: a noisy link or a board talking out of turn.

    Attributes:
        port: The serial port or URL.
        received: The bytes (at most the first 64).
    """

    def __init__(self, port: str, received: bytes, *, last_state: object | None = None):
        self.port = port
        self.received = bytes(received[:64])
        super().__init__(
            f"{port}: the board sent {self.received!r} unasked; an SSC-32 speaks only when "
            "asked, so the link is noisy or another program shares the port",
            last_state=last_state,
        )


class SimCollisionError(ServoError):
    """The simulated arm's body ran into the table, a bin or an object.

    The kinematic simulator checks every move against the same collision model the
    planner does (:mod:`mearm.kinematics.collision`), so a route the planner let through
    a wall is a fault there, as it would be in physics.
    """


class ServoStallError(ServoError):
    """A joint servo did not reach its command: it stopped short or ran out of time.

    Attributes:
        joint: The joint's name.
        commanded: Where it was told to go [deg or cm].
        measured: Where its potentiometer says it is [deg or cm].
        reason: ``"stalled"`` (at rest short of the command) or ``"timeout"``.
    """

    def __init__(
        self,
        joint: str,
        commanded: float,
        measured: float,
        reason: str,
        detail: str,
        *,
        last_state: object | None = None,
    ):
        self.joint = joint
        self.commanded = commanded
        self.measured = measured
        self.reason = reason
        super().__init__(
            f"joint {joint} {detail}: commanded {commanded:.2f}, measured {measured:.2f}",
            last_state=last_state,
        )


__all__ += ["MoveNotConfirmedError", "SerialPortError", "ServoStallError", "UnsolicitedBytesError"]
__all__ += ["SimCollisionError"]


class ServoCalibrationError(CalibrationError):
    """A servo calibration cannot be fitted, read, written or applied (names what and why)."""


__all__ += ["ServoCalibrationError"]
