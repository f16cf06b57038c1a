"""Choose the servo backend the config names (``servo.backend``)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from mearm.config import Config
from mearm.exceptions import ConfigError
from mearm.hardware.arduino import ArduinoBus
from mearm.hardware.bus import ServoBus
from mearm.hardware.ssc32 import SSC32Bus

if TYPE_CHECKING:
    from mearm.sim.world import World


def open_bus(config: Config, world: World | None = None, *, port: str | None = None) -> ServoBus:
    """The backend of ``config.servo.backend``, not yet connected.

    Args:
        config: The whole configuration.
        world: The simulated table; required by the ``sim`` backend, ignored otherwise.
        port: Override ``servo.port`` (serial backends).

    Returns:
        A :class:`~mearm.sim.SimArm` (``sim``), :class:`ArduinoBus` (``serial``),
        :class:`SSC32Bus` (``ssc32``) or :class:`~mearm.sim.virtual_uno.VirtualUnoBus`
        (``virtual_uno``: the firmware in simavr, its pulses moving a simulated arm over
        ``world``, or over a table of its own laid out from ``task.scene`` when ``world``
        is ``None``; ``port`` is ignored, the bus opens the virtual board's pty); call
        ``connect()`` or use it as a context manager.

    Raises:
        ConfigError: ``sim`` without a world.
        VirtualUnoError: ``virtual_uno`` whose firmware or simulator cannot be built.
    """
    backend = config.servo.backend
    if backend == "sim":
        if world is None:
            raise ConfigError(
                None,
                ["servo.backend: 'sim' needs the simulated world: open_bus(config, world=...)"],
            )
        # The simulator is the layer above hardware: imported only when it is asked for.
        from mearm.sim.servo_bus import SimArm

        return SimArm(config, world)
    if backend == "serial":
        return ArduinoBus(config, port=port)
    if backend == "ssc32":
        return SSC32Bus(config, port=port)
    if backend == "virtual_uno":
        from mearm.sim.virtual_uno import VirtualUnoBus

        return VirtualUnoBus(config, world)
    raise ConfigError(
        None, [f"servo.backend: {backend!r} is not one of sim, serial, ssc32, virtual_uno"]
    )
