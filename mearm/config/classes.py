"""Colour classes as data: what to look for, how to draw it, where it goes.

Any number of named classes; each has its hue band(s) (a band with ``lo > hi`` wraps
through 0°, as red does), the colour it is drawn in (simulated camera, 3-D view, plots),
its bin, and the size of its objects. The sort takes the classes in the order listed.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from mearm.config.base import Name, NonNegative, Positive, Strict, Vector3

Rgb = tuple[
    Annotated[int, Field(ge=0, le=255)],
    Annotated[int, Field(ge=0, le=255)],
    Annotated[int, Field(ge=0, le=255)],
]


class HueBand(Strict):
    """A hue interval in degrees [0, 360]; ``lo > hi`` wraps through 0."""

    lo_deg: Annotated[float, Field(ge=0, le=360)]
    hi_deg: Annotated[float, Field(ge=0, le=360)]


class ColorClass(Strict):
    """One class of objects to sort.

    Attributes:
        name: The class's name (used in logs, scenes and the CLI).
        hue_bands_deg: Hue intervals a pixel of this class falls in.
        draw_rgb: The colour its objects are drawn in (sim camera, view, plots), 0–255.
        bin_cm: Where the TCP goes to drop an object of this class, base frame [cm].
        diameter_cm: The objects' diameter [cm].
        height_cm: The objects' height [cm].
        grip_height_cm: Height above the table at which the jaws close on one [cm]
            (default: half the height).
    """

    name: Name
    hue_bands_deg: list[HueBand] = Field(min_length=1)
    draw_rgb: Rgb
    bin_cm: Vector3
    diameter_cm: Positive = 2.0
    height_cm: Positive = 1.0
    grip_height_cm: NonNegative | None = None

    @property
    def grip_z_cm(self) -> float:
        """Height above the table at which the jaws close [cm]."""
        return self.height_cm / 2 if self.grip_height_cm is None else self.grip_height_cm
