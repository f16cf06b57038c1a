"""The built-in defaults: the paper's arm, its three colour classes and its demo layout.

The arm is the reference arm ``mearm_paper`` (its file, ``configs/arms/mearm_paper.yaml``,
is the one place its joints are written); the classes and the layout are here, the only
place in the package that names the paper's colours. ``configs/sim.yaml`` writes the
defaults out with their sources, and a test keeps the two equal.
"""

from __future__ import annotations

import functools

from mearm.config.arm import ArmDescription
from mearm.config.classes import ColorClass, HueBand
from mearm.config.compose import reference_arm

#: The built-in arm: the reference arm of this name (configs/arms/mearm_paper.yaml).
DEFAULT_ARM = "mearm_paper"


@functools.cache
def paper_arm() -> ArmDescription:
    """The paper's enlarged MeArm: base, shoulder, elbow and the parallelogram wrist.

    Read from its file, ``configs/arms/mearm_paper.yaml`` (:data:`DEFAULT_ARM`), the one
    description every config that names it shares; read and checked once per process
    (the model is frozen: every default config shares it).
    """
    return ArmDescription.model_validate(reference_arm(DEFAULT_ARM))


def default_classes() -> list[ColorClass]:
    """Red, green and blue objects (2 cm across, 1 cm tall) with hue bands for real ones."""
    return [
        ColorClass(
            name="red",
            hue_bands_deg=[HueBand(lo_deg=330.0, hi_deg=15.0)],
            draw_rgb=(200, 30, 35),
            bin_cm=(-20.0, 35.0, 20.0),
            grip_height_cm=1.5,
        ),
        ColorClass(
            name="green",
            hue_bands_deg=[HueBand(lo_deg=75.0, hi_deg=165.0)],
            draw_rgb=(30, 160, 60),
            bin_cm=(-20.0, 45.0, 20.0),
            grip_height_cm=1.5,
        ),
        ColorClass(
            name="blue",
            hue_bands_deg=[HueBand(lo_deg=190.0, hi_deg=255.0)],
            draw_rgb=(35, 60, 200),
            bin_cm=(-20.0, 55.0, 20.0),
            grip_height_cm=1.5,
        ),
    ]


#: The paper's hue bands as printed, per class name (they cannot be right for real
#: objects: green sits near 120°, blue near 240°, H ≥ 280° is magenta).
PAPER_HUE_BANDS_DEG: dict[str, tuple[tuple[float, float], ...]] = {
    "red": ((280.0, 20.0),),
    "green": ((130.0, 160.0),),
    "blue": ((90.0, 120.0),),
}


def paper_classes() -> list[ColorClass]:
    """:func:`default_classes` with the paper's printed hue bands."""
    return [
        c.model_copy(
            update={
                "hue_bands_deg": [
                    HueBand(lo_deg=lo, hi_deg=hi) for lo, hi in PAPER_HUE_BANDS_DEG[c.name]
                ]
            }
        )
        for c in default_classes()
    ]


#: The paper's demo layout (M = red, H = green, B = blue), base frame [cm].
PAPER_LAYOUT: tuple[tuple[str, float, float], ...] = (
    ("red", -10.99, 49.70), ("red", -0.75, 53.72), ("red", -0.40, 42.01),
    ("red", 8.08, 46.71), ("green", -8.31, 53.81), ("green", -4.57, 47.58),
    ("green", 5.15, 53.38), ("green", 11.74, 42.88), ("blue", -10.08, 44.03),
    ("blue", 2.03, 48.57), ("blue", 6.93, 41.11), ("blue", 12.15, 51.86),
)  # fmt: skip

#: The paper's three classes, in its sort order (all red, then green, then blue).
PAPER_CLASS_NAMES: tuple[str, ...] = ("red", "green", "blue")
