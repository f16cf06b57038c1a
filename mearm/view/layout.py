"""Where the view puts the table, how big it makes the bins, and where it looks from.

Nothing here knows an arm or a class: the layout follows from the config. The table
covers everything on it (the base, the bins, the scene's objects, the camera's field)
with a margin; each bin is a square as large as it can be without touching its
neighbours (at most :data:`BIN_SIDE_MAX_CM`, and four object diameters); the camera
frames the arm at home and everything on the table.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from mearm.config import Config
from mearm.kinematics import CM_PER_M, ArmModel
from mearm.view.viewpoint import ViewCamera
from mearm.vision.calibration import camera_geometry

#: Largest bin footprint side [cm] (bins 10 cm apart, the paper's Table 2, fit 8 cm).
BIN_SIDE_MAX_CM = 8.0
#: A bin's side is at most this many of the largest object's diameter [-].
BIN_SIDE_PER_DIAMETER = 4.0
#: A bin's wall height per side [-] (8 cm bins: 4.8 cm walls).
BIN_HEIGHT_PER_SIDE = 0.6
#: Share of the distance to the nearest other bin a bin's side may take [-].
BIN_SIDE_SHARE = 0.9
#: Table margin around everything on it: at least this [cm], or this share of its size.
TABLE_MARGIN_CM = 12.0
TABLE_MARGIN_SHARE = 0.15


@dataclass(frozen=True)
class SceneLayout:
    """The static scene's geometry.

    Attributes:
        table_x_cm: The table top's extent along x [cm], (min, max).
        table_y_cm: Its extent along y [cm], (min, max).
        bin_side_cm: Each bin's square footprint side [cm].
        bin_height_cm: Each bin's wall height [cm].
        camera: The viewpoint that frames the arm at home and the table's contents.
    """

    table_x_cm: tuple[float, float]
    table_y_cm: tuple[float, float]
    bin_side_cm: float
    bin_height_cm: float
    camera: ViewCamera

    @classmethod
    def of(cls, model: ArmModel, config: Config) -> SceneLayout:
        """The layout for ``model`` at home on the rig and task of ``config``."""
        bins = np.array([c.bin_cm[:2] for c in config.task.classes], dtype=float)  # (k, 2)
        largest_cm = max(c.diameter_cm for c in config.task.classes)
        bin_side = min(bin_side_cm(bins), BIN_SIDE_PER_DIAMETER * largest_cm)
        table_points = [np.zeros((1, 2)), bins - bin_side / 2, bins + bin_side / 2]
        table_points.append(np.array([[o.x, o.y] for o in config.task.scene]).reshape(-1, 2))
        table_points.append(camera_field_cm(config))
        xy = np.vstack(table_points)
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        margin = max(TABLE_MARGIN_CM, TABLE_MARGIN_SHARE * float(np.max(hi - lo)))
        lo, hi = lo - margin, hi + margin

        arm = arm_points_cm(model, model.home)
        on_table = np.column_stack([xy, np.zeros(len(xy))])
        camera = ViewCamera.framing(np.vstack([arm, on_table]))
        return cls(
            table_x_cm=(float(lo[0]), float(hi[0])),
            table_y_cm=(float(lo[1]), float(hi[1])),
            bin_side_cm=bin_side,
            bin_height_cm=BIN_HEIGHT_PER_SIDE * bin_side,
            camera=camera,
        )


def bin_side_cm(bins_xy_cm: np.ndarray) -> float:
    """The bins' common footprint side [cm].

    :data:`BIN_SIDE_SHARE` of the least Chebyshev distance between two bins (squares
    that far apart do not overlap), at most :data:`BIN_SIDE_MAX_CM`.
    """
    if len(bins_xy_cm) < 2:
        return BIN_SIDE_MAX_CM
    d = np.abs(bins_xy_cm[:, None, :] - bins_xy_cm[None, :, :]).max(axis=2)
    np.fill_diagonal(d, np.inf)
    return float(min(BIN_SIDE_MAX_CM, BIN_SIDE_SHARE * d.min()))


def camera_field_cm(config: Config) -> np.ndarray:
    """Where the camera image's corners land on the table [cm], (4, 2)."""
    w, h = config.camera.width_px, config.camera.height_px
    corners = np.array([[0, 0], [w, 0], [w, h], [0, h]], dtype=float)
    return camera_geometry(config.calibration, config.camera).pixel_to_table(corners)


def arm_points_cm(model: ArmModel, q: np.ndarray) -> np.ndarray:
    """The base, every joint origin and the TCP at ``q`` (model units) [cm], (n + 2, 3)."""
    data = model.model.createData()
    pin.forwardKinematics(model.model, data, np.asarray(q, dtype=float))
    joints = [data.oMi[i].translation * CM_PER_M for i in range(1, model.model.njoints)]
    return np.vstack([np.zeros(3), *joints, model.fk_cm(q)])
