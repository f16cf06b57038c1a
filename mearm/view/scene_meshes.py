"""The meshcat geometry the view builds from the config and layout.

The table (its top the plane z = 0), one open bin per class, a class's object as a
cylinder, and the camera frame as a textured plane. Sizes come in centimetres and go
to meshcat in metres; the bins come in metres already, as the shapes of
:func:`mearm.kinematics.bodies.bin_shapes`: the planner's collision model and the MuJoCo
twin are built from the same shapes, so the bins drawn are the bins the arm avoids.
"""

from __future__ import annotations

from typing import Any

import cv2
import meshcat
import meshcat.geometry as mg
import meshcat.transformations as tf
import numpy as np

from mearm.config import ColorClass
from mearm.kinematics.bodies import TableContents, bin_name, bin_origin_m, bin_shapes
from mearm.view.errors import ViewRunError
from mearm.view.frame_plane import FramePlane
from mearm.view.layout import SceneLayout
from mearm.view.view_items import rgb_int
from mearm.view.viewpoint import M_PER_CM

TABLE_RGB = 0xD8D5CE
TABLE_THICKNESS_CM = 2.0


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


def draw_bin(vis: meshcat.Visualizer, table: TableContents, color_class: ColorClass) -> None:
    """A class's open bin in its colour, standing on the table under its ``bin_cm``.

    Its floor and walls are :func:`~mearm.kinematics.bodies.bin_shapes` (the walls as high
    as the table's objects of the class need, :meth:`TableContents.objects`), each drawn
    under ``bins/<class>/<part>`` (``floor``, ``wall_px``, …), the part its shape names.
    """
    material = mg.MeshLambertMaterial(color=rgb_int(color_class.draw_rgb))
    origin = tf.translation_matrix(bin_origin_m(color_class))
    prefix = bin_name(color_class.name, "")
    for shape in bin_shapes(color_class, table.objects(color_class.name)):
        node = vis[f"bins/{color_class.name}/{shape.name.removeprefix(prefix)}"]
        node.set_object(mg.Box([2 * half for half in shape.size]), material)  # half-sizes
        node.set_transform(origin @ shape.pose)


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
