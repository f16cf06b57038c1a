r"""A conveyor belt: where it lies, how fast it runs and what it brings.

The belt is a straight strip on the table, base frame: it starts at ``start_cm`` (the
middle of its upstream end) and runs ``length_cm`` along ``heading_deg``, ``width_cm``
wide, its surface ``surface_cm`` above the table. Objects arrive on its upstream end at
seeded times (:class:`BeltArrivals`), each of a class drawn from ``task.classes``, and
ride along at ``speed_cm_s`` until something picks them up or they fall off its
downstream end. The bins stay where their classes put them (``task.classes[*].bin_cm``).

A belt the arm cannot follow is refused at load (:func:`follow_limit_cm_s`), as are
arrivals that would land an object partly off it (:func:`overhang_cm`): both need more
of the config than the belt's section, so the whole config checks them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from pydantic import Field, model_validator

from mearm.config.base import MAX_LENGTH_CM, Angle, Length, PositiveLength, Seed, Strict
from mearm.config.classes import ColorClass

#: Largest belt speed any config may give [cm/s] (1 m/s); the arm's own bound
#: (:func:`follow_limit_cm_s`) is usually far lower.
MAX_BELT_SPEED_CM_S = 100.0
#: Most objects a belt brings in one run.
MAX_ARRIVALS = 500
#: Largest gap between two arrivals [s].
MAX_GAP_S = 600.0
#: The share of the TCP's top sweep speed a belt may run at: the arm must also come down,
#: close and lift while it keeps up with the object [-].
FOLLOW_SHARE = 0.5


class BeltArrivals(Strict):
    """When objects arrive on the belt's upstream end, and where across it.

    The gaps between arrivals are drawn uniformly in ``[min_gap_s, max_gap_s]``, the
    class of each uniformly from ``task.classes``, its offset across the belt uniformly
    within ``±lateral_cm`` and its yaw uniformly in [0°, 90°), all from ``seed``: the same
    seed brings the same objects at the same times.
    """

    count: int = Field(default=20, ge=0, le=MAX_ARRIVALS)
    """How many objects the belt brings."""
    first_s: float = Field(default=1.0, ge=0, le=MAX_GAP_S, allow_inf_nan=False)
    """When the first one arrives, after the run starts [s]."""
    min_gap_s: float = Field(default=6.0, gt=0, le=MAX_GAP_S, allow_inf_nan=False)
    """Shortest time between two arrivals [s]."""
    max_gap_s: float = Field(default=9.0, gt=0, le=MAX_GAP_S, allow_inf_nan=False)
    """Longest time between two arrivals [s] (at least ``min_gap_s``)."""
    lateral_cm: float = Field(default=0.0, ge=0, le=MAX_LENGTH_CM, allow_inf_nan=False)
    """Largest offset of an object's centre from the belt's middle line [cm]: at most half
    the belt's ``width_cm`` less the footprint radius of the largest object of
    ``task.classes`` (the smallest circle around it: it lands at any yaw), so that every
    object lands wholly on the belt."""
    seed: Seed = 0
    """Seed of the draw."""

    @model_validator(mode="after")
    def _gaps_ordered(self) -> BeltArrivals:
        if self.max_gap_s < self.min_gap_s:
            raise ValueError(
                f"@max_gap_s: {self.max_gap_s:g} s is below min_gap_s ({self.min_gap_s:g} s)"
            )
        return self


class TrackingConfig(Strict):
    """How the objects on the belt are followed from frame to frame.

    Each object is a track: a Kalman filter of its position and velocity on the table
    under a constant-velocity model (:mod:`mearm.vision.tracking`).
    """

    coast_s: float = Field(default=10.0, gt=0, le=MAX_GAP_S, allow_inf_nan=False)
    """How long a track lives on its prediction alone, unseen [s]: the arm over it, or the
    sorter busy with a pick (the camera is read between moves), which takes 2 to 3 s."""
    gate_cm: float = Field(default=2.0, gt=0, le=MAX_LENGTH_CM, allow_inf_nan=False)
    """A detection farther than this from a track's predicted position is not its object
    [cm]."""
    accel_std_cm_s2: float = Field(default=1.0, gt=0, le=1000, allow_inf_nan=False)
    """How much an object's velocity may change unmodelled: the process noise's
    acceleration, standard deviation [cm/s²]."""
    measurement_std_cm: float = Field(default=0.1, gt=0, le=MAX_LENGTH_CM, allow_inf_nan=False)
    """How far a detected centre may lie from the object's, standard deviation [cm]."""
    min_area_share: float = Field(default=0.9, gt=0, le=1, allow_inf_nan=False)
    """A region smaller than this share of a whole object's footprint is an object partly
    hidden (the arm over it, the frame's edge): its centre is off, so the track coasts
    instead of taking it [-]."""


class BeltConfig(Strict):
    """A conveyor belt on the table: a straight strip that carries what lies on it.

    It starts at ``start_cm`` and runs ``length_cm`` along ``heading_deg``; objects arrive
    on its upstream end (``arrivals``) and ride along at ``speed_cm_s`` until the arm
    picks them up or they drop off its downstream end onto the table. The bins stay where
    ``task.classes`` puts them; a belt over the arm's base is refused at load, and the
    twin refuses one over a bin.
    Conveyor: [Sorting](sorting.md#a-conveyor-belt).
    """

    start_cm: tuple[Length, Length]
    """The middle of the belt's upstream end on the table, base frame (x, y) [cm]."""
    heading_deg: Angle = 0.0
    """Which way the belt runs, from the base frame's x axis towards its y axis [deg]."""
    length_cm: PositiveLength
    """How long the belt is, along ``heading_deg`` [cm]."""
    width_cm: PositiveLength
    """How wide it is [cm]."""
    surface_cm: float = Field(default=0.2, gt=0, le=10, allow_inf_nan=False)
    """Its surface's height above the table [cm]: what it carries lies this much higher."""
    speed_cm_s: float = Field(default=2.0, ge=0, le=MAX_BELT_SPEED_CM_S, allow_inf_nan=False)
    """How fast its surface moves [cm/s]. At most half the speed at which the arm's first
    joint, at its servo's top speed, sweeps the TCP across the belt's nearest point: the
    arm must also come down, close and lift while it keeps up (:func:`follow_limit_cm_s`)."""
    arrivals: BeltArrivals = BeltArrivals()
    """What it brings, and when."""
    tracking: TrackingConfig = TrackingConfig()
    """How the camera's detections become tracks of the objects it carries."""

    def direction(self) -> tuple[float, float]:
        """The unit vector it runs along, base frame (x, y) [-]."""
        a = math.radians(self.heading_deg)
        return (math.cos(a), math.sin(a))

    def nearest_cm(self) -> float:
        """The distance from the base axis (x = y = 0) to the belt's middle line [cm]."""
        ux, uy = self.direction()
        x0, y0 = self.start_cm
        s = min(max(-(x0 * ux + y0 * uy), 0.0), self.length_cm)
        return math.hypot(x0 + s * ux, y0 + s * uy)


def arrival_draws(
    belt: BeltConfig | None, classes: Sequence[ColorClass]
) -> list[tuple[str, float, float, float]]:
    """The belt's arrivals as drawn: (class name, time [s], offset across [cm], yaw [deg]).

    One draw from ``belt.arrivals.seed`` (:class:`BeltArrivals`), each class from
    ``classes``; none without a belt. Where they land is the simulators'
    (:func:`mearm.sim.belt.belt_arrivals`).
    """
    if belt is None:
        return []
    a = belt.arrivals
    rng = np.random.default_rng(a.seed)
    out = []
    t = a.first_s
    for _ in range(a.count):
        c = classes[int(rng.integers(len(classes)))]
        across = float(rng.uniform(-a.lateral_cm, a.lateral_cm))
        yaw = round(float(rng.uniform(0.0, 90.0)), 1)
        out.append((c.name, t, across, yaw))
        t += float(rng.uniform(a.min_gap_s, a.max_gap_s))
    return out


def belt_classes(belt: BeltConfig | None, classes: Sequence[ColorClass]) -> list[str]:
    """The classes of the objects the belt brings, in arrival order."""
    return [name for name, *_ in arrival_draws(belt, classes)]


def overhang_cm(belt: BeltConfig, classes: Sequence[ColorClass]) -> tuple[float, ColorClass]:
    """How far the farthest-out arrival's footprint may reach past the belt's edge [cm].

    An object lands with its centre up to ``arrivals.lateral_cm`` off the middle line and
    at any yaw, so the smallest circle around its footprint
    (:attr:`~mearm.config.classes.ColorClass.footprint_radius_cm`) may reach that much
    farther; ≤ 0 when every object of every class lands wholly on the belt.

    Returns:
        The overhang [cm] and the class of the largest footprint (the first if several).
    """
    largest = max(classes, key=lambda c: c.footprint_radius_cm)
    return belt.arrivals.lateral_cm + largest.footprint_radius_cm - belt.width_cm / 2, largest


def follow_limit_cm_s(sweep_deg_s: float, belt: BeltConfig) -> float:
    r"""The fastest belt the arm can follow [cm/s].

    The arm's first joint turns about the vertical; at its top speed
    :math:`\omega` it sweeps the TCP at :math:`\omega r` along a belt whose middle line
    passes :math:`r` from the base axis. Following an object means also coming down,
    closing and lifting on it, so the belt may run at :data:`FOLLOW_SHARE` of that:

    .. math:: v_{max} = s\,\omega\,r

    Args:
        sweep_deg_s: The first joint's top speed [deg/s].
        belt: The belt.
    """
    return FOLLOW_SHARE * math.radians(sweep_deg_s) * belt.nearest_cm()
