"""Which backend opens the rig a config names: one registry of kinds.

Every simulator (``simulator``), kind of servo bus (``servo.backend``) and of camera
(``camera.kind``) is one opener in this registry, and :func:`open_parts`,
:func:`open_bus` and :func:`open_camera` are the only places that choose. The
simulators:

========================  ================================================================
``simulator``             opens
========================  ================================================================
``kinematic``             the servo bus and the camera the config names, over one
                          :class:`~mearm.sim.World` when either is simulated
``mujoco``                the physical twin: :class:`~mearm.sim.twin.twin_bus.TwinArm` and
                          :class:`~mearm.sim.twin.twin_camera.TwinCamera` in one MuJoCo scene
========================  ================================================================

The servo backends:

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
afresh at every read). The MuJoCo twin replaces both with its physics and its rendered
camera.

This module sits above the hardware, vision and simulator packages and below the task:
they never import it, so a lower layer never reaches a higher one to find a backend.
Those layers take the parts of the config they need, never the whole of it; the few
assemblies a command needs from a whole config are here (:func:`open_bus`) and, for the
planner's collision model, in :func:`mearm.sim.table_collision.collision_model`.
A new kind registers its opener (:func:`register_simulator`, :func:`register_bus`,
:func:`register_camera`) and is then opened like the built-in ones (docs/development.md
shows a small one).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import TYPE_CHECKING

from mearm.config import Config, SceneObject
from mearm.errors import ConfigError, wrong_argument

if TYPE_CHECKING:
    import numpy as np

    from mearm.hardware.bus import ServoBus
    from mearm.sim.kinematic.world import World
    from mearm.vision.camera import Camera

#: Opens a servo bus (not yet connected): ``(config, world, port) -> bus``.
BusOpener = Callable[[Config, "World | None", "str | None"], "ServoBus"]
#: Opens a camera: ``(config, world) -> camera``.
CameraOpener = Callable[[Config, "World | None"], "Camera"]

_BUSES: dict[str, BusOpener] = {}
_CAMERAS: dict[str, CameraOpener] = {}


@dataclass
class RigParts:
    """What a simulator opens: the frame source, the servo bus and, simulated, the table.

    Attributes:
        world: The kinematic simulator's table, or ``None`` (a real rig, or the twin,
            whose table is its physics).
        camera: The frame source, open.
        bus: The servo bus, not yet connected.
        in_bins: In simulation, how many objects of each class lie in its bin (what a
            place is confirmed against); ``None`` on a real rig.
        placed: In simulation, how many objects of each class lay on the table at the
            start (a belt's, which arrive later, are not among them); ``None`` on a real
            rig, where only what the camera sees is known.
    """

    world: World | None
    camera: Camera
    bus: ServoBus
    in_bins: Callable[[], Mapping[str, int]] | None = None
    placed: Mapping[str, int] | None = None


#: Opens a rig's parts and closes them on exit: ``(config, scene) -> context``; ``scene``
#: ``None`` is the config's own ``task.scene``.
SimulatorOpener = Callable[[Config, "list[SceneObject] | None"], AbstractContextManager[RigParts]]
_SIMULATORS: dict[str, SimulatorOpener] = {}


def register_simulator(name: str, opener: SimulatorOpener) -> None:
    """Make ``simulator: name`` open with ``opener`` (a later one replaces it)."""
    _SIMULATORS[name] = opener


def register_bus(name: str, opener: BusOpener) -> None:
    """Make ``servo.backend: name`` open with ``opener`` (a later one replaces it)."""
    _BUSES[name] = opener


def register_camera(name: str, opener: CameraOpener) -> None:
    """Make ``camera.kind: name`` open with ``opener`` (a later one replaces it)."""
    _CAMERAS[name] = opener


def simulator_kinds() -> tuple[str, ...]:
    """The registered simulators, in registration order."""
    return tuple(_SIMULATORS)


def bus_kinds() -> tuple[str, ...]:
    """The registered servo backends, in registration order."""
    return tuple(_BUSES)


def camera_kinds() -> tuple[str, ...]:
    """The registered camera kinds, in registration order."""
    return tuple(_CAMERAS)


def require_table(config: object, scene: object, user: str) -> None:
    """Raise :class:`ConfigError` unless ``config`` is a whole config and ``scene`` a table.

    ``scene``: ``None`` or a list (a sequence) of :class:`SceneObject`. Anything else (a
    config's section, a scene file's name, a list of dicts) stopped deep inside, where
    the world reads an object's colour, on an AttributeError that named neither.
    """
    if not isinstance(config, Config):
        needs = "the whole config, a Config (load_config(...))"
        raise ConfigError(None, [wrong_argument(user, needs, config)])
    if scene is None:
        return
    if (
        isinstance(scene, (str, bytes))
        or not isinstance(scene, Sequence)
        or not all(isinstance(o, SceneObject) for o in scene)
    ):
        needs = (
            "a scene: a list of SceneObject (config.task.scene, or load_scene(path) for a "
            "scene file) or None"
        )
        raise ConfigError(None, [wrong_argument(user, needs, scene)])


def open_parts(
    config: Config, scene: list[SceneObject] | None = None
) -> AbstractContextManager[RigParts]:
    """The camera, servo bus and table of ``config.simulator``; closed on leaving.

    Args:
        config: The whole configuration.
        scene: Objects for the simulated table (default: ``config.task.scene``); every
            part is opened with it as ``task.scene``, so the bins' walls each part builds
            or checks against are those of this table.

    Raises:
        ConfigError: a simulator no kind registered; ``config`` not a whole config or
            ``scene`` not a list of :class:`SceneObject` (:func:`require_table`).
    """
    require_table(config, scene, "open_parts")
    opener = _SIMULATORS.get(config.simulator)
    if opener is None:
        kinds = ", ".join(_SIMULATORS)
        raise ConfigError(None, [f"simulator: {config.simulator!r} is not one of {kinds}"])
    return opener(config if scene is None else config.with_scene(scene), scene)


def uses_world(config: Config) -> bool:
    """Whether a table of objects is laid out (:attr:`~mearm.config.Config.simulated_table`)."""
    return config.simulated_table


def table_world(config: Config, scene: list[SceneObject] | None = None) -> World:
    """The simulated table: ``scene`` (default ``task.scene``), the bins and the belt.

    Raises:
        ConfigError: ``config`` is not a whole config or ``scene`` not a list of
            :class:`SceneObject` (:func:`require_table`).
    """
    require_table(config, scene, "table_world")
    from mearm.sim.kinematic.world import World  # noqa: PLC0415

    return World.from_config(config, scene)


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


def grab_frame(config: Config) -> np.ndarray:
    """One frame of the config's camera, the frame a sort's first look sees (BGR).

    Under the kinematic simulator (or on a real rig) the camera of ``camera.kind`` alone:
    no servo bus is opened. Under another simulator (the MuJoCo twin) its own render,
    the arm at home: its camera is part of its scene, and a perspective calibration
    fits only that one (``camera.kind``'s ``sim`` would draw the kinematic table).
    ``mearm detect --camera`` and ``mearm learn-colours --camera`` both read it, so
    colours are taught on what is detected.

    Raises:
        CameraError: the source cannot be opened or read.
        ConfigError: a kind no opener registered.
    """
    if config.simulator == "kinematic":
        with open_camera(config) as camera:
            return camera.read()
    with open_parts(config) as parts:
        return parts.camera.read()


# --------------------------------------------------------------------------- built-in kinds
# Each imports its package only when opened: a command that never opens a virtual Uno
# never loads it.


@contextlib.contextmanager
def _kinematic(config: Config, scene: list[SceneObject] | None) -> Iterator[RigParts]:
    world = table_world(config, scene) if uses_world(config) else None
    with contextlib.ExitStack() as stack:
        camera = stack.enter_context(open_camera(config, world=world))
        bus = open_bus(config, world=world)
        stack.callback(bus.close)
        in_bins = placed = None
        if world is not None:
            names = config.task.class_names
            in_bins = lambda: {c: len(world.in_bin(c)) for c in names}  # noqa: E731
        if world is not None and config.camera.kind == "sim":  # what the camera looks at
            start = [(o.color, o.x_cm, o.y_cm) for o in world.objects if o.arrives_s is None]
            placed = _on_table(config, start)
        yield RigParts(world, camera, bus, in_bins, placed)


def _on_table(config: Config, objects: Iterable[tuple[str, float, float]]) -> dict[str, int]:
    """How many objects ``(class, x, y)`` of each class lie on the table, not in a bin."""
    counts: dict[str, int] = {}
    for color, x, y in objects:
        if not any(c.in_bin(x, y) for c in config.task.classes):
            counts[color] = counts.get(color, 0) + 1
    return counts


@contextlib.contextmanager
def _mujoco(config: Config, scene: list[SceneObject] | None) -> Iterator[RigParts]:
    """The physical twin behind the servo bus and the camera.

    One MuJoCo scene; a place counts when the physics has the object in its bin, too slow
    to leave it.
    """
    from mearm.sim.twin.twin_bus import TwinArm  # noqa: PLC0415
    from mearm.sim.twin.twin_camera import TwinCamera  # noqa: PLC0415

    twin = TwinArm(config)  # (its walls those of ``scene``: :func:`open_parts`)
    with contextlib.ExitStack() as stack:
        camera = stack.enter_context(TwinCamera(config, twin))
        stack.callback(twin.close)

        def in_bins() -> dict[str, int]:
            twin.settle_objects()  # a dropped object rests before it is counted
            return twin.in_bin_counts()

        placed = _on_table(config, [(o.color, o.x, o.y) for o in config.task.scene])
        yield RigParts(None, camera, twin, in_bins, placed)


def _no_port(config: Config, port: str | None) -> None:
    """Refuse a port given to a simulated bus: a maker who typed one meant a board."""
    if port is not None:
        raise ConfigError(
            "--port",
            [
                f"{port}: servo.backend is {config.servo.backend!r}, which opens no serial "
                "port (the arm is simulated): drop --port, or give a config whose "
                "servo.backend is serial or ssc32 (e.g. --config lab)"
            ],
        )


def _sim_bus(config: Config, world: World | None, port: str | None) -> ServoBus:
    _no_port(config, port)
    if world is None:
        raise ConfigError(
            None, ["servo.backend: 'sim' needs the simulated world: open_bus(config, world=...)"]
        )
    from mearm.sim.kinematic.servo_bus import SimArm  # noqa: PLC0415

    return SimArm(config, world)


def _virtual_uno_bus(config: Config, world: World | None, port: str | None) -> ServoBus:
    _no_port(config, port)
    from mearm.sim.virtual_uno import VirtualUnoBus  # noqa: PLC0415

    return VirtualUnoBus(config, world)


def _arduino_bus(config: Config, world: World | None, port: str | None) -> ServoBus:
    from mearm.hardware.arduino import ArduinoBus  # noqa: PLC0415

    return ArduinoBus(config.arm, config.servo, port=port)


def _ssc32_bus(config: Config, world: World | None, port: str | None) -> ServoBus:
    from mearm.hardware.ssc32 import SSC32Bus  # noqa: PLC0415

    return SSC32Bus(config.arm, config.servo, port=port)


def _sim_camera(config: Config, world: World | None) -> Camera:
    from mearm.sim.kinematic.table_camera import SimCamera  # noqa: PLC0415
    from mearm.sim.kinematic.world import World  # noqa: PLC0415

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


register_simulator("kinematic", _kinematic)
register_simulator("mujoco", _mujoco)
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
    "RigParts",
    "SimulatorOpener",
    "bus_kinds",
    "camera_kinds",
    "grab_frame",
    "open_bus",
    "open_camera",
    "open_parts",
    "register_bus",
    "register_camera",
    "register_simulator",
    "require_table",
    "simulator_kinds",
    "table_world",
    "uses_world",
]
