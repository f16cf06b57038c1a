"""The built-in defaults: the paper's arm, its three colour classes and its demo layout.

These are the only places in the package that name the paper's joints or colours; every
other module reads them from the config. ``configs/sim.yaml`` writes them out with their
sources, and a test keeps the two equal.
"""

from __future__ import annotations

from mearm.config.arm import (
    ArmDescription,
    Coupling,
    DHRow,
    Gripper,
    Joint,
    JointServo,
    ServoCalibration,
    TargetBox,
    Tool,
    ToolActuator,
)
from mearm.config.base import Range
from mearm.config.classes import ColorClass, HueBand


def paper_arm() -> ArmDescription:
    """The paper's enlarged MeArm: base, shoulder, elbow and the parallelogram wrist."""

    def servo(channel: int, zero_us: float) -> JointServo:
        # An RDS3135: 0.15 s/60° at 6.8 V (datasheet no-load speed).
        return JointServo(
            channel=channel, zero_us=zero_us, us_per_unit=10.0, seconds_per_60deg=0.15
        )

    return ArmDescription(
        name="mearm_paper",
        joints=[
            Joint(
                name="base",
                dh=DHRow(a_cm=3.0, alpha_deg=90.0, d_cm=17.5),
                limits=Range(min=20, max=160),
                home=120.0,
                servo=servo(0, 600.0),
            ),
            Joint(
                name="shoulder",
                dh=DHRow(a_cm=22.3),
                limits=Range(min=30, max=135),
                home=93.0,
                servo=servo(1, 600.0),
            ),
            Joint(
                name="elbow",
                dh=DHRow(a_cm=31.5),
                limits=Range(min=-160, max=-20),
                home=-132.0,
                servo=servo(2, 2400.0),
            ),
            Joint(
                name="wrist",
                dh=DHRow(a_cm=14.0),
                coupling=Coupling(terms={"shoulder": -1.0, "elbow": -1.0}),
            ),
        ],
        tool=Tool(
            tcp_above_grip_cm=11.26,
            gripper=Gripper(
                servo=ServoCalibration(
                    channel=4,
                    zero_us=2200.0,
                    direction=-1,
                    us_per_unit=300.0,
                    seconds_per_60deg=0.17,  # an MG996R at 4.8 V
                ),
                open_cm=4.0,
                closed_cm=1.0,
                jaw_length_cm=4.0,
            ),
            actuators=[
                ToolActuator(
                    name="gripper_arm",
                    servo=ServoCalibration(  # the same RDS3135, on the tool
                        channel=3, zero_us=1500.0, us_per_unit=10.0, seconds_per_60deg=0.15
                    ),
                    limits=Range(min=-90, max=90),
                    home=60.0,
                    travel=30.0,
                    grip=-60.0,
                )
            ],
        ),
        target_box=TargetBox(),
        closed_form="planar_wrist",
    )


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
