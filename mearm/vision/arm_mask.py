"""Where the arm's own body is in a calibrated camera's frame, at given joints.

The camera sees the arm: its blue brackets, a red servo horn or the object in its jaws
are of a class's colour but are no object on the table. The arm's shapes
(:func:`~mearm.kinematics.bodies.arm_bodies`, the collision model's and the twin's) are
placed at the joints (the model's forward kinematics), each shape's corners (a box's 8,
a cylinder's two rims) projected into the frame
(:meth:`~mearm.vision.pinhole.PerspectiveCamera.project`), their convex hull filled, and
the whole grown by :data:`MARGIN_CM` at the table's scale under the tool: the shapes
leave out screws, cables and the servo horns, and a joint's reading is a degree or so
off. The detector classifies nothing there (``exclude`` of
:meth:`~mearm.vision.detector.ColorDetector.detect`).
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import numpy.typing as npt
import pinocchio as pin

from mearm.kinematics.bodies import ArmBodies, Shape
from mearm.kinematics.chain import M_PER_CM
from mearm.kinematics.model import ArmModel
from mearm.vision.pinhole import PerspectiveCamera

#: What the mask adds around the arm's shapes [cm]: parts the shapes leave out (screws,
#: cables, horns) and the joints' error (1° at 20 cm is 0.35 cm).
MARGIN_CM = 1.0
#: How far beyond the frame's corners (in normalised radius) the lens's distortion model
#: is used [-]; past it, points are projected without it (:func:`project_in_view`).
FIELD_REACH = 1.1
#: Points on each rim of a cylinder [-] (a 16-gon's area is 97 % of its circle's).
RIM_POINTS = 16


def _corners_m(shape: Shape) -> np.ndarray:
    """A shape's corners in its own frame, (K, 3) [m]: a box's 8, a cylinder's two rims."""
    if shape.kind == "box":
        sx, sy, sz = shape.size
        return np.array(
            [[x, y, z] for x in (-sx, sx) for y in (-sy, sy) for z in (-sz, sz)], dtype=float
        )
    r, h = shape.size[0], shape.size[1]
    a = np.linspace(0.0, 2 * math.pi, RIM_POINTS, endpoint=False)
    # the polygon around the circle (its corners at r / cos(π/K)) holds the rim
    ring = r / math.cos(math.pi / RIM_POINTS) * np.stack([np.cos(a), np.sin(a)], axis=1)
    return np.concatenate([np.column_stack([ring, np.full(RIM_POINTS, z)]) for z in (-h, h)])


def project_in_view(camera: PerspectiveCamera, points_cm: np.ndarray) -> np.ndarray:
    """Pixels of base-frame points (N, 3) [cm] → (N, 2) [px], sound far outside the frame.

    The lens's distortion polynomial folds back points well outside the field of view
    (a body beside the frame would land in it): those, and points behind the camera's
    plane, are projected without distortion (they stay outside, on their own side).
    """
    intr = camera.intrinsics
    cam = (points_cm - camera.centre_cm) @ camera.extrinsics.rotation  # camera frame, (N, 3)
    z = np.maximum(cam[:, 2], 1e-6)
    xn = cam[:, :2] / z[:, None]
    w, h = camera.size_px
    corners = intr.undistort(np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]]))
    inside = (np.linalg.norm(xn, axis=1) <= FIELD_REACH * np.linalg.norm(corners, axis=1).max()) & (
        cam[:, 2] > 0
    )
    K = intr.camera_matrix
    out = xn @ K[:2, :2].T + K[:2, 2]
    if inside.any():
        out[inside] = camera.project(points_cm[inside])
    return out


class ArmInView:
    """The arm's body in a calibrated camera's frame.

    Args:
        camera: The calibrated camera.
        model: The arm's kinematic model (its Pinocchio model).
        bodies: The arm's shapes (the collision model's ``bodies``).
        opening_cm: The jaws' opening the mask assumes [cm]: the widest (open) covers
            every opening.
    """

    def __init__(
        self, camera: PerspectiveCamera, model: ArmModel, bodies: ArmBodies, *, opening_cm: float
    ):
        self.camera = camera
        self.model = model
        self.bodies = bodies
        self.opening_cm = float(opening_cm)
        pm = model.model
        self._data = pm.createData()
        last = pm.njoints - 1
        self._joint_of = {"base_link": 0, "tcp": last}
        for name in model.chain.names:
            self._joint_of[f"link_{name}"] = pm.getJointId(name)
        self._last = last
        self._corners = [_corners_m(s) for s in bodies.shapes]

    def _in_joint(self, shape: Shape) -> np.ndarray:
        """A shape's pose in its joint's frame, (4, 4) [m] (a jaw's slid by the opening)."""
        T = shape.pose
        if shape.jaw:
            slide = np.eye(4)
            slide[:3, 3] = self.bodies.across * shape.jaw * self.opening_cm * M_PER_CM / 2
            return self.bodies.tcp_in_last @ slide @ T
        if shape.body == "tcp":
            return self.bodies.tcp_in_last @ T
        return T

    def poses(self, q: npt.ArrayLike) -> list[np.ndarray]:
        """Each shape's pose in the base frame at joints ``q`` (model units), (4, 4) [m]."""
        pm = self.model.model
        pin.forwardKinematics(pm, self._data, np.asarray(q, dtype=float))
        out = []
        for shape in self.bodies.shapes:
            joint = self._data.oMi[self._joint_of.get(shape.body, self._last)]
            out.append(joint.homogeneous @ self._in_joint(shape))
        return out

    def mask(self, q: npt.ArrayLike, frame_shape: tuple[int, ...]) -> np.ndarray:
        """0/255 uint8 mask (H, W) of the arm's body in the frame at joints ``q``, grown."""
        h, w = int(frame_shape[0]), int(frame_shape[1])
        out = np.zeros((h, w), np.uint8)
        for T, corners in zip(self.poses(q), self._corners, strict=True):
            world_cm = (corners @ T[:3, :3].T + T[:3, 3]) / M_PER_CM
            px = project_in_view(self.camera, world_cm).astype(np.float32)
            hull = cv2.convexHull(px.reshape(-1, 1, 2))
            cv2.fillConvexPoly(out, np.round(hull).astype(np.int32), 255)
        grow = self._margin_px(q)
        if grow > 0:
            k = 2 * grow + 1
            kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
            return np.asarray(cv2.dilate(out, kernel), dtype=np.uint8)
        return out

    def _margin_px(self, q: npt.ArrayLike) -> int:
        """:data:`MARGIN_CM` in pixels at the table under the tool."""
        x, y, _ = (float(v) for v in self.model.fk_cm(q))
        (u, v), = self.camera.table_to_pixel(np.array([[x, y]]))  # fmt: skip
        cm2 = float(self.camera.pixel_area_cm2(np.array([[u, v]]))[0])
        if not math.isfinite(cm2) or cm2 <= 0:
            return 0
        return math.ceil(MARGIN_CM / math.sqrt(cm2))


def arm_view(
    camera: object, model: ArmModel, bodies: ArmBodies, *, opening_cm: float
) -> ArmInView | None:
    """The arm's body in the camera's frame, or ``None`` where it cannot be known.

    ``None`` unless ``camera`` is a calibrated :class:`PerspectiveCamera` (a homography
    knows only the table's plane, not where a body above it shows).
    """
    if not isinstance(camera, PerspectiveCamera):
        return None
    return ArmInView(camera, model, bodies, opening_cm=opening_cm)
