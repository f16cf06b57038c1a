"""Errors of servo I/O: a command the arm cannot take, and every fault of a bus.

Every :class:`ServoError` carries ``last_state``: the last pose the board acknowledged
(a :class:`mearm.hardware.ArmState`, or ``None`` before the first move), so a caller
always knows where the arm was last told to be. The simulated buses raise them too: the
rest of the code cannot tell a simulated bus from a serial one.
"""

from __future__ import annotations

import os

from mearm.errors import MearmError
from mearm.kinematics.errors import JointLimitError


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


class FirmwareVersionError(HandshakeError):
    """The board's firmware speaks another protocol version than this host: reflash it.

    Found from its banner, before anything is sent (``sent``: from its ``V`` reply, when
    the banner named the right version): a board of another protocol would read this
    host's lines as garbled at best. Version 1 (lines checked by an XOR) is the
    firmware flashed before the CRC-16; ``mearm flash`` puts the one this mearm ships on the
    board, from :data:`mearm.data.FIRMWARE_DIR` (a wheel has no checkout, but has that).

    Attributes:
        port: The serial port or URL.
        firmware: What the board reports, e.g. ``mearm_servo 1.0``.
        board_major: The protocol major version the board speaks.
        host_major: The one this host speaks.
    """

    def __init__(
        self, port: str, firmware: str, board_major: int, host_major: int, *, sent: bool = False
    ):
        self.port = port
        self.firmware = firmware
        self.board_major = int(board_major)
        self.host_major = int(host_major)
        check = " (lines checked by an XOR, not a CRC-16)" if board_major == 1 else ""
        super().__init__(
            f"{port}: the board runs {firmware}, which speaks protocol {board_major}{check}; "
            f"this host speaks protocol {host_major}: reflash the board with the firmware "
            f"this mearm ships (mearm flash --port {port} builds it from its "
            f"mearm/data/firmware; docs/maker-path.md)"
            + ("" if sent else "; nothing was sent to it")
        )


class LinkError(ServoError):
    """The serial link cannot be opened or was lost.

    Attributes:
        port: The serial port or URL.
    """

    def __init__(self, port: str, message: str, *, last_state: object | None = None):
        self.port = port
        super().__init__(f"{port}: {message}", last_state=last_state)


class PortInUseError(LinkError):
    """Another process holds the serial port: this one sends nothing and does not reset it.

    The serial backends hold an exclusive ``flock`` on their port while it is open
    (:mod:`mearm.hardware.serial_bus`). A second mearm process on the same port would
    reset an Uno (DTR), send its home as one jump and stream its moves interleaved with
    the first's; it is refused instead, before a byte is sent.

    Attributes:
        port: The serial port.
        pid: The holder's process id, or ``None`` when it cannot be found.
        command: The holder's command line, or ``""``.
    """

    def __init__(self, port: str, pid: int | None, command: str = ""):
        self.port = port
        self.pid = pid
        self.command = command
        self.last_state = None
        if pid is None:
            who, stop = "another process", "stop it or wait for it to end"
        elif pid == os.getpid():
            who, stop = "this process (a bus on it is open already)", "close that bus first"
        else:
            who = f"process {pid}" + (f" ({command})" if command else "")
            stop = f"stop it (Ctrl-C in its terminal, or kill {pid}) or wait for it to end"
        MearmError.__init__(
            self,
            f"{port}: the serial port is in use by {who}: one program drives a board at a "
            f"time; nothing was sent to it. {stop[0].upper()}{stop[1:]}, then run this "
            "again (or give this command another board's port)",
        )


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
