"""The servo-bus interface every backend implements, and the command and state records.

Joint angles are DH degrees at this interface (SPEC §2); each backend maps them to servo
units with :class:`~mearm.hardware.mapping.ServoMap`. The base class owns what every
backend shares (lerobot's ``MotorsBus`` pattern): the connection state, checked in one
place; refusal of out-of-limit angles before anything is sent; pacing at
``servo.rate_hz``; and the fault latch — after a link or board fault nothing more is
sent, and every later call raises :class:`~mearm.exceptions.ServoFaultedError`.
"""

from __future__ import annotations

import logging
import math
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from types import TracebackType
from typing import Any, TypeVar

import numpy.typing as npt

from mearm.config import Config
from mearm.exceptions import (
    InvalidCommandError,
    ServoError,
    ServoFaultedError,
    ServoNotConnectedError,
)
from mearm.hardware.mapping import ServoMap

log = logging.getLogger(__name__)
_T = TypeVar("_T")


def _finite(value: float, what: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidCommandError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise InvalidCommandError(f"{what} must be finite, got {v}")
    return v


def _joints3(joints_deg: npt.ArrayLike) -> tuple[float, float, float]:
    try:
        # An array-like may be a scalar: list() raises TypeError then (caught below). The
        # items can be anything; _finite checks each one.
        values: list[Any] = list(joints_deg)  # type: ignore[arg-type]
    except TypeError:
        raise InvalidCommandError(
            f"joints_deg must be (θ1, θ2, θ3) in DH degrees, got {joints_deg!r}"
        ) from None
    if len(values) != 3:
        raise InvalidCommandError(
            f"joints_deg must be (θ1, θ2, θ3) in DH degrees (θ4 follows from the "
            f"parallelogram), got {len(values)} values: {values!r}"
        )
    a, b, c = (_finite(v, f"θ{i + 1}") for i, v in enumerate(values))
    return (a, b, c)


def _describe(joints: tuple[float, float, float], arm: float, closed: bool) -> str:
    j = ", ".join(f"{v:.2f}" for v in joints)
    return f"joints ({j}) deg, gripper arm {arm:.2f} deg, gripper {'closed' if closed else 'open'}"


@dataclass(frozen=True)
class ArmCommand:
    """One atomic command to the whole arm.

    Attributes:
        joints_deg: (θ1, θ2, θ3) in DH degrees; θ4 is the parallelogram, never commanded.
        gripper_arm_deg: The gripper-arm angle θ5 [deg] (SPEC §2).
        gripper_closed: Close (True) or open (False) the gripper.
    """

    joints_deg: tuple[float, float, float]
    gripper_arm_deg: float
    gripper_closed: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "joints_deg", _joints3(self.joints_deg))
        object.__setattr__(self, "gripper_arm_deg", _finite(self.gripper_arm_deg, "θ5"))
        if not isinstance(self.gripper_closed, bool):
            raise InvalidCommandError(
                f"gripper_closed must be True or False, got {self.gripper_closed!r}"
            )

    @property
    def angles_deg(self) -> tuple[float, float, float, float]:
        """(θ1, θ2, θ3, θ5) [deg]."""
        return (*self.joints_deg, self.gripper_arm_deg)

    def __str__(self) -> str:
        return _describe(self.joints_deg, self.gripper_arm_deg, self.gripper_closed)


@dataclass(frozen=True)
class ArmState:
    """The last command a backend confirmed (acknowledged by the board).

    Attributes:
        joints_deg: (θ1, θ2, θ3) [deg].
        gripper_arm_deg: θ5 [deg].
        gripper_closed: Whether the gripper was told to close.
    """

    joints_deg: tuple[float, float, float]
    gripper_arm_deg: float
    gripper_closed: bool

    @classmethod
    def from_command(cls, command: ArmCommand) -> ArmState:
        """The state a confirmed command leaves."""
        return cls(command.joints_deg, command.gripper_arm_deg, command.gripper_closed)

    def to_command(self) -> ArmCommand:
        """The command that would reproduce this state."""
        return ArmCommand(self.joints_deg, self.gripper_arm_deg, self.gripper_closed)

    def __str__(self) -> str:
        return _describe(self.joints_deg, self.gripper_arm_deg, self.gripper_closed)


class RateLimiter:
    """Spaces calls at least ``period`` apart (loop-rate-limiters' ``RateLimiter`` idea).

    Args:
        clock: Monotonic time source [s].
        sleep: Sleep function [s].
    """

    def __init__(
        self,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ):
        self._clock = clock
        self._sleep = sleep
        self._last: float | None = None

    def wait(self, period_s: float) -> float:
        """Sleep until ``period_s`` after the previous call; returns the time slept [s]."""
        now = self._clock()
        slept = 0.0
        if self._last is not None:
            due = self._last + period_s
            if now < due:
                slept = due - now
                self._sleep(slept)
                now = max(self._clock(), due)
        self._last = now
        return slept

    def reset(self) -> None:
        """Forget the previous call: the next :meth:`wait` returns at once."""
        self._last = None


class ServoBus(ABC):
    """A servo backend: connect, move atomically, read the confirmed state, stop, close.

    Subclasses implement ``_connect``, ``_send_move``, ``_stop`` and ``_close``; every
    :class:`~mearm.exceptions.ServoError` they raise latches the bus as faulted.

    Args:
        config: The whole configuration (``servo`` and ``robot`` sections are used).
        paced: Whether :meth:`move` waits to keep ``servo.rate_hz``.
    """

    def __init__(self, config: Config, *, paced: bool = True):
        self.config = config
        self.servo_map = ServoMap.from_config(config)
        self.paced = paced
        self._rate = RateLimiter()
        self._state: ArmState | None = None
        self._connected = False
        self._fault: ServoError | None = None

    # ----------------------------------------------------------------- public API

    @property
    def is_connected(self) -> bool:
        """Whether :meth:`connect` succeeded and :meth:`close` was not called since."""
        return self._connected

    @property
    def state(self) -> ArmState | None:
        """The last confirmed command, or ``None`` before the first one."""
        return self._state

    @property
    def fault(self) -> ServoError | None:
        """The fault that stopped the bus, if any."""
        return self._fault

    @property
    def period_s(self) -> float:
        """Time between commands [s]: 1 / ``rate_hz``, or longer if the link needs it."""
        return 1.0 / self.config.servo.rate_hz

    def connect(self) -> None:
        """Open the link and handshake; a no-op if already connected.

        Raises:
            ServoError: the backend's connection error (see each backend).
        """
        if self._connected:
            return
        self._fault = None
        self._state = None
        self._rate.reset()
        self._connect()
        self._connected = True
        log.info("%s connected", type(self).__name__)

    def move(self, command: ArmCommand) -> None:
        """Send one atomic command and wait for its confirmation.

        Every angle is checked first; nothing is sent if one is out of its limits.

        Raises:
            ServoNotConnectedError: not connected.
            ServoFaultedError: an earlier fault stopped the bus.
            JointLimitError: an angle outside its joint limits (nothing sent).
            PulseRangeError: an angle whose pulse leaves its channel's range (nothing sent).
            ServoError: the link or board failed; the bus is stopped from then on.
        """
        self._require_ready()
        pulses = self.servo_map.pulses_us(command)
        if self.paced:
            self._rate.wait(self.period_s)
        self._guarded(self._send_move, command, pulses)
        self._state = ArmState.from_command(command)

    def stop(self) -> None:
        """Stop motion and hold where the arm is. Sends nothing after a fault."""
        if not self._connected or self._fault is not None:
            log.warning("stop(): bus not connected or faulted; nothing sent")
            return
        self._guarded(self._stop)

    def close(self) -> None:
        """Close the link. Safe to call twice; sends nothing after a fault."""
        if not self._connected:
            return
        try:
            self._close()
        finally:
            self._connected = False
            log.info("%s closed", type(self).__name__)

    def __enter__(self) -> ServoBus:
        self.connect()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # ----------------------------------------------------------------- for subclasses

    def _require_ready(self) -> None:
        """The one place the connection state is checked."""
        if not self._connected:
            raise ServoNotConnectedError(
                f"{type(self).__name__} is not connected: call connect() first "
                "(or use it as a context manager)",
                last_state=self._state,
            )
        if self._fault is not None:
            raise ServoFaultedError(self._fault)

    def _guarded(self, call: Callable[..., _T], *args: object) -> _T:
        """Run an I/O call; a :class:`ServoError` from it latches the bus as faulted."""
        try:
            return call(*args)
        except ServoError as exc:
            self._fault = exc
            log.error("%s stopped: %s", type(self).__name__, exc)
            raise

    @abstractmethod
    def _connect(self) -> None:
        """Open the link and handshake."""

    @abstractmethod
    def _send_move(self, command: ArmCommand, pulses_us: dict[int, int]) -> None:
        """Send one checked command (``pulses_us``: channel → µs) and await confirmation."""

    @abstractmethod
    def _stop(self) -> None:
        """Stop motion and hold."""

    @abstractmethod
    def _close(self) -> None:
        """Release the link."""
