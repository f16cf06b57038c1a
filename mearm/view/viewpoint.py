r"""The viewpoint of the meshcat view, and where it puts a point on the screen.

meshcat's browser camera is an orbit camera that always looks at the three.js world
origin. To look at the workspace rather than at the robot's base, :meth:`ViewCamera.apply`
shifts the whole scene (the ``/meshcat`` node, whose frame is the robot base frame) by
−target, and places the camera at position − target. Everything drawn under
``/meshcat`` therefore keeps base-frame coordinates.

:meth:`ViewCamera.project` is the pinhole model of that camera (three.js
``PerspectiveCamera`` with its vertical field of view, ``lookAt`` with z up):

.. math::
    u = \frac{W}{2}\Bigl(1 + \frac{x_c}{z_c \tan(\phi/2)\,W/H}\Bigr), \qquad
    v = \frac{H}{2}\Bigl(1 - \frac{y_c}{z_c \tan(\phi/2)}\Bigr)

with :math:`(x_c, y_c, z_c)` the point in the camera's right / up / forward axes.
"""

from __future__ import annotations

from dataclasses import dataclass

import meshcat
import meshcat.transformations as tf
import numpy as np
import numpy.typing as npt

from mearm.kinematics.chain import M_PER_CM
from mearm.view.errors import ViewInputError

_Z_UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class ViewCamera:
    """A fixed viewpoint, base frame.

    Attributes:
        position_cm: Where the camera is [cm], (3,).
        target_cm: The point it looks at, drawn at the centre of the view [cm], (3,).
        fov_deg: Vertical field of view [deg].
    """

    position_cm: tuple[float, float, float]
    target_cm: tuple[float, float, float]
    fov_deg: float = 40.0

    def __post_init__(self) -> None:
        offset = np.subtract(self.position_cm, self.target_cm)
        if not np.all(np.isfinite(offset)) or np.linalg.norm(offset) < 1e-6:
            raise ViewInputError(
                "position_cm", self.position_cm, "a finite point away from target_cm"
            )
        if np.linalg.norm(np.cross(offset, _Z_UP)) < 1e-6:
            raise ViewInputError(
                "position_cm", self.position_cm, "a point not straight above or below target_cm"
            )
        if not 1.0 <= self.fov_deg <= 170.0:
            raise ViewInputError("fov_deg", self.fov_deg, "a field of view in [1, 170] deg")

    def axes(self) -> np.ndarray:
        """The camera's right, up and forward unit vectors as rows, base frame, (3, 3)."""
        forward = np.subtract(self.target_cm, self.position_cm)
        forward = forward / np.linalg.norm(forward)
        right = np.cross(forward, _Z_UP)
        right /= np.linalg.norm(right)
        return np.array([right, np.cross(right, forward), forward])

    def project(self, points_cm: npt.ArrayLike, width_px: int, height_px: int) -> np.ndarray:
        """Pixel coordinates (u right, v down) of base-frame points on a W × H view.

        Args:
            points_cm: Points in the base frame [cm], (N, 3) or (3,).
            width_px: View width [px].
            height_px: View height [px].

        Returns:
            (N, 2) pixel coordinates [px]; NaN for points behind the camera.
        """
        p = np.atleast_2d(np.asarray(points_cm, dtype=float))
        cam = (p - np.asarray(self.position_cm)) @ self.axes().T  # (N, 3): right, up, fwd
        half = np.tan(np.radians(self.fov_deg) / 2.0)
        aspect = width_px / height_px
        with np.errstate(divide="ignore", invalid="ignore"):
            x_ndc = cam[:, 0] / (cam[:, 2] * half * aspect)
            y_ndc = cam[:, 1] / (cam[:, 2] * half)
        uv = np.column_stack([(x_ndc + 1.0) * width_px / 2.0, (1.0 - y_ndc) * height_px / 2.0])
        uv[cam[:, 2] <= 0] = np.nan
        return uv

    @classmethod
    def framing(
        cls,
        points_cm: npt.ArrayLike,
        direction: npt.ArrayLike | None = None,
        fov_deg: float = 40.0,
        margin: float = 1.05,
    ) -> ViewCamera:
        r"""A camera that sees every point.

        It looks at the points' bounding box's centre from ``direction``, far enough that
        the box's bounding sphere fills the view's height:

        .. math:: d = \frac{m\,r}{\sin(\phi/2)}

        with r the sphere's radius, φ the vertical field of view and m the margin.

        Args:
            points_cm: Points to keep in view, base frame [cm], (N, 3).
            direction: From the target towards the camera (any length), (3,); default
                :data:`DEFAULT_CAMERA`'s (from the front right, above).
            fov_deg: Vertical field of view [deg].
            margin: Distance factor beyond the tight fit [-].
        """
        p = np.atleast_2d(np.asarray(points_cm, dtype=float))
        lo, hi = p.min(axis=0), p.max(axis=0)
        target = (lo + hi) / 2.0
        radius = max(float(np.linalg.norm(hi - lo)) / 2.0, 1.0)
        if direction is None:
            direction = np.subtract(DEFAULT_CAMERA.position_cm, DEFAULT_CAMERA.target_cm)
        unit = np.asarray(direction, dtype=float)
        unit = unit / np.linalg.norm(unit)
        distance = margin * radius / np.sin(np.radians(fov_deg) / 2.0)
        position = target + distance * unit
        return cls(
            tuple(float(v) for v in position),  # type: ignore[arg-type]
            tuple(float(v) for v in target),  # type: ignore[arg-type]
            fov_deg,
        )

    def apply(self, vis: meshcat.Visualizer) -> None:
        """Point the browser camera of ``vis`` (its root, ``/meshcat``) at the target."""
        target_m = np.asarray(self.target_cm) * M_PER_CM
        rel = (np.asarray(self.position_cm) - np.asarray(self.target_cm)) * M_PER_CM
        vis["/meshcat"].set_transform(tf.translation_matrix(-target_m))
        vis["/Cameras/default"].set_transform(np.eye(4))
        camera = vis["/Cameras/default/rotated/<object>"]
        # The camera sits under a node turned +90° about x (three.js is y-up):
        # base (x, y, z) is (x, z, −y) there.
        camera.set_property("position", [float(rel[0]), float(rel[2]), float(-rel[1])])
        camera.set_property("fov", float(self.fov_deg))


#: The view's default: from the front right, above the table, looking at the workspace
#: between the base and the objects.
DEFAULT_CAMERA = ViewCamera(position_cm=(28.0, 118.0, 82.0), target_cm=(-5.0, 28.0, 15.0))
