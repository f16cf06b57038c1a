"""The servo-bus interface every backend implements, and the command and state records.

Commands name their actuators: each actuated joint of the arm by its name (its value in
degrees, or centimetres for a prismatic joint), each tool actuator by its name [deg], and
whether the gripper is closed. Each backend maps them to pulses with
:class:`~mearm.hardware.mapping.ServoMap`. The base class owns what every backend shares
(lerobot's ``MotorsBus`` pattern): the connection state, checked in one place; refusal of
a command that misses or misnames an actuator or leaves a limit, before anything is
sent; pacing at ``servo.rate_hz``; and the fault latch — after a link or board fault
nothing more is sent, and every later call raises
:class:`~mearm.hardware.errors.ServoFaultedError`.
"""

from __future__ import annotations

import logging
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Mapping
from types import TracebackType
from typing import Any, Protocol, TypeVar, runtime_checkable

import numpy as np

from mearm.config import ArmDescription, ServoConfig
from mearm.hardware.command import ArmCommand, ArmState
from mearm.hardware.errors import ServoError, ServoFaultedError, ServoNotConnectedError
from mearm.hardware.mapping import PlayCompensation, ServoMap

log = logging.getLogger(__name__)
_T = TypeVar("_T")


@runtime_checkable
class MeasuresTcp(Protocol):
    """A bus that knows where its arm's TCP really is (a simulator's): ``ee_cm`` [cm]."""

    @property
    def ee_cm(self) -> np.ndarray: ...  # noqa: D102


@runtime_checkable
class MeasuresJoints(Protocol):
    """A bus that knows where its arm's actuated joints really are (a simulator's).

    ``actual_joints``: name → deg or cm, what the arm realised (not what was commanded).
    A read-only mapping is enough: a caller copies what it keeps.
    """

    @property
    def actual_joints(self) -> Mapping[str, float]: ...  # noqa: D102


@runtime_checkable
class MeasuresTool(Protocol):
    """A bus that knows where its arm's tool actuators really are (the kinematic sim's).

    ``actual_tool``: name → deg, what the arm realised (the twin has no tool actuators).
    """

    @property
    def actual_tool(self) -> Mapping[str, float]: ...  # noqa: D102


@runtime_checkable
class MeasuresPulses(Protocol):
    """A bus whose board measures the pulses its pins output (the virtual Uno's).

    It reports pulses, not values
    (:meth:`~mearm.sim.virtual_uno.VirtualUnoBus.measured_pulses_us`): a caller that
    holds a calibration of its own maps them through it (``calibrate-servos`` replaces
    the bus's map with a widened one while it measures the calibration).
    """

    def measured_pulses_us(self) -> dict[int, float]:
        """Channel → width [µs] of the pulses measured after the last move."""


@runtime_checkable
class MeasuresWorld(MeasuresTcp, MeasuresJoints, Protocol):
    """A bus that measures its arm and the objects (the physical twin's).

    The view draws what it measures, and the run log records it.
    """

    @property
    def object_ids(self) -> tuple[str, ...]: ...  # noqa: D102
    @property
    def opening_cm(self) -> float: ...  # noqa: D102
    def object_pose(self, object_id: str) -> Any: ...  # noqa: D102


@runtime_checkable
class ReportsRelease(Protocol):
    """A bus that knows where a released object went (a simulator's): ``last_release``."""

    @property
    def last_release(self) -> Any: ...  # noqa: D102


@runtime_checkable
class ReportsHold(Protocol):
    """A bus that knows what its jaws hold (a simulator's: the twin, the kinematic sim).

    ``held_classes()``: the classes of the objects the jaws hold, empty when they hold
    nothing. The place reads it over the bin before the jaws open, and a place with
    nothing of its class held fails (a real rig's camera sees only that the object left
    its spot).
    """

    def held_classes(self) -> frozenset[str]: ...  # noqa: D102


@runtime_checkable
class ReportsWhere(Protocol):
    """A simulator that knows its objects: which the jaws hold, and where one is now.

    ``held_ids()``: the objects the jaws hold (read after a grip). ``where(object_id)``:
    where that object is now, as the end of a sentence (``fell into the green bin``), for
    a place that found the jaws empty over its bin. ``in_own_bin(object_id)``: the
    object's class when a bin of that class holds it (it is sorted, wherever it fell
    from), else ``None``: a place whose object slipped out on the way into its own bin
    did its job.
    """

    def held_ids(self) -> frozenset[str]: ...  # noqa: D102
    def where(self, object_id: str) -> str: ...  # noqa: D102
    def in_own_bin(self, object_id: str) -> str | None: ...  # noqa: D102


@runtime_checkable
class SettlesObjects(Protocol):
    """A simulator that can run its physics until objects come to rest (the twin's).

    ``settle_objects(object_ids=ids)``: until those objects rest, for at most a bounded
    time; whether they did. A place reads where its released object went once it rests:
    one read at its bounce on the bin's floor was still too fast to count as held.
    """

    def settle_objects(  # noqa: D102
        self, max_s: float = ..., step_s: float = ..., object_ids: Iterable[str] | None = ...
    ) -> bool: ...


@runtime_checkable
class Sampler(Protocol):
    """Samples a run at a fixed rate (a dataset recorder, :mod:`mearm.dataset`).

    The bus calls :meth:`sample` whenever its clock (:attr:`ServoBus.clock_s`) has passed
    ``due_s``: after each command, hold and wait, and (the twin) within its physics.
    """

    @property
    def due_s(self) -> float: ...  # noqa: D102
    def sample(self, bus: ServoBus) -> None: ...  # noqa: D102


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
    :class:`~mearm.hardware.errors.ServoError` they raise latches the bus as faulted.

    Args:
        arm: The arm whose actuators it drives (their channels, calibrations, limits).
        link: The ``servo`` section: rate, timeouts, retries, port.
        paced: Whether :meth:`move` waits to keep ``link.rate_hz``.
    """

    def __init__(self, arm: ArmDescription, link: ServoConfig, *, paced: bool = True):
        self.link = link
        self.servo_map = ServoMap.from_arm(arm)
        self.paced = paced
        self._rate = RateLimiter()
        self._state: ArmState | None = None
        self._connected = False
        self._fault: ServoError | None = None
        self._sent: ArmCommand | None = None
        self._clock_s = 0.0
        #: Called as the clock passes its ``due_s`` (``None``: nothing samples the run).
        self.sampler: Sampler | None = None

    # ----------------------------------------------------------------- public API

    @property
    def servo_map(self) -> ServoMap:
        """The pulse mapping :meth:`move` sends by; setting it resets the play compensation."""
        return self._servo_map

    @servo_map.setter
    def servo_map(self, smap: ServoMap) -> None:
        self._servo_map = smap
        self._play = PlayCompensation(smap)

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
    def commanded(self) -> ArmCommand | None:
        """The command being sent, else the last one sent (``None`` before the first)."""
        return self._sent

    @property
    def clock_s(self) -> float:
        """The run's time on this bus [s].

        The periods of the commands streamed, the holds and the waits for arrival (a
        simulated bus: its own time).
        """
        return self._clock_s

    def _advance(self, seconds: float) -> None:
        """Move the clock on by ``seconds`` and let the sampler take what is due."""
        self._clock_s += seconds
        self._sample()

    def _sample(self) -> None:
        sampler = self.sampler
        if sampler is not None and self.clock_s >= sampler.due_s - 1e-9:
            sampler.sample(self)

    @property
    def period_s(self) -> float:
        """Time between commands [s]: 1 / ``rate_hz``, or longer if the link needs it."""
        return 1.0 / self.link.rate_hz

    @property
    def step_s(self) -> float:
        """Time one command's motion takes [s]: the speed limits bound its step over this.

        The period, unless the board glides each move over a time of its own and talks
        on the wire besides (the SSC-32's ``T``).
        """
        return self.period_s

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
        self._play.reset()
        self._connect()
        self._connected = True
        log.info("%s connected", type(self).__name__)

    def move(self, command: ArmCommand) -> None:
        """Send one atomic command and wait for its confirmation.

        The command is checked first (:meth:`ServoMap.check`); nothing is sent if it
        misses or misnames an actuator or a value is out of range.

        Raises:
            ServoNotConnectedError: not connected.
            ServoFaultedError: an earlier fault stopped the bus.
            InvalidCommandError: a missing or unknown actuator name (nothing sent).
            JointLimitError: a value outside its limits (nothing sent).
            PulseRangeError: a value whose pulse leaves its channel's range (nothing sent).
            ServoError: the link or board failed; the bus is stopped from then on.
        """
        self._require_ready()
        pulses = self.servo_map.pulses_us(command)
        if self._play.active:
            pulses = self._play.apply(pulses, self.servo_map.limit_pulses_us(command))
        if self.paced:
            self._rate.wait(self.period_s)
        self._sent = command
        self._guarded(self._send_move, command, pulses)
        self._state = ArmState.from_command(command)
        self._advance(self.period_s)

    def hold(self, seconds: float) -> None:
        """Let the last command take effect for ``seconds`` (a gripper closing).

        Sends nothing: a paced bus waits; a simulated one runs its physics (``_hold``).

        Raises:
            ServoNotConnectedError, ServoFaultedError: as :meth:`move`.
        """
        self._require_ready()
        if seconds > 0:
            self._guarded(self._hold, float(seconds))
            self._advance(float(seconds))

    def _hold(self, seconds: float) -> None:
        """Backend hook of :meth:`hold`: by default wait, if the bus is paced."""
        if self.paced:
            time.sleep(seconds)

    def await_arrival(self, timeout_s: float) -> float:
        """Wait until the joint servos have reached the last command, if the bus can tell.

        A bus that measures its joints (the physical twin's potentiometers) runs on with
        the last command until every joint servo has arrived; a bus that cannot tell
        (hobby servos over serial report no position) returns at once: there the
        configured speed limits (``seconds_per_60deg``) are the promise that the servos
        keep up with the stream.

        Returns:
            How long it waited [s].

        Raises:
            ServoNotConnectedError, ServoFaultedError: as :meth:`move`.
            ServoStallError: a joint did not arrive within ``timeout_s`` or came to rest
                short of the command; the bus is stopped from then on.
        """
        self._require_ready()
        waited = self._guarded(self._await_arrival, float(timeout_s))
        self._advance(waited)
        return waited

    def _await_arrival(self, timeout_s: float) -> float:
        """Backend hook of :meth:`await_arrival`: by default the bus cannot tell."""
        return 0.0

    def stop(self) -> None:
        """Hold the last confirmed pose; commands no move. Sends nothing after a fault.

        Each backend either sends a hold command that changes no pulse or sends nothing
        at all; never a fixed pulse, never a move. :attr:`state` is unchanged.
        """
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
        """Hold the last confirmed pose: a hold command that changes no pulse, or nothing."""

    @abstractmethod
    def _close(self) -> None:
        """Release the link."""
