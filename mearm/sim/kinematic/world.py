"""The simulated table: objects with a colour class and a position, one bin per class, a belt.

One :class:`World` is shared by the simulated camera (which renders what lies on the
table) and the simulated arm (which picks objects up and drops them into bins), so a pick
really removes an object from the next frame. Objects and bins are keyed by class name
(``task.classes``); the world knows no colours.

The world only keeps state; the rules (how close the gripper must be to pick, which bin
catches a released object) live in the simulated arm (``mearm.sim.SimArm``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field

from mearm.config import ColorClass, Config, SceneObject
from mearm.sim.belt import Arrival, Belt, belt_arrivals, radius_cm
from mearm.sim.errors import WorldError

Vector3 = tuple[float, float, float]


@dataclass
class WorldObject:
    """One object on the table, in the gripper or in a bin.

    Attributes:
        id: Its name: class name and index, e.g. ``"red1"`` for the first of class red.
        color: The name of its colour class.
        x_cm: Position, base frame [cm].
        y_cm: Position, base frame [cm].
        held: Whether it is in the gripper.
        bin: The class name of the bin it was dropped into, or ``None``.
        yaw_deg: Its turn about the vertical, base frame [deg] (its shape is its
            class's).
        arrives_s: When the belt brings it [s]; ``None``: it lies on the table from the
            start.
        waiting: Whether it is still to come on the belt.
    """

    id: str
    color: str
    x_cm: float
    y_cm: float
    held: bool = False
    bin: str | None = None
    yaw_deg: float = 0.0
    arrives_s: float | None = None
    waiting: bool = False

    @property
    def on_table(self) -> bool:
        """Whether the object lies on the table or the belt (here, not held, not in a bin)."""
        return not self.held and self.bin is None and not self.waiting


@dataclass
class World:
    """The table's objects and the bins.

    With a belt, the belt's objects (:func:`~mearm.sim.belt.belt_arrivals`) follow the
    scene's, waiting until :meth:`advance` brings the time of their arrival; from then on
    each moves with the belt while it lies on it (:meth:`Belt.carried_cm`).

    Attributes:
        objects: Every object, in scene order, then the belt's in arrival order.
        bins: Per class name, the class whose bin stands on the table (its place and
            size).
        belt: The conveyor belt, or ``None``.
        radii_cm: Per class name, half an object's widest extent [cm] (where one drops
            off the belt's end).
        time_s: The world's time since the run started [s].
    """

    objects: list[WorldObject] = field(default_factory=list)
    bins: dict[str, ColorClass] = field(default_factory=dict)
    belt: Belt | None = None
    radii_cm: dict[str, float] = field(default_factory=dict)
    time_s: float = 0.0

    @property
    def bins_cm(self) -> dict[str, Vector3]:
        """Per class name, where its bin is, base frame (x, y, z) [cm]."""
        return {name: c.bin_cm for name, c in self.bins.items()}

    @classmethod
    def from_scene(cls, scene: list[SceneObject], bins: Iterable[ColorClass]) -> World:
        """Objects named by class and index (``red1``, ``red2``, …) in scene order."""
        counts: dict[str, int] = {}
        objects = []
        for obj in scene:
            counts[obj.color] = counts.get(obj.color, 0) + 1
            oid = f"{obj.color}{counts[obj.color]}"
            objects.append(WorldObject(oid, obj.color, obj.x, obj.y, yaw_deg=obj.yaw_deg))
        return cls(objects=objects, bins={c.name: c for c in bins})

    @classmethod
    def from_config(cls, config: Config, scene: list[SceneObject] | None = None) -> World:
        """The world of ``scene`` (default ``config.task.scene``), bins and belt.

        Each class has its bin (``task.classes``); the belt's objects (``config.belt``)
        wait to arrive.
        """
        world = cls.from_scene(config.task.scene if scene is None else scene, config.task.classes)
        if config.belt is not None:
            world.belt = Belt(config.belt)
            world.radii_cm = {c: radius_cm(config, c) for c in config.task.class_names}
            world.objects += [_waiting(a) for a in belt_arrivals(config)]
        return world

    def advance(self, seconds: float) -> None:
        """Let ``seconds`` pass: objects arrive on the belt and ride it.

        Raises:
            WorldError: ``seconds`` is negative or not finite.
        """
        if not (math.isfinite(seconds) and seconds >= 0):
            raise WorldError(f"cannot advance the world by {seconds!r} s: must be finite, >= 0")
        end = self.time_s + seconds
        belt = self.belt
        if belt is not None:
            for o in self.objects:
                if o.waiting and o.arrives_s is not None and o.arrives_s <= end:
                    o.waiting = False
                    ridden = end - o.arrives_s
                elif o.on_table:
                    ridden = seconds
                else:
                    continue
                if ridden > 0 and belt.carries(o.x_cm, o.y_cm):
                    o.x_cm, o.y_cm = belt.carried_cm(o.x_cm, o.y_cm, ridden, self.radii_cm[o.color])
        self.time_s = end

    def table_objects(self) -> list[WorldObject]:
        """Objects lying on the table, in scene order."""
        return [o for o in self.objects if o.on_table]

    def held_object(self) -> WorldObject | None:
        """The object in the gripper, if any."""
        return next((o for o in self.objects if o.held), None)

    def nearest_on_table(self, x_cm: float, y_cm: float) -> tuple[WorldObject | None, float]:
        """The table object nearest to (x, y) in the plane and its distance [cm]."""
        best, best_d = None, math.inf
        for o in self.table_objects():
            d = math.hypot(o.x_cm - x_cm, o.y_cm - y_cm)
            if d < best_d:
                best, best_d = o, d
        return best, best_d

    def in_bin(self, color: str) -> list[WorldObject]:
        """Objects dropped into a bin (:meth:`release_into_bin`) that lie in ``color``'s.

        Which bin holds one is its class's rule (:meth:`~mearm.config.ColorClass.in_bin`).
        """
        cls = self.bins.get(color)
        if cls is None:
            return []
        return [o for o in self.objects if o.bin is not None and cls.in_bin(o.x_cm, o.y_cm)]

    def nearest_bin(self, x_cm: float, y_cm: float) -> tuple[str | None, float]:
        """The class of the bin nearest to (x, y) in the plane and its distance [cm]."""
        best: str | None = None
        best_d = math.inf
        for color, c in self.bins.items():
            d = math.hypot(c.bin_cm[0] - x_cm, c.bin_cm[1] - y_cm)
            if d < best_d:
                best, best_d = color, d
        return best, best_d

    def grip(self, obj: WorldObject) -> None:
        """Take a table object into the gripper.

        Raises:
            WorldError: the object is not on the table, or something is already held.
        """
        held = self.held_object()
        if held is not None:
            raise WorldError(f"cannot grip {obj.id}: {held.id} is already held")
        if obj not in self.objects or not obj.on_table:
            raise WorldError(f"cannot grip {obj.id}: it is not on the table")
        obj.held = True

    def release_into_bin(self, color: str) -> WorldObject:
        """Drop the held object into the bin of class ``color``; returns it.

        Raises:
            WorldError: nothing is held, or there is no such bin.
        """
        if color not in self.bins:
            raise WorldError(f"no bin {color!r}; bins: {sorted(self.bins)}")
        obj = self._take_held()
        obj.bin = color
        obj.x_cm, obj.y_cm = self.bins[color].bin_cm[:2]
        return obj

    def release_on_table(self, x_cm: float, y_cm: float) -> WorldObject:
        """Put the held object down on the table at (x, y) [cm]; returns it.

        Raises:
            WorldError: nothing is held.
        """
        obj = self._take_held()
        obj.x_cm, obj.y_cm = float(x_cm), float(y_cm)
        return obj

    def _take_held(self) -> WorldObject:
        obj = self.held_object()
        if obj is None:
            raise WorldError("nothing is held")
        obj.held = False
        return obj


def _waiting(arrival: Arrival) -> WorldObject:
    """An object still to come on the belt, where it will land."""
    return WorldObject(
        arrival.id,
        arrival.color,
        arrival.x_cm,
        arrival.y_cm,
        yaw_deg=arrival.yaw_deg,
        arrives_s=arrival.t_s,
        waiting=True,
    )
