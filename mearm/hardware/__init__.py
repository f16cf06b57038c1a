"""Servo I/O: one bus interface keyed by actuator name and two serial protocols (issue 5).

Two serial backends: :class:`ArduinoBus`, our protocol to the Uno running
``tools/arduino/mearm_servo`` (``tools/arduino/PROTOCOL.md``), and :class:`SSC32Bus`, the
Lynxmotion SSC-32 / SSC-32U protocol. Which backend a config names is chosen in one place
above this package, :func:`mearm.backends.open_bus` (with the simulated ones).

Commands (:class:`ArmCommand`) name every actuated joint and tool actuator of the arm;
:class:`ServoMap` turns them into pulses per channel from the arm description. Ports are
device paths or ``socket://``, ``rfc2217://`` and ``loop://`` URLs
(:func:`~mearm.config.port.check_port`).
"""

from mearm._lazy import lazy_exports
from mearm.hardware.bus import RateLimiter, ServoBus
from mearm.hardware.command import ArmCommand, ArmState
from mearm.hardware.mapping import ActuatorMap, Quantization, ServoMap

# The serial backends (and pyserial) are imported on first access: a simulated run never
# opens a serial port.
_LAZY: dict[str, str] = {
    "ArduinoBus": "mearm.hardware.arduino",
    "BoardStatus": "mearm.hardware.arduino",
    "SerialServoBus": "mearm.hardware.serial_bus",
    "SSC32Bus": "mearm.hardware.ssc32",
}

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
]

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals(), __all__)
