"""Where the view puts the table, and where it looks from.

The layout follows from the config. The table covers everything on it (the base, each
bin's footprint, the scene's objects, the camera's field) with a margin; the camera
frames the arm at home and everything on the table. The bins themselves are the
collision model's (:func:`mearm.kinematics.bodies.bin_shapes`, drawn by
:func:`mearm.view.scene_meshes.draw_bin`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from mearm.config import Config
from mearm.kinematics import CM_PER_M, ArmModel
from mearm.kinematics.bodies import bin_half_outer_m
from mearm.view.viewpoint import ViewCamera
from mearm.vision.calibration import camera_geometry

#: Table margin around everything on it: at least this [cm], or this share of its size.
TABLE_MARGIN_CM = 12.0
TABLE_MARGIN_SHARE = 0.15


@dataclass(frozen=True)
class SceneLayout:
    """The static scene's geometry.

    Attributes:
        table_x_cm: The table top's extent along x [cm], (min, max).
        table_y_cm: Its extent along y [cm], (min, max).
        camera: The viewpoint that frames the arm at home and the table's contents.
    """

    table_x_cm: tuple[float, float]
    table_y_cm: tuple[float, float]
    camera: ViewCamera

    @classmethod
    def of(cls, model: ArmModel, config: Config) -> SceneLayout:
        """The layout for ``model`` at home on the rig and task of ``config``."""
        bins = np.array([c.bin_cm[:2] for c in config.task.classes], dtype=float)  # (k, 2)
        half = np.array([[bin_half_outer_m(c) * CM_PER_M] for c in config.task.classes])
        table_points = [np.zeros((1, 2)), bins - half, bins + half]
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
            camera=camera,
        )


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
