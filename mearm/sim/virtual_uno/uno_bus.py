r"""``servo.backend: virtual_uno``: the serial backend driving the virtual Uno.

After each acknowledged move the first servo frame the board generated after its ``OK``
is measured, each pulse mapped back through the calibration of the rig's own servo (the
config's before its servo calibration file: :mod:`mearm.sim.virtual_uno.own_servos`, not
the map the host sends by),

.. math:: v = (p_\text{measured} - p_0) / (s\,k),

the simulated arm moved there, no joint past its stops (the arm description's limits:
:mod:`mearm.sim.kinematic.joint_stops`), and the move faulted when a pulse is off the one
sent.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mearm.config import Config
from mearm.hardware.arduino import ArduinoBus
from mearm.hardware.bus import ArmCommand, RateLimiter
from mearm.hardware.errors import (
    BannerTimeoutError,
    HandshakeError,
    MoveNotConfirmedError,
    NoAckError,
    ServoError,
)
from mearm.hardware.mapping import ActuatorMap
from mearm.hardware.serial_bus import Deadline
from mearm.kinematics import ArmModel
from mearm.sim.kinematic.joint_stops import joints_at_stops
from mearm.sim.kinematic.servo_bus import GripResult, ReleaseResult, SimArm
from mearm.sim.kinematic.world import World
from mearm.sim.virtual_uno.board import Frame, SimDeadline, VirtualUno
from mearm.sim.virtual_uno.build import build_virtual_uno
from mearm.sim.virtual_uno.errors import VirtualUnoError
from mearm.sim.virtual_uno.own_servos import own_arm, own_servo_map


class VirtualUnoBus(ArduinoBus):
    """``servo.backend: virtual_uno``: the serial backend; the board's pulses move the arm.

    The board is a :class:`VirtualUno`. Every move is sent as to a real board (``M``,
    acknowledged by ``OK``); then the first servo frame that started after the ``OK`` left
    the board's UART is measured, the simulated arm over the world is put where those
    pulses put its servos — its own, built once from the config before its servo
    calibration file (:func:`~mearm.sim.virtual_uno.own_servos.own_servo_map`), whatever
    map the host later sends by (a joint sent past its limits stops at them, as the twin's
    does: :func:`~mearm.sim.kinematic.joint_stops.joints_at_stops`), and the move is refused
    (:class:`~mearm.hardware.errors.MoveNotConfirmedError`, which stops the bus with the last
    confirmed pose) when any pulse is missing or farther than
    ``servo.virtual_uno.pulse_tolerance_us`` from the one sent. The reason names the
    actuator, the value its pulse stands for to the host and the commanded one.

    Args:
        config: The whole configuration.
        world: The table (shared with the simulated camera); ``None``: the board's own,
            laid out from ``task.scene``.
        model: Arm model for the TCP (built from ``config.arm`` if omitted).

    Attributes:
        arm: The simulated arm its pins drive.
        own_servos: How the simulated arm's servos turn a pulse into a value.
        board: The running virtual Uno, while connected.
        last_frame: The frame that confirmed (or refused) the last move.

    Raises:
        VirtualUnoError: the firmware or the harness cannot be built (missing tools).
        ServoCalibrationError, ConfigError: as
            :func:`~mearm.sim.virtual_uno.own_servos.own_servo_map`.
    """

    #: What the board is, for what records it (a servo calibration's ``board_id``): not a
    #: real Uno (:func:`mearm.maker.servo_output.board_identity`).
    simulated_as = "the virtual Uno, the firmware in simavr"

    def __init__(self, config: Config, world: World | None = None, model: ArmModel | None = None):
        settings = config.servo.virtual_uno
        self.built = build_virtual_uno(settings.defines)
        super().__init__(config.arm, config.servo)
        self.config = config
        self.arm = SimArm(config, world if world is not None else World.from_config(config), model)
        self.board: VirtualUno | None = None
        self.last_frame: Frame | None = None
        self._last_wait: SimDeadline | None = None  # the last wait for the board's answer
        #: The rig's servos turn by their own build, not by the host's map, which a servo
        #: calibration replaces (read back through it, the pulses would always put the
        #: servos where the calibration believes them).
        self.own_servos = own_servo_map(config)
        #: The simulated arm's joints stop at the arm's own limits, before the servo
        #: calibration file (which may narrow them to what its fits reach), whatever map
        #: the host drives it by later (``calibrate-servos`` widens them to the pulses').
        self._stops = own_arm(config).joint_limits()

    # ----------------------------------------------------------------- the arm

    @property
    def world(self) -> World:
        """The table the arm acts on."""
        return self.arm.world

    @property
    def ee_cm(self) -> np.ndarray:
        """Where the pulses put the TCP, base frame [cm], (3,)."""
        return self.arm.ee_cm

    @property
    def actual_joints(self) -> dict[str, float]:
        """The actuated joints the pulses stand for, name → deg or cm."""
        return dict(self.arm.actual_joints)

    def measured_pulses_us(self) -> dict[int, float]:
        """What the board measured: channel → pulse width [µs].

        The pulses of the frame that confirmed (or refused) the last move; empty before
        the first move, and without the channels the board left silent. Pulses, not
        values: a caller that holds a calibration of its own maps them through it
        (``calibrate-servos`` replaces the bus's map while it measures one:
        :class:`~mearm.hardware.bus.MeasuresPulses`).
        """
        return {} if self.last_frame is None else dict(self.last_frame.widths_us)

    @property
    def last_grip(self) -> GripResult | None:
        """What the last close of the gripper did."""
        return self.arm.last_grip

    @property
    def last_release(self) -> ReleaseResult | None:
        """What the last release of an object did."""
        return self.arm.last_release

    def held_classes(self) -> frozenset[str]:
        """The class of the object the simulated gripper holds, or nothing."""
        return self.arm.held_classes()

    # ----------------------------------------------------------------- backend hooks

    def _connect(self) -> None:
        board = VirtualUno(self.built, speed=self.config.servo.virtual_uno.speed)
        self.board = board
        self.port = board.port
        self._rate = RateLimiter(board.clock_s, board.sleep_s)  # simulated time
        self._last_wait = None
        try:
            super()._connect()
        except HandshakeError as exc:  # the firmware answered: the simulator ran
            self._close()
            raise VirtualUnoError(str(exc)) from None
        except ServoError as exc:
            self._close()  # (done already by the serial backend's connect: a no-op)
            # Read once it is closed: the close's own output is no reason, only an exit of
            # the simulator's own is (stopped_because); the last wait says what else did.
            why = board.stopped_because
            if why is not None:
                raise VirtualUnoError(f"the simulator stopped ({why}): {exc}") from None
            wait = self._last_wait
            silence = wait.why_over() if wait is not None else None
            if silence is not None and isinstance(exc, (BannerTimeoutError, NoAckError)):
                raise VirtualUnoError(f"{silence}: {exc}") from None
            raise
        except BaseException:
            self._close()
            raise

    def _close(self) -> None:
        super()._close()
        if self.board is not None:
            self.board.close()
            self.board = None

    def _deadline(self, timeout_s: float) -> float | Deadline:
        """The end of a wait for the board, by its simulated clock and the wall clock both.

        Its banner, acknowledgements and lines on their way
        (:class:`~mearm.sim.virtual_uno.board.SimDeadline`): a machine too loaded to run
        the chip at speed does not stop the run, a chip that does not answer still does.
        """
        if self.board is None:
            return super()._deadline(timeout_s)
        self._last_wait = self.board.deadline(timeout_s)
        return self._last_wait

    def _hold(self, seconds: float) -> None:
        assert self.board is not None
        self.board.sleep_s(seconds)

    def _send_move(self, command: ArmCommand, pulses_us: dict[int, int]) -> None:
        super()._send_move(command, pulses_us)
        assert self.board is not None
        sent_at = self.board.reply_time_us()
        frame = None if sent_at is None else self.board.frame_after(sent_at, sorted(pulses_us))
        self.last_frame = frame
        widths = dict(frame.widths_us) if frame is not None else {}
        self._follow(widths)
        problems = self._mismatches(command, pulses_us, widths)
        if problems:
            raise MoveNotConfirmedError(
                self.port,
                "; ".join(problems),
                pulses_us,
                {ch: round(w) for ch, w in widths.items()},
                last_state=self.state,
            )

    # ----------------------------------------------------------------- measured pose

    def _follow(self, widths_us: Mapping[int, float]) -> None:
        """Put the simulated arm where the measured pulses put its servos, within its stops.

        The rig's own servos (:attr:`own_servos`), not the host's map.

        Raises:
            SimCollisionError: the arm ran into something; it stays, and the fault
                carries this bus's last confirmed pose.
        """
        smap = self.own_servos
        joints: dict[str, float] = {}
        stops = self._stops
        if all(j.channel in widths_us for j in smap.joints):
            # the joints together: a servo may turn a combination of them
            servo = {j.name: j.value_of(widths_us[j.channel]) for j in smap.joints}
            joints = joints_at_stops(smap, servo, stops)
        else:  # some channel silent: those servos stay; the others turn their own joint
            joints = {
                j.name: min(stops[j.name].max, max(stops[j.name].min, j.value_of(w)))
                for j in smap.joints
                if (w := widths_us.get(j.channel)) is not None and not j.combined
            }
        tool = {
            a.name: a.value_of(widths_us[a.channel]) for a in smap.tool if a.channel in widths_us
        }
        g = smap.gripper
        closed = self.arm.gripper_closed
        if g.channel in widths_us:
            opening = g.value_of(widths_us[g.channel])
            closed = abs(opening - smap.gripper_closed_cm) < abs(opening - smap.gripper_open_cm)
        # the arm's own state is None (it is never moved by move()): a collision's fault
        # names the last pose this bus confirmed, as the serial backend's faults do
        self.arm.actuate(joints, tool, gripper_closed=closed, last_state=self.state)

    def _mismatches(
        self, command: ArmCommand, pulses_us: Mapping[int, int], widths_us: Mapping[int, float]
    ) -> list[str]:
        """One line per actuator whose measured pulse is missing or off the one sent."""
        smap = self.servo_map
        tol = self.config.servo.virtual_uno.pulse_tolerance_us
        servo = smap.servo_values(command.joints)  # a joint servo's value: maybe a combination
        commanded: list[tuple[str, ActuatorMap, float]] = [
            *(("joint", j, servo[j.name]) for j in smap.joints),
            *(("tool actuator", a, command.tool[a.name]) for a in smap.tool),
            ("gripper", smap.gripper, smap.gripper_opening_cm(closed=command.gripper_closed)),
        ]
        problems = []
        for kind, a, value in commanded:
            name = a.servo_text  # a joint servo over a combination says which
            sent = pulses_us[a.channel]
            unit = "°" if a.unit == "deg" else " cm"
            measured = widths_us.get(a.channel)
            if measured is None:
                problems.append(
                    f"{kind} {name}: the board produced no pulse on channel {a.channel}, "
                    f"the command was {value:.1f}{unit} ({sent} µs sent)"
                )
            elif abs(measured - sent) > tol:
                problems.append(
                    f"{kind} {name}: the board's pulses say {a.value_of(measured):.1f}{unit}, "
                    f"the command was {value:.1f}{unit} (channel {a.channel}: {measured:.1f} µs "
                    f"measured, {sent} µs sent, tolerance ±{tol:g} µs)"
                )
        return problems
