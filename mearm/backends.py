"""Which backend opens the servo bus and the camera a config names: one registry of kinds.

Every kind of servo bus (``servo.backend``) and of camera (``camera.kind``) is one opener
in this registry, and :func:`open_bus` and :func:`open_camera` are the only places that
choose. The built-in kinds:

========================  ================================================================
``servo.backend``         opened as
========================  ================================================================
``sim``                   :class:`~mearm.sim.SimArm`, the kinematic arm over the shared
                          :class:`~mearm.sim.World`
``virtual_uno``           :class:`~mearm.sim.virtual_uno.VirtualUnoBus`: the firmware in
                          simavr, its pulses moving a simulated arm
``serial``                :class:`~mearm.hardware.ArduinoBus`: the Uno running
                          ``tools/arduino/mearm_servo``
``ssc32``                 :class:`~mearm.hardware.SSC32Bus`: a Lynxmotion SSC-32
========================  ================================================================

Cameras: ``device`` (a USB camera), ``file`` and ``folder`` (recorded frames) from
:mod:`mearm.vision.camera`, and ``sim`` (:class:`~mearm.sim.SimCamera`, the world drawn
afresh at every read). The MuJoCo twin (``simulator: mujoco``) replaces both with its
physics and its rendered camera (:func:`mearm.task.rig.open_rig`).

This module sits above the hardware, vision and simulator packages and below the task:
they never import it, so a lower layer never reaches a higher one to find a backend.
A new kind registers its opener (:func:`register_bus`, :func:`register_camera`) and is
then opened like the built-in ones (docs/development.md shows a small one).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from mearm.config import Config
from mearm.errors import ConfigError

if TYPE_CHECKING:
    from mearm.hardware.bus import ServoBus
    from mearm.sim.world import World
    from mearm.vision.camera import Camera

#: Opens a servo bus (not yet connected): ``(config, world, port) -> bus``.
BusOpener = Callable[[Config, "World | None", "str | None"], "ServoBus"]
#: Opens a camera: ``(config, world) -> camera``.
CameraOpener = Callable[[Config, "World | None"], "Camera"]

_BUSES: dict[str, BusOpener] = {}
_CAMERAS: dict[str, CameraOpener] = {}


def register_bus(name: str, opener: BusOpener) -> None:
    """Make ``servo.backend: name`` open with ``opener`` (a later one replaces it)."""
    _BUSES[name] = opener


def register_camera(name: str, opener: CameraOpener) -> None:
    """Make ``camera.kind: name`` open with ``opener`` (a later one replaces it)."""
    _CAMERAS[name] = opener


def bus_kinds() -> tuple[str, ...]:
    """The registered servo backends, in registration order."""
    return tuple(_BUSES)


def camera_kinds() -> tuple[str, ...]:
    """The registered camera kinds, in registration order."""
    return tuple(_CAMERAS)


def open_bus(config: Config, world: World | None = None, *, port: str | None = None) -> ServoBus:
    """The servo bus of ``config.servo.backend``, not yet connected.

    Args:
        config: The whole configuration.
        world: The simulated table; required by ``sim``, optional for ``virtual_uno``
            (without one it lays out a table of its own from ``task.scene``), ignored by
            the serial backends.
        port: Override ``servo.port`` (the serial backends; the virtual Uno opens its
            own pseudo-terminal).

    Raises:
        ConfigError: a backend no kind registered, or ``sim`` without a world.
        VirtualUnoError: ``virtual_uno`` whose firmware or simulator cannot be built.
    """
    backend = config.servo.backend
    opener = _BUSES.get(backend)
    if opener is None:
        raise ConfigError(None, [f"servo.backend: {backend!r} is not one of {', '.join(_BUSES)}"])
    return opener(config, world, port)


def open_camera(config: Config, world: World | None = None) -> Camera:
    """The camera of ``config.camera.kind``, open.

    Args:
        config: The whole config.
        world: The table the ``sim`` camera shows; ``None`` builds one from
            ``config.task.scene``. Ignored by the other kinds.

    Raises:
        CameraError: the source cannot be opened.
        ConfigError: a kind no opener registered.
    """
    kind = config.camera.kind
    opener = _CAMERAS.get(kind)
    if opener is None:
        raise ConfigError(None, [f"camera.kind: {kind!r} is not one of {', '.join(_CAMERAS)}"])
    return opener(config, world)


# --------------------------------------------------------------------------- built-in kinds
# Each imports its package only when opened: a command that never opens a virtual Uno
# never loads it.


def _sim_bus(config: Config, world: World | None, port: str | None) -> ServoBus:
    if world is None:
        raise ConfigError(
            None, ["servo.backend: 'sim' needs the simulated world: open_bus(config, world=...)"]
        )
    from mearm.sim.servo_bus import SimArm  # noqa: PLC0415

    return SimArm(config, world)


def _virtual_uno_bus(config: Config, world: World | None, port: str | None) -> ServoBus:
    from mearm.sim.virtual_uno import VirtualUnoBus  # noqa: PLC0415

    return VirtualUnoBus(config, world)


def _arduino_bus(config: Config, world: World | None, port: str | None) -> ServoBus:
    from mearm.hardware.arduino import ArduinoBus  # noqa: PLC0415

    return ArduinoBus(config, port=port)


def _ssc32_bus(config: Config, world: World | None, port: str | None) -> ServoBus:
    from mearm.hardware.ssc32 import SSC32Bus  # noqa: PLC0415

    return SSC32Bus(config, port=port)


def _sim_camera(config: Config, world: World | None) -> Camera:
    from mearm.sim.table_camera import SimCamera  # noqa: PLC0415
    from mearm.sim.world import World  # noqa: PLC0415

    return SimCamera(config, World.from_config(config) if world is None else world)


def _device_camera(config: Config, world: World | None) -> Camera:
    from mearm.vision.camera import DeviceCamera  # noqa: PLC0415

    return DeviceCamera(config.camera)


def _file_camera(config: Config, world: World | None) -> Camera:
    from mearm.vision.camera import FileCamera  # noqa: PLC0415

    return FileCamera(config.camera)


def _folder_camera(config: Config, world: World | None) -> Camera:
    from mearm.vision.camera import FolderCamera  # noqa: PLC0415

    return FolderCamera(config.camera)


register_bus("sim", _sim_bus)
register_bus("serial", _arduino_bus)
register_bus("ssc32", _ssc32_bus)
register_bus("virtual_uno", _virtual_uno_bus)
register_camera("device", _device_camera)
register_camera("file", _file_camera)
register_camera("folder", _folder_camera)
register_camera("sim", _sim_camera)

__all__ = [
    "BusOpener",
    "CameraOpener",
    "bus_kinds",
    "camera_kinds",
    "open_bus",
    "open_camera",
    "register_bus",
    "register_camera",
]
