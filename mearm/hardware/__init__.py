"""Servo I/O: one bus interface keyed by actuator name and two serial protocols (issue 5).

``open_bus(config, world=...)`` returns the backend of ``servo.backend``:

- ``sim``: :class:`~mearm.sim.SimArm`, a model arm over the shared
  :class:`~mearm.sim.World` (the simulator is the layer above; it is imported only then);
- ``serial``: :class:`ArduinoBus`, our protocol to the Uno running
  ``tools/arduino/mearm_servo`` (``tools/arduino/PROTOCOL.md``);
- ``ssc32``: :class:`SSC32Bus`, the Lynxmotion SSC-32 / SSC-32U protocol.

Commands (:class:`ArmCommand`) name every actuated joint and tool actuator of the arm;
:class:`ServoMap` turns them into pulses per channel from the arm description. Ports are
device paths or ``socket://``, ``rfc2217://`` and ``loop://`` URLs
(:func:`~mearm.config.port.check_port`).
"""

from mearm.hardware.arduino import ArduinoBus, BoardStatus
from mearm.hardware.bus import ArmCommand, ArmState, RateLimiter, ServoBus
from mearm.hardware.factory import open_bus
from mearm.hardware.mapping import ActuatorMap, Quantization, ServoMap
from mearm.hardware.serial_bus import SerialServoBus
from mearm.hardware.ssc32 import SSC32Bus

__all__ = [
    "ActuatorMap",
    "ArduinoBus",
    "ArmCommand",
    "ArmState",
    "BoardStatus",
    "Quantization",
    "RateLimiter",
    "SSC32Bus",
    "SerialServoBus",
    "ServoBus",
    "ServoMap",
    "open_bus",
]
