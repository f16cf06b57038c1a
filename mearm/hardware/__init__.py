"""Servo I/O: one bus interface, a simulated arm and two serial protocols (issue 5).

``open_bus(config, world=...)`` returns the backend of ``servo.backend``:

- ``sim``: :class:`SimArm`, a model arm over the shared :class:`~mearm.world.World`;
- ``serial``: :class:`ArduinoBus`, our protocol to the Uno running
  ``tools/arduino/mearm_servo`` (``tools/arduino/PROTOCOL.md``);
- ``ssc32``: :class:`SSC32Bus`, the Lynxmotion SSC-32 / SSC-32U protocol.
"""

from mearm.hardware.arduino import ArduinoBus, BoardStatus
from mearm.hardware.bus import ArmCommand, ArmState, RateLimiter, ServoBus
from mearm.hardware.factory import open_bus
from mearm.hardware.mapping import JointMap, ServoMap
from mearm.hardware.serial_bus import SerialServoBus
from mearm.hardware.sim import GripResult, ReleaseResult, SimArm, quantize_deg
from mearm.hardware.ssc32 import SSC32Bus

__all__ = [
    "ArduinoBus",
    "ArmCommand",
    "ArmState",
    "BoardStatus",
    "GripResult",
    "JointMap",
    "RateLimiter",
    "ReleaseResult",
    "SSC32Bus",
    "SerialServoBus",
    "ServoBus",
    "ServoMap",
    "SimArm",
    "open_bus",
    "quantize_deg",
]
