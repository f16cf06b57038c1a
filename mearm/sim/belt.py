r"""The conveyor belt both simulators share: what arrives when, and where the belt carries it.

The belt (``config.belt``, :class:`~mearm.config.belt_config.BeltConfig`) is a strip on the
table. An object lying on it moves with its surface,

.. math:: p(t) = p_0 + v\,\hat u\,(t - t_0),

until it passes the downstream end, where it drops onto the table just beyond the end
and stays. The kinematic world (:class:`~mearm.sim.kinematic.world.World`) moves its
objects by this rule; the physical twin builds the belt as a geom whose surface moves
(MuJoCo's ``surfacevel``) and lets the contacts carry them.

Arrivals (:func:`belt_arrivals`) are drawn once from ``belt.arrivals.seed``; their ids
go on from the scene's (``red5`` after a scene with four reds).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mearm.config import Config
from mearm.config.belt_config import BeltConfig, arrival_draws


@dataclass(frozen=True)
class Arrival:
    """One object the belt brings.

    Attributes:
        id: Its name, class name and index (``red5``).
        color: Its class's name.
        t_s: When it lands on the belt's upstream end, from the run's start [s].
        x_cm: Where it lands, base frame [cm].
        y_cm: Where it lands, base frame [cm].
        yaw_deg: Its turn about the vertical [deg].
    """

    id: str
    color: str
    t_s: float
    x_cm: float
    y_cm: float
    yaw_deg: float


@dataclass(frozen=True)
class Belt:
    """The belt's geometry and motion, base frame [cm, cm/s].

    Attributes:
        config: Its config section.
    """

    config: BeltConfig

    @property
    def direction(self) -> np.ndarray:
        """The unit vector it runs along (x, y) [-], (2,)."""
        return np.array(self.config.direction())

    @property
    def velocity_cm_s(self) -> np.ndarray:
        """Its surface's velocity (x, y) [cm/s], (2,)."""
        return self.config.speed_cm_s * self.direction

    @property
    def centre_cm(self) -> np.ndarray:
        """The middle of the strip (x, y) [cm], (2,)."""
        return np.array(self.config.start_cm) + self.config.length_cm / 2 * self.direction

    def along_across_cm(self, x_cm: float, y_cm: float) -> tuple[float, float]:
        """A point's distance along the belt and across it [cm].

        Along: from its upstream end; across: from its middle line, positive to the left
        of the way it runs.
        """
        ux, uy = self.config.direction()
        dx, dy = x_cm - self.config.start_cm[0], y_cm - self.config.start_cm[1]
        return dx * ux + dy * uy, -dx * uy + dy * ux

    def point_cm(self, along_cm: float, across_cm: float) -> tuple[float, float]:
        """The point ``along_cm`` down the belt and ``across_cm`` left of its middle [cm]."""
        ux, uy = self.config.direction()
        x0, y0 = self.config.start_cm
        return x0 + along_cm * ux - across_cm * uy, y0 + along_cm * uy + across_cm * ux

    def carries(self, x_cm: float, y_cm: float) -> bool:
        """Whether an object standing at (x, y) lies on the belt."""
        along, across = self.along_across_cm(x_cm, y_cm)
        return 0.0 <= along <= self.config.length_cm and abs(across) <= self.config.width_cm / 2

    def carried_cm(
        self, x_cm: float, y_cm: float, seconds: float, radius_cm: float
    ) -> tuple[float, float]:
        """Where an object at (x, y) on the belt is ``seconds`` later [cm].

        Past the downstream end it drops onto the table with its edge at the end
        (``radius_cm`` beyond it) and stays there.
        """
        along, across = self.along_across_cm(x_cm, y_cm)
        end = self.config.length_cm
        along += self.config.speed_cm_s * seconds
        if along > end:
            along = end + radius_cm
        return self.point_cm(along, across)


def belt_arrivals(config: Config) -> list[Arrival]:
    """The objects ``config.belt`` brings, in arrival order (none without a belt).

    The gaps, classes, offsets across the belt and yaws are drawn from
    ``belt.arrivals.seed`` (:class:`~mearm.config.belt_config.BeltArrivals`); each object lands
    its own radius past the upstream end.
    """
    if config.belt is None:
        return []
    counts: dict[str, int] = {}
    for obj in config.task.scene:
        counts[obj.color] = counts.get(obj.color, 0) + 1
    geometry = Belt(config.belt)
    out = []
    for name, t, across, yaw in arrival_draws(config.belt, config.task.classes):
        counts[name] = counts.get(name, 0) + 1
        x, y = geometry.point_cm(radius_cm(config, name), across)
        out.append(Arrival(f"{name}{counts[name]}", name, t, x, y, yaw))
    return out


def radius_cm(config: Config, color: str) -> float:
    """Half the widest extent of an object of class ``color`` [cm]."""
    c = config.task.class_named(color)
    return c.object_shape.widest_cm(c.diameter_cm) / 2


__all__ = ["Arrival", "Belt", "belt_arrivals", "radius_cm"]
