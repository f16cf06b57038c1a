"""The meshcat geometry the view builds from the config and layout.

The table (its top the plane z = 0), one open bin per class, a class's object as a
cylinder, and the camera frame as a textured plane. Sizes come in centimetres and go
to meshcat in metres.
"""

from __future__ import annotations

from typing import Any

import cv2
import meshcat
import meshcat.geometry as mg
import meshcat.transformations as tf
import numpy as np

from mearm.config import ColorClass
from mearm.view.errors import ViewRunError
from mearm.view.frame_plane import FramePlane
from mearm.view.layout import SceneLayout
from mearm.view.view_items import rgb_int
from mearm.view.viewpoint import M_PER_CM

TABLE_RGB = 0xD8D5CE
TABLE_THICKNESS_CM = 2.0
#: Open bins: wall thickness [cm]; side and height come from the layout.
BIN_WALL_CM = 0.4


class PlaneGeometry(mg.Geometry):
    """three.js ``PlaneGeometry``: a width × height rectangle in the local xy plane [m]."""

    def __init__(self, width_m: float, height_m: float):
        super().__init__()
        self.width_m = width_m
        self.height_m = height_m

    def lower(self, object_data: Any) -> dict[str, Any]:
        """The geometry as three.js's JSON object format has it."""
        return {
            "uuid": self.uuid,
            "type": "PlaneGeometry",
            "width": self.width_m,
            "height": self.height_m,
            "widthSegments": 1,
            "heightSegments": 1,
        }


def png_bytes(bgra: np.ndarray) -> bytes:
    """An 8-bit BGRA image encoded as PNG."""
    ok, buf = cv2.imencode(".png", bgra)
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 BGRA image
        raise ViewRunError("OpenCV could not encode the camera frame as PNG")
    return buf.tobytes()


def draw_table(vis: meshcat.Visualizer, layout: SceneLayout) -> None:
    """The table: a thin slab under the layout's extent whose top is the plane z = 0."""
    (x0, x1), (y0, y1) = layout.table_x_cm, layout.table_y_cm
    size_m = np.array([x1 - x0, y1 - y0, TABLE_THICKNESS_CM]) * M_PER_CM
    center_m = np.array([(x0 + x1) / 2, (y0 + y1) / 2, -TABLE_THICKNESS_CM / 2]) * M_PER_CM
    vis["table"].set_object(mg.Box(size_m.tolist()), mg.MeshLambertMaterial(color=TABLE_RGB))
    vis["table"].set_transform(tf.translation_matrix(center_m))


def draw_bin(
    vis: meshcat.Visualizer,
    layout: SceneLayout,
    color_class: ColorClass,
    x_cm: float,
    y_cm: float,
) -> None:
    """An open box in the class's colour standing on the table under (x, y, ·)."""
    s, h, t = layout.bin_side_cm, layout.bin_height_cm, BIN_WALL_CM
    material = mg.MeshLambertMaterial(color=rgb_int(color_class.draw_rgb))
    parts = {  # name: (size, centre) relative to the bin's footprint centre [cm]
        "floor": ((s, s, t), (0, 0, t / 2)),
        "wall_xn": ((t, s, h), (-(s - t) / 2, 0, h / 2)),
        "wall_xp": ((t, s, h), ((s - t) / 2, 0, h / 2)),
        "wall_yn": ((s - 2 * t, t, h), (0, -(s - t) / 2, h / 2)),
        "wall_yp": ((s - 2 * t, t, h), (0, (s - t) / 2, h / 2)),
    }
    for name, (size, (cx, cy, cz)) in parts.items():
        node = vis[f"bins/{color_class.name}/{name}"]
        node.set_object(mg.Box([v * M_PER_CM for v in size]), material)
        node.set_transform(tf.translation_matrix(np.array([x_cm + cx, y_cm + cy, cz]) * M_PER_CM))


def class_cylinder(cls: ColorClass) -> tuple[mg.Geometry, mg.Material]:
    """A class's object: a cylinder of its size in its colour (along three.js y)."""
    geometry = mg.Cylinder(cls.height_cm * M_PER_CM, radius=cls.diameter_cm / 2 * M_PER_CM)
    return geometry, mg.MeshLambertMaterial(color=rgb_int(cls.draw_rgb))


def camera_frame_mesh(plane: FramePlane) -> mg.Mesh:
    """The camera frame as a plane of its size on the table, textured with the frame."""
    width_m, height_m = plane.size_cm * M_PER_CM
    texture = mg.ImageTexture(image=mg.PngImage(png_bytes(plane.texture_bgra)))
    material = mg.MeshBasicMaterial(map=texture, transparent=True)
    return mg.Mesh(PlaneGeometry(width_m, height_m), material)
