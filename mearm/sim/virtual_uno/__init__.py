r"""The virtual Uno: the project's real firmware on a simulated ATmega328P, behind a pty.

Three parts:

- :func:`build_virtual_uno` builds ``tools/arduino/mearm_servo`` with Debian's avr-gcc
  and the simulator harness ``tools/arduino/sim/mearm_sim.c`` against libsimavr, once,
  into a cache folder (``~/.cache/mearm/virtual_uno/<hash of the sources>``);
- :class:`VirtualUno` runs the firmware in the harness and serves it on a
  pseudo-terminal: a serial port for pyserial, ``find-port``, ``jog``… Opening the port
  restarts the simulated chip, as DTR resets a real Uno. Every servo pulse the emulated
  pins produce is measured in CPU cycles and collected;
- :class:`VirtualUnoBus` (``servo.backend: virtual_uno``) is the serial backend
  (:class:`~mearm.hardware.arduino.ArduinoBus`) driving that board. After each
  acknowledged move it takes the first servo frame the board generated after its
  ``OK``, maps each measured pulse back through the calibration of the rig's own servo
  (the config's before its servo calibration file, whatever map the host sends by:
  :mod:`mearm.sim.virtual_uno.own_servos`),

  .. math:: v = (p_\text{measured} - p_0) / (s\,k),

  solves the actuated joints from the joint servos' values (a servo may turn a
  combination of joints: :meth:`~mearm.hardware.ServoMap.joints_from_pulses`), none past
  its limits, where it stops as the twin's joints do
  (:func:`~mearm.sim.kinematic.joint_stops.joints_at_stops`), moves the simulated arm
  (:class:`~mearm.sim.kinematic.servo_bus.SimArm`) there, and faults the
  move (:class:`~mearm.hardware.errors.MoveNotConfirmedError`) when a pulse is farther than
  ``servo.virtual_uno.pulse_tolerance_us`` from the one sent: a firmware with two
  channels swapped cannot pass for a working one.

Time: the harness keeps simulated time (``servo.virtual_uno.speed`` simulated seconds per
wall-clock second, 0 = as fast as the computer runs it) and reports it; the bus paces
its moves and holds in simulated time, so the firmware sees the same command stream at
any speed, and gives the board's banner and replies their timeouts in simulated time and
wall-clock time both (:class:`~mearm.sim.virtual_uno.board.SimDeadline`), so a machine too
loaded to run the chip at speed does not take it for a silent one. The simulator runs
at the normal scheduling policy whatever the host's thread runs at: at speed 0 it never
sleeps, and realtime it would hold a core.
"""

from mearm.sim.virtual_uno.board import (
    FRAME_GAP_US,
    FRAME_US,
    FRAMES_TO_CONFIRM,
    MAX_LINES,
    MAX_PULSES,
    MAX_SPEED,
    WALL_TIMEOUT_S,
    Frame,
    Pulse,
    VirtualUno,
)
from mearm.sim.virtual_uno.build import (
    BUILD_TIMEOUT_S,
    SKETCH,
    VirtualUnoBuild,
    build_virtual_uno,
    cache_root,
    missing_requirements,
)
from mearm.sim.virtual_uno.errors import VirtualUnoError
from mearm.sim.virtual_uno.uno_bus import VirtualUnoBus

__all__ = [
    "BUILD_TIMEOUT_S",
    "FRAMES_TO_CONFIRM",
    "FRAME_GAP_US",
    "FRAME_US",
    "MAX_LINES",
    "MAX_PULSES",
    "MAX_SPEED",
    "SKETCH",
    "WALL_TIMEOUT_S",
    "Frame",
    "Pulse",
    "VirtualUno",
    "VirtualUnoBuild",
    "VirtualUnoBus",
    "VirtualUnoError",
    "build_virtual_uno",
    "cache_root",
    "missing_requirements",
]
