"""Faults the physical twin injects into a run (``twin.faults``): what breaks, and when.

Each fault is data: a ``kind``, the simulated time it strikes at (``at_s``, seconds of the
twin's physics since the run began) and what it needs, e.g.::

    twin:
      faults:
        - {kind: limp_servo, at_s: 1.0, joint: shoulder}   # its servo loses all torque
        - {kind: knock_object, at_s: 2.0, object: green1}  # off the table, out of view
        - {kind: camera_black, at_s: 2.0}                  # every frame black from then on
        - {kind: camera_frozen, at_s: 2.0}                 # the last frame, over and over
        - {kind: camera_bump, at_s: 2.0, shift_cm: [1, 0, 0]}  # the camera moved 1 cm

None of them tells the software: the sort must find each out from what it measures (a
joint short of its command, an object gone, a frame that is black or stale, objects that
moved though the arm never came near them) and stop with the reason
(:mod:`mearm.sim.twin.twin_faults` applies them).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from mearm.config.base import Name, Strict

#: Latest time a fault may strike [s of simulated time]: an hour of sorting.
MAX_FAULT_TIME_S = 3600.0
#: Largest camera bump along each axis [cm].
MAX_BUMP_CM = 10.0

FaultTime = Annotated[float, Field(ge=0, le=MAX_FAULT_TIME_S, allow_inf_nan=False)]
BumpCm = Annotated[float, Field(ge=-MAX_BUMP_CM, le=MAX_BUMP_CM, allow_inf_nan=False)]


class _Fault(Strict):
    at_s: FaultTime
    """When it strikes: seconds of the twin's simulated time since the run began [s]."""


class LimpServo(_Fault):
    """A joint's servo goes limp (its power or signal lost): it gives no torque any more."""

    kind: Literal["limp_servo"]
    joint: Name
    """The actuated joint whose servo fails."""


class KnockObject(_Fault):
    """An object is knocked off the table: it ends up at rest beyond the camera's view."""

    kind: Literal["knock_object"]
    object: Name
    """The object's id in the twin: its class and its number in the scene's order within
    that class (``red1``, ``green2``, …)."""


class CameraBlack(_Fault):
    """The camera delivers black frames (a covered lens, a dead sensor or lamp)."""

    kind: Literal["camera_black"]


class CameraFrozen(_Fault):
    """The camera's stream freezes.

    Every read returns the last frame taken before ``at_s``, with that frame's time.
    """

    kind: Literal["camera_frozen"]


class CameraBump(_Fault):
    """The camera is knocked.

    It moves by ``shift_cm`` and stays there: the calibration no longer holds.
    """

    kind: Literal["camera_bump"]
    shift_cm: tuple[BumpCm, BumpCm, BumpCm]
    """How far it moves in the robot's base frame (x, y, z) [cm]."""


TwinFault = Annotated[
    LimpServo | KnockObject | CameraBlack | CameraFrozen | CameraBump,
    Field(discriminator="kind"),
]
