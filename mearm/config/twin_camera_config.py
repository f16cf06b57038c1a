"""Where the physical twin's camera stands and what lens it has (``twin.camera``).

Unset (``twin.camera: null``) the twin's camera looks straight down from 52 cm over the
calibrated field's centre, its yaw and field of view taken from
``calibration.homography`` so that the homography holds on the table plane. Set, it is a
perspective camera the software does not know: placed, tilted and with lens distortion
as a real one would be, for calibrating from its pictures (intrinsics from ChArUco
boards, extrinsics from ArUco markers on the table).
"""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from mearm.config.base import Length, Strict

#: Bound on each distortion coefficient k1 k2 p1 p2 k3 [-]: |k| ≤ 1 covers any webcam or
#: action-camera lens short of a fisheye at its frame's corners.
MAX_DISTORTION = 1.0

Distortion = Annotated[float, Field(ge=-MAX_DISTORTION, le=MAX_DISTORTION, allow_inf_nan=False)]


class TwinCameraConfig(Strict):
    """The twin's camera as a real perspective camera (every field is the twin's truth).

    The optical axis passes through ``target_cm`` on the table (z = 0). With
    ``tilt_deg`` = 0 the camera looks straight down from ``height_cm``; tilted, it stays
    ``height_cm`` up and moves horizontally *against* ``tilt_direction_deg`` by
    ``height_cm · tan(tilt_deg)``, so that it looks along that direction, down at
    ``tilt_deg`` from the vertical, through the target. The default direction, 90°
    (+y), puts the camera towards −y, the robot's side, looking away from the robot.
    """

    height_cm: float = Field(default=52.0, ge=20.0, le=200.0, allow_inf_nan=False)
    """Height of the camera's optical centre above the table top [cm]."""
    target_cm: tuple[Length, Length] | None = None
    """Table point (x, y) the optical axis passes through, base frame [cm]; ``null``: the
    calibrated field's centre (the homography's image of the frame centre)."""
    yaw_deg: float | None = Field(default=None, ge=-180.0, le=180.0, allow_inf_nan=False)
    """Direction on the table of the image's +u (rightward) axis before tilting,
    counter-clockwise from the base frame's +x [deg]; ``null``: the homography's (0° for
    the paper's rig: image right is +x, image up is +y)."""
    tilt_deg: float = Field(default=0.0, ge=0.0, le=45.0, allow_inf_nan=False)
    """Angle of the optical axis from the vertical [deg]; 0: straight down."""
    tilt_direction_deg: float = Field(default=90.0, ge=-180.0, le=180.0, allow_inf_nan=False)
    """Horizontal direction the tilted camera looks along, counter-clockwise from +x
    [deg]; the camera stands on the opposite side of the target. 90: looks towards +y
    from the robot's side."""
    fovy_deg: float | None = Field(default=None, ge=10.0, le=120.0, allow_inf_nan=False)
    """Vertical field of view of the ideal (undistorted) pinhole camera [deg]: the
    frame's full height spans it. ``null``: the angle under which the calibrated field's
    height is seen from ``height_cm`` (today's camera)."""
    distortion: tuple[Distortion, Distortion, Distortion, Distortion, Distortion] = (
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    )
    """Lens distortion k1, k2, p1, p2, k3 in OpenCV's model (normalised image
    coordinates) [-]; k1 < 0 is barrel distortion. All zero: an ideal pinhole."""
