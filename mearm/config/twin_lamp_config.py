"""A lamp over the physical twin's table (``twin.lamp``): real light for the twin's renders.

Unset (``twin.lamp: null``) the twin is lit by one light straight down from above and
MuJoCo's headlight (a light on the camera), and the sorter's frames are drawn without
shadows, the fast path. Set, the lamp replaces both: a spotlight (or a directional
light) standing where a desk lamp would, whose cone falls off towards its edge so that
the table is unevenly lit, casting each object's shadow beside it, with the rest of the
room's light as a uniform ambient and the objects as glossy as their plastic.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from mearm.config.base import Length, Strict

#: A light's level or a material's reflectance, 0 … 1 of full white [-].
Level = Annotated[float, Field(ge=0.0, le=1.0, allow_inf_nan=False)]
#: The lamp must stand at least this high above the table top [cm].
MIN_LAMP_HEIGHT_CM = 1.0


class TwinLampConfig(Strict):
    """A lamp lighting the twin's table (every field is the twin's truth).

    The lamp stands at ``position_cm`` and points at ``target_cm`` on the table. A
    ``spot`` lights a cone of half-angle ``cutoff_deg`` whose light falls off as
    cos(θ)^``exponent`` with the angle θ from its axis (a desk lamp's uneven pool of
    light); a ``directional`` light lights the whole table evenly from that direction (the
    sun through a window). The rest of the room's light is ``ambient``, from no direction.
    """

    kind: Literal["spot", "directional"] = "spot"
    """``spot``: a lamp at ``position_cm`` whose light falls off across its cone;
    ``directional``: parallel light along ``position_cm`` → ``target_cm``, even over the
    table."""
    position_cm: tuple[Length, Length, Length] = (-35.0, 10.0, 80.0)
    """Where the lamp stands, base frame [cm]; z, its height above the table top, at least 1."""
    target_cm: tuple[Length, Length] | None = None
    """Table point (x, y) the lamp points at, base frame [cm]; ``null``: the calibrated
    field's centre (the homography's image of the frame centre)."""
    cutoff_deg: float = Field(default=45.0, ge=5.0, le=90.0, allow_inf_nan=False)
    """A spot's cone: no light beyond this angle from its axis [deg]."""
    exponent: float = Field(default=8.0, ge=0.0, le=128.0, allow_inf_nan=False)
    """A spot's falloff: its light at θ from the axis is cos(θ)^exponent of the axis's
    [-]; 0 lights the cone evenly."""
    diffuse: Level = 0.8
    """The lamp's light on a surface facing it, 0 … 1 of full white [-]."""
    specular: Level = 0.5
    """The lamp's specular light (the highlights it makes on glossy objects) [-]."""
    ambient: Level = 0.25
    """The rest of the room's light, from no direction [-] (what lights a shadow)."""
    shadows: bool = True
    """Cast each object's shadow (a shadow map); ``false`` draws the lamp's light
    without shadows."""
    shadow_map_px: int = Field(default=2048, ge=256, le=8192)
    """Side of the shadow map the lamp's shadows are drawn from [px]: its cost per frame
    (640×480, no MSAA, on the CPU) is about 20 ms at 1024, 30 ms at 2048 and 60 ms at
    4096; a smaller map blurs and steps the shadows' edges."""
    object_specular: Level = 1.0
    """How glossy the objects are: their material's specular reflectance [-] (0: matte)."""
    object_shininess: Level = 0.2
    """How small and sharp their highlights are [-]: 0.2 spreads a glossy plastic's
    highlight over much of a lit face; 1 makes it a small sharp spot, seen only where
    the lamp's mirror image falls."""

    @model_validator(mode="after")
    def _above_the_table(self) -> TwinLampConfig:
        if self.position_cm[2] < MIN_LAMP_HEIGHT_CM:
            raise ValueError(
                f"@position_cm: the lamp stands at z = {self.position_cm[2]:g} cm; it must be "
                f"at least {MIN_LAMP_HEIGHT_CM:g} cm above the table top"
            )
        return self
