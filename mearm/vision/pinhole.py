r"""The camera as a 3-D sensor: a calibrated pinhole with lens distortion, placed in the base frame.

The paper maps pixels to the table with one plane homography (:mod:`mearm.vision.calibration`),
exact for a distortion-free camera and points *on the table*. A real webcam bends lines
(lens distortion) and sees the *top* of each object, which is nearer to it than the
table: an object of height *h* seen at distance ρ from the camera's foot point shows
its top pushed outwards by ρ·h/(H − h) (*H* the camera's height), 0.3 cm for a 1 cm
object 15 cm from the foot of a camera 52 cm up.

This module models the camera instead:

- :class:`Intrinsics` — the camera matrix *K* and OpenCV's distortion coefficients
  (k1, k2, p1, p2, k3), from views of a ChArUco board (:mod:`mearm.vision.charuco`);
- :class:`Extrinsics` — the camera's pose in the robot base frame: the rotation
  :math:`R` (camera → base; camera axes x right, y down, z forward as in OpenCV) and
  its optical centre :math:`C` [cm], from ArUco markers lying on the table (solvePnP);
- :class:`PerspectiveCamera` — both together: a pixel is undistorted, its ray
  :math:`C + t\,R\,[x_n, y_n, 1]^T` cast into the base frame and cut with the plane
  z = *h* of the object's top face; and the inverse, a base-frame point projected to a
  pixel.

**Locating an object** (:meth:`PerspectiveCamera.locate_object`). An upright cylinder
(radius *r*, height *h*) is convex, so its image is the convex hull of the images of its
two end discs. Cast back onto the plane of its top, z = *h*, the top disc is a circle
of radius *r* around the object's axis and the base disc a smaller circle nearer the
camera's foot point *N*; the side wall fills the hull between them. The half of the
outline facing away from *N* is therefore always the top disc's rim: the object's
centre is the centre of the circle fitted to that arc (the fit's radius is free, so a
mask grown or shrunk by a fraction of a pixel all round does not move it). Whether the
side wall is bright enough to be segmented does not matter.

**Files.** Each calibration is its own versioned YAML file
(:mod:`mearm.vision.calibration_file`, whose names this module re-exports).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from mearm.config.errors import CalibrationError
from mearm.vision.calibration_file import (
    _KINDS,
    _UNDISTORT_CRITERIA,
    FORMAT,
    MAX_CAMERA_DISTANCE_CM,
    MAX_DISTORTION,
    MAX_FIT_COUNT,
    MAX_PIXELS,
    VERSION,
    CalibrationFile,
    Extrinsics,
    Intrinsics,
    Kind,
    _check_replace,
    _matrix,
    _rms,
    _size_px,
    _whole,
    calibration_text,
    load_calibration,
    save_calibration,
    today,
)
from mearm.vision.subpixel import _outward_normals, subpixel_edges
from mearm.vision.top_face import (
    TopFace,
    TopFit,
    _fit_circle,
    _fit_disc,
    _fit_polygon,
    _nearest_on_sides,
)

__all__ = [
    "FAR_ARC_DEG",
    "FORMAT",
    "MAX_CAMERA_DISTANCE_CM",
    "MAX_DISTORTION",
    "MAX_FIT_COUNT",
    "MAX_PIXELS",
    "POLYGON_OUTSIDE_CM",
    "POLYGON_TURNS",
    "VERSION",
    "CalibrationFile",
    "Extrinsics",
    "Intrinsics",
    "Kind",
    "PerspectiveCamera",
    "TopFace",
    "TopFit",
    "_KINDS",
    "_UNDISTORT_CRITERIA",
    "_check_replace",
    "_fit_circle",
    "_fit_disc",
    "_fit_polygon",
    "_matrix",
    "_nearest_on_sides",
    "_outward_normals",
    "_rms",
    "_size_px",
    "_whole",
    "calibration_text",
    "load_calibration",
    "save_calibration",
    "solve_pose",
    "subpixel_edges",
    "today",
]

#: this angle of the direction away from the camera's foot point [deg]. The top disc's
#: rim owns at least ±90° of the outline (the base disc, cast onto the top's plane, is
#: smaller and nearer the foot point, so the hull's straight sides touch the top circle
#: beyond ±90°).
FAR_ARC_DEG = 89.0
#: A rim fitted wider than this many times the object's radius is not its top's rim [-]:
#: the top's rim, cast onto its own plane, has the object's radius (on the open table no
#: fit came wider than 1.25 of it in 22 scenes of the three perspective twins,
#: simulated), while an arc the arm's body cut short, straightened along the cut, fitted
#: a circle 2.9 times as wide, its centre 2.2 cm off. (Stacks in a bin reach 3 with
#: their centre at the centroid's, which is then taken.)
RIM_WIDEST = 1.5
#: Starting turns of the polygon fit, spread over one period of its symmetry [-].
POLYGON_TURNS = 3
#: A fitted polygon's corner may lie this far outside the region's outline [cm] (the
#: outline's pixels and the corner's own rounding); farther, the fit is the far edges'
#: mirror image.
POLYGON_OUTSIDE_CM = 0.05
#: Sub-pixel bits of the silhouettes' anti-aliased fill (1/16 px).
_SUBPIXEL_BITS = 4
_SUBPIXEL = 1 << _SUBPIXEL_BITS
#: The silhouette fit: its box's margin [px], iterations and derivative step [cm].
_FIT_PAD_PX = 3
_FIT_ITERATIONS = 20
_FIT_STEP_CM = 0.01


def _levenberg_marquardt(residual: Callable[[np.ndarray], np.ndarray], p: np.ndarray) -> np.ndarray:
    """The parameters minimising ``|residual(p)|²`` from ``p`` (forward differences)."""
    r = residual(p)
    cost = float(r @ r)
    damping = 1e-3
    for _ in range(_FIT_ITERATIONS):
        J = np.empty((len(r), len(p)))
        for i in range(len(p)):
            q = p.copy()
            q[i] += _FIT_STEP_CM
            J[:, i] = (residual(q) - r) / _FIT_STEP_CM
        JtJ, Jtr = J.T @ J, J.T @ r
        improved = False
        for _ in range(8):
            step = np.linalg.solve(JtJ + damping * np.diag(np.diag(JtJ) + 1e-9), -Jtr)
            q = p + step
            rq = residual(q)
            cq = float(rq @ rq)
            if cq < cost:
                p, r, cost, improved = q, rq, cq, True
                damping = max(damping / 3.0, 1e-7)
                break
            damping *= 4.0
        if not improved or np.abs(step).max() < 1e-4:
            break
    return p


def _wrong_share(region: np.ndarray, hull: np.ndarray, tops: np.ndarray) -> float:
    """The share of the region's area the fitted silhouettes get wrong by over a pixel.

    Wrong: a top's pixel (over half covered) with no mask pixel within one pixel, or a
    mask pixel with no silhouette pixel within one (a mask's edge wanders by up to a
    pixel with the colour thresholds).
    """
    near = np.ones((3, 3), np.uint8)
    seen = region.astype(np.uint8)
    seen_near = cv2.dilate(seen, near).view(bool)
    hull_near = cv2.dilate((hull > 0.5).astype(np.uint8), near).view(bool)
    bad = np.count_nonzero((tops > 0.5) & ~seen_near) + np.count_nonzero(
        seen.view(bool) & ~hull_near
    )
    return bad / max(float(region.sum()), 1.0)


class PerspectiveCamera:
    """A calibrated camera placed in the base frame: pixels ↔ 3-D points [cm].

    Args:
        intrinsics: The camera matrix and distortion.
        extrinsics: Its pose in the base frame.

    Raises:
        CalibrationError: the two were made for different frame sizes, or the camera is
            not above the table (z ≤ 0).
    """

    def __init__(self, intrinsics: Intrinsics, extrinsics: Extrinsics):
        if intrinsics.size_px != extrinsics.size_px:
            raise CalibrationError(
                f"the intrinsics are for {intrinsics.size_px[0]}x{intrinsics.size_px[1]} px "
                f"frames but the extrinsics were fitted at {extrinsics.size_px[0]}x"
                f"{extrinsics.size_px[1]} px: recalibrate the pose at this resolution"
            )
        if extrinsics.position_cm[2] <= 0:
            raise CalibrationError(
                f"the camera is at z = {extrinsics.position_cm[2]:.1f} cm, not above the "
                "table: the extrinsics are wrong (mirrored marker positions?)"
            )
        self.intrinsics = intrinsics
        self.extrinsics = extrinsics
        self.size_px = intrinsics.size_px
        self.centre_cm = extrinsics.position_cm
        self._R = extrinsics.rotation
        self._rvec, self._tvec = extrinsics.rvec_tvec()

    @classmethod
    def from_files(cls, intrinsics: str | Path, extrinsics: str | Path) -> PerspectiveCamera:
        """The camera the two calibration files describe."""
        i = load_calibration(intrinsics, "intrinsics")
        e = load_calibration(extrinsics, "extrinsics")
        assert isinstance(i, Intrinsics) and isinstance(e, Extrinsics)
        return cls(i, e)

    def with_extrinsics(self, extrinsics: Extrinsics) -> PerspectiveCamera:
        """The same camera at another pose."""
        return PerspectiveCamera(self.intrinsics, extrinsics)

    # ------------------------------------------------------------------ geometry

    def rays(self, pixels_px: npt.ArrayLike) -> np.ndarray:
        """Base-frame directions of the rays through pixels, (N, 2) → (N, 3) (not unit length)."""
        xn = self.intrinsics.undistort(pixels_px)
        cam = np.column_stack([xn, np.ones(len(xn))])
        return cam @ self._R.T

    def pixel_to_plane(self, pixels_px: npt.ArrayLike, z_cm: npt.ArrayLike = 0.0) -> np.ndarray:
        """Where each pixel's ray meets the plane z = ``z_cm`` [cm]: (x, y) [cm].

        Shapes as :meth:`pixel_to_table`; ``z_cm`` is one height or one per pixel.

        Raises:
            CalibrationError: a ray does not come down to that plane (it points above
                the horizon).
        """
        px = np.asarray(pixels_px, dtype=float)
        d = self.rays(px.reshape(-1, 2))
        z = np.broadcast_to(np.asarray(z_cm, dtype=float), (len(d),))
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (z - self.centre_cm[2]) / d[:, 2]
        if not np.all(t > 0):
            raise CalibrationError(
                "a pixel's ray does not meet the table: it looks above the horizon"
            )
        xy = self.centre_cm[:2] + t[:, None] * d[:, :2]
        return xy.reshape(px.shape)

    def pixel_to_table(self, pixels_px: npt.ArrayLike) -> np.ndarray:
        """Table points (z = 0) of pixels; (N, 2) → (N, 2), (2,) → (2,) [cm]."""
        return self.pixel_to_plane(pixels_px, 0.0)

    def project(self, points_cm: npt.ArrayLike) -> np.ndarray:
        """Pixels of base-frame points (N, 3) [cm] → (N, 2) [px], distortion included."""
        pts = np.asarray(points_cm, dtype=np.float64).reshape(-1, 1, 3)
        px, _ = cv2.projectPoints(
            pts, self._rvec, self._tvec, self.intrinsics.camera_matrix, self.intrinsics.distortion
        )
        return px.reshape(-1, 2)

    def table_to_pixel(self, table_cm: npt.ArrayLike, z_cm: float = 0.0) -> np.ndarray:
        """Pixels of points (x, y) on the plane z = ``z_cm``; (N, 2) → (N, 2), (2,) → (2,)."""
        xy = np.asarray(table_cm, dtype=float)
        flat = xy.reshape(-1, 2)
        pts = np.column_stack([flat, np.full(len(flat), z_cm)])
        return self.project(pts).reshape(xy.shape)

    def pixel_area_cm2(self, pixels_px: npt.ArrayLike, z_cm: float = 0.0) -> np.ndarray:
        """Area one pixel covers on the plane z = ``z_cm`` at each pixel [cm²], (N,)."""
        px = np.asarray(pixels_px, dtype=float).reshape(-1, 2)
        e = 0.5
        p = self.pixel_to_plane(
            np.concatenate([px - (e, 0), px + (e, 0), px - (0, e), px + (0, e)]), z_cm
        ).reshape(4, -1, 2)
        du, dv = (p[1] - p[0]) / (2 * e), (p[3] - p[2]) / (2 * e)
        return np.abs(du[:, 0] * dv[:, 1] - du[:, 1] * dv[:, 0])

    def expected_disc_area_px(
        self, pixels_px: npt.ArrayLike, diameter_cm: npt.ArrayLike
    ) -> np.ndarray:
        """Image area [px] of a flat disc on the table centred at each pixel, (N,)."""
        radius_cm = np.asarray(diameter_cm, dtype=float) / 2.0
        return math.pi * radius_cm**2 / self.pixel_area_cm2(pixels_px)

    def silhouette_px(
        self,
        centre_cm: npt.ArrayLike,
        radius_cm: float,
        height_cm: float,
        n: int = 48,
        *,
        top_only: bool = False,
    ) -> np.ndarray:
        """The image outline of an upright cylinder standing at ``centre_cm`` (x, y), (M, 2) [px].

        The convex hull of its two end discs' images (exact for a convex body); with
        ``top_only``, of its top disc's image alone.
        """
        a = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
        x, y = np.asarray(centre_cm, dtype=float)
        ring = np.column_stack([x + radius_cm * np.cos(a), y + radius_cm * np.sin(a)])
        top = np.column_stack([ring, np.full(n, height_cm)])
        pts = top if top_only else np.concatenate([np.column_stack([ring, np.zeros(n)]), top])
        px = self.project(pts).astype(np.float32)
        return cv2.convexHull(px).reshape(-1, 2).astype(float)

    def object_image(
        self, centre_cm: npt.ArrayLike, radius_cm: float, height_cm: float
    ) -> tuple[float, float]:
        """Image area [px] and principal-axis ratio [-] of an upright cylinder's outline."""
        hull = self.silhouette_px(centre_cm, radius_cm, height_cm).astype(np.float32)
        m = cv2.moments(hull)
        a, b, c = m["mu20"], m["mu11"], m["mu02"]
        root = math.sqrt(max((a - c) ** 2 + 4.0 * b * b, 0.0))
        lam_min = (a + c - root) / 2.0
        ratio = math.sqrt((a + c + root) / 2.0 / lam_min) if lam_min > 1e-12 else math.inf
        return float(m["m00"]), ratio

    def silhouette_coverage(
        self,
        centres_cm: npt.ArrayLike,
        radius_cm: float,
        height_cm: float,
        origin_px: tuple[int, int],
        shape: tuple[int, int],
        *,
        top_only: bool = False,
    ) -> np.ndarray:
        """How much of each pixel of a box the cylinders at ``centres_cm`` cover.

        Args:
            centres_cm: Their positions (x, y) [cm], (N, 2).
            radius_cm: Their radius [cm].
            height_cm: Their height [cm].
            origin_px: The box's top-left pixel (x, y) in the frame.
            shape: The box's shape (rows, columns).
            top_only: Cover with their top faces' images alone.

        Returns:
            (rows, columns) float, 0 (none) to 1 (whole pixel), edges anti-aliased.
        """
        canvas = np.zeros(shape, np.uint8)
        for c in np.asarray(centres_cm, dtype=float).reshape(-1, 2):
            hull = self.silhouette_px(c, radius_cm, height_cm, top_only=top_only) - origin_px
            fixed = np.round(hull * _SUBPIXEL).astype(np.int32)
            cv2.fillConvexPoly(canvas, fixed, 255, cv2.LINE_AA, _SUBPIXEL_BITS)
        return canvas.astype(float) / 255.0

    def fit_silhouettes(
        self,
        mask: np.ndarray,
        origin_px: tuple[int, int],
        radius_cm: float,
        height_cm: float,
        count: int,
    ) -> tuple[np.ndarray, float]:
        """Where ``count`` touching cylinders stand whose images together make ``mask``.

        Two upright cylinders side by side need not leave a neck in their joint image:
        seen from the side, one's wall fills the gap to the other. The camera knows the
        outline of one (:meth:`silhouette_px`), so the region is explained instead: the
        pixels are split into ``count`` clusters on the plane of the tops (k-means), and
        the positions moved (Levenberg–Marquardt, numerical derivatives) until the mask
        holds every top face (a top is never hidden: nothing of a neighbour of the same
        height rises above it) and lies within the union of the silhouettes (the side
        walls between may be segmented or not: a darker wall often is not). Both are
        scored on anti-aliased coverage, so the fit moves by fractions of a pixel.

        Args:
            mask: The region, a 0/1 (or 0/255) uint8 image of its bounding box.
            origin_px: The box's top-left pixel (x, y) in the frame.
            radius_cm: One object's radius [cm].
            height_cm: One object's height [cm].
            count: How many objects to fit (≥ 1).

        Returns:
            ``(centres, wrong)``: the positions (count, 2) [cm] and the share of the
            region's area that the fitted silhouettes get wrong (0 = exact).
        """
        region = (np.asarray(mask) > 0).astype(float)
        pad = _FIT_PAD_PX
        region = np.pad(region, pad)
        origin = (origin_px[0] - pad, origin_px[1] - pad)
        ys, xs = np.nonzero(region)
        pixels = np.column_stack([xs + origin[0], ys + origin[1]]).astype(float)
        on_top = self.pixel_to_plane(pixels, height_cm).astype(np.float32)
        criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-4)
        cv2.setRNGSeed(0)  # k-means++ seeding is random: the same region, the same fit
        labels = np.zeros((len(on_top), 1), np.int32)
        _, _, start = cv2.kmeans(on_top, count, labels, criteria, 3, cv2.KMEANS_PP_CENTERS)
        p = start.astype(float).ravel()

        def residual(q: np.ndarray) -> np.ndarray:
            at = q.reshape(-1, 2)
            hull = self.silhouette_coverage(at, radius_cm, height_cm, origin, region.shape)
            tops = self.silhouette_coverage(
                at, radius_cm, height_cm, origin, region.shape, top_only=True
            )
            return np.concatenate(
                [np.maximum(tops - region, 0.0).ravel(), np.maximum(region - hull, 0.0).ravel()]
            )

        at = _levenberg_marquardt(residual, p).reshape(-1, 2)
        hull = self.silhouette_coverage(at, radius_cm, height_cm, origin, region.shape)
        tops = self.silhouette_coverage(
            at, radius_cm, height_cm, origin, region.shape, top_only=True
        )
        return at, _wrong_share(region, hull, tops)

    def _outline_on_plane(
        self,
        mask: np.ndarray,
        origin_px: tuple[int, int],
        height_cm: float,
        frame: np.ndarray | None,
    ) -> np.ndarray:
        """A region's outer outline (on the colour edge with ``frame``) cast onto z = h."""
        contours, _ = cv2.findContours(
            (mask > 0).view(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE
        )
        outline = max(contours, key=len).reshape(-1, 2).astype(float) + origin_px
        if frame is not None:
            outline = subpixel_edges(frame, outline)
        return self.pixel_to_plane(outline, height_cm)

    def _far_side(self, pts: np.ndarray, c: np.ndarray, radius_cm: float) -> np.ndarray:
        """The outline points (on the top's plane) on the far side of ``c``.

        Those within :data:`FAR_ARC_DEG` of the way away from the camera's foot point;
        all of them when ``c`` is under the camera (the whole outline is the top's rim).
        """
        away = c - self.centre_cm[:2]
        dist = float(np.linalg.norm(away))
        if dist < 1e-6 * max(radius_cm, 1e-3):
            return pts
        d = pts - c
        cosang = (d @ (away / dist)) / np.maximum(np.linalg.norm(d, axis=1), 1e-12)
        return pts[cosang >= math.cos(math.radians(FAR_ARC_DEG))]

    def rim_centres(
        self,
        mask: np.ndarray,
        origin_px: tuple[int, int],
        centres_cm: npt.ArrayLike,
        radius_cm: float,
        height_cm: float,
        frame: np.ndarray | None = None,
    ) -> np.ndarray:
        """Touching objects' positions refined on their own top rims.

        The silhouette fit (:meth:`fit_silhouettes`) places each object to a fraction of a
        pixel on a binary mask; the rims are sharper. Each object keeps the outline points
        of the region (on the colour edge with ``frame``: :func:`subpixel_edges`) that are
        nearer to it than to the others, lie within a fifth of its radius of its top circle
        and face away from the camera's foot point (the top's rim: module docstring); a
        circle of the known radius is fitted to them (Gauss–Newton). An object with
        fewer than 8 such points keeps its fitted position.

        Args:
            mask: The region, a 0/1 (or 0/255) uint8 image of its bounding box.
            origin_px: The box's top-left pixel (x, y) in the frame.
            centres_cm: The fitted positions (x, y) [cm], (N, 2).
            radius_cm: The objects' radius [cm].
            height_cm: Their height [cm].
            frame: The whole image, for the sub-pixel outline.

        Returns:
            The positions (N, 2) [cm].
        """
        centres = np.array(centres_cm, dtype=float).reshape(-1, 2)
        pts = self._outline_on_plane(mask, origin_px, height_cm, frame)
        owner = np.argmin(np.linalg.norm(pts[:, None, :] - centres[None], axis=2), axis=1)
        foot = self.centre_cm[:2]
        far = math.cos(math.radians(FAR_ARC_DEG))
        for i in range(len(centres)):
            c = centres[i].copy()
            away = c - foot
            u = away / max(float(np.linalg.norm(away)), 1e-9)
            d = pts - c
            dist = np.linalg.norm(d, axis=1)
            facing = (d @ u) >= far * np.maximum(dist, 1e-12)
            rim = pts[(owner == i) & (np.abs(dist - radius_cm) < 0.2 * radius_cm) & facing]
            if len(rim) < 8:
                continue
            centres[i] = _fit_disc(rim, radius_cm, c)[0]
        return centres

    def _centroid_on_plane(
        self, mask: np.ndarray, origin_px: tuple[int, int], height_cm: float
    ) -> np.ndarray:
        """The region's centroid cast onto the plane z = ``height_cm``: (x, y) [cm], (2,)."""
        m = cv2.moments((mask > 0).view(np.uint8), binaryImage=True)
        centroid_px = np.array([m["m10"] / m["m00"], m["m01"] / m["m00"]]) + origin_px
        return self.pixel_to_plane(centroid_px, height_cm)

    def locate_object(
        self,
        mask: np.ndarray,
        origin_px: tuple[int, int],
        radius_cm: float,
        height_cm: float,
        frame: np.ndarray | None = None,
    ) -> np.ndarray:
        """The table position (x, y) [cm] of an upright cylinder from its image region.

        Fits a circle to the far side of the region's outline cast onto the plane of the
        object's top (module docstring). A centre farther from the region's centroid (cast
        onto that plane) than the object could stand, ``3 r + 2 h``, or of a circle wider
        than :data:`RIM_WIDEST` times ``r``, is not believed: the outline's own pixels are
        fitted instead of its colour edges, and failing that the centroid is the answer.

        Args:
            mask: The region, a 0/1 (or 0/255) uint8 image of its bounding box.
            origin_px: The box's top-left pixel (x, y) in the frame.
            radius_cm: The object's radius [cm] (used when the arc is too short to fit).
            height_cm: The object's height [cm]: the plane of its top face.
            frame: The whole image the region was found in; if given, the outline is
                moved onto its colour edge to a fraction of a pixel (:func:`subpixel_edges`).
        """
        centroid = self._centroid_on_plane(mask, origin_px, height_cm)
        # the region's image, cast onto the top's plane, lies within the top's rim and its
        # walls' cast (under the height); a region of two touching objects adds one more
        # object across: a centre farther from its centroid is not this region's
        within_cm = 3 * radius_cm + 2 * height_cm
        outlines = [frame, None] if frame is not None else [None]
        for image in outlines:
            pts = self._outline_on_plane(mask, origin_px, height_cm, image)
            c, r = self._rim_fit(pts, centroid, radius_cm)
            if np.linalg.norm(c - centroid) <= within_cm and abs(r) <= RIM_WIDEST * radius_cm:
                return c
            # the outline moved onto colour edges that are not the rim (a region cut by
            # the arm's dark link: 23 cm off, simulated), or the arc fits no circle near,
            # or the arc is not the rim's (cut short by the arm's body, simulated)
        return np.asarray(centroid, dtype=float)

    def _rim_fit(
        self, pts: np.ndarray, c: np.ndarray, radius_cm: float
    ) -> tuple[np.ndarray, float]:
        """The circle fitted to the outline's far side from ``c``, refined: centre, radius.

        The radius is ``radius_cm`` where too little of the outline faces away to fit.
        """
        r = radius_cm
        for _ in range(4):
            chosen = self._far_side(pts, c, radius_cm)
            if len(chosen) < 6:
                break
            c_new, r_new = _fit_circle(chosen)
            if not np.all(np.isfinite(c_new)):
                break
            moved = float(np.linalg.norm(c_new - c))
            c, r = c_new, r_new
            if moved < 1e-6:
                break
        return np.asarray(c, dtype=float), float(r)

    def fit_top(
        self,
        mask: np.ndarray,
        origin_px: tuple[int, int],
        face: TopFace,
        height_cm: float,
        frame: np.ndarray | None = None,
    ) -> TopFit:
        """Where an upright object of a known top face stands, its turn, and the fit's rms.

        As :meth:`locate_object` for a disc, the far side of the region's outline cast
        onto the plane of the object's top is the top face's own rim. The face of the
        known size is fitted to it: a disc's centre, or a polygon's (a square, a
        triangle) centre and turn, from turns spread over one period of its symmetry, each
        fit from the region's centroid on the top's plane (the walls draw the centroid
        towards the camera's foot point, so more of the outline counts as the far side,
        not less) and again from the fit.

        Args:
            mask: The region, a 0/1 (or 0/255) uint8 image of its bounding box.
            origin_px: The box's top-left pixel (x, y) in the frame.
            face: The top face's outline around its centre.
            height_cm: The object's height [cm]: the plane of its top face.
            frame: The whole image, for the sub-pixel outline.

        Returns:
            The top's centre, the far side's rms distance from the fitted face (∞ when too
            little of the outline faces away to fit) and a polygon's turn (:class:`TopFit`).
        """
        c = self._centroid_on_plane(mask, origin_px, height_cm)
        pts = self._outline_on_plane(mask, origin_px, height_cm, frame)
        outline = pts.astype(np.float32).reshape(-1, 1, 2)
        rms, yaw = math.inf, None
        for _ in range(3):  # the far side is judged from the centre: again from the fit
            chosen = self._far_side(pts, c, face.radius_cm)
            if len(chosen) < 6:
                break
            if face.corners_cm is None:
                fitted, rms = _fit_disc(chosen, face.radius_cm, c)
            else:
                fitted, turn, rms = self._fit_face(chosen, outline, face, c)
            if not np.all(np.isfinite(fitted)):
                break
            if face.corners_cm is not None:
                yaw = math.degrees(turn) % face.symmetry_deg
            moved = float(np.linalg.norm(fitted - c))
            c = fitted
            if moved < 1e-6:
                break
        return TopFit(np.asarray(c, dtype=float), rms, yaw)

    @staticmethod
    def _fit_face(
        chosen: np.ndarray, outline: np.ndarray, face: TopFace, c: np.ndarray
    ) -> tuple[np.ndarray, float, float]:
        """The polygon's best fit to the far side's points, over its starting turns.

        Returns its centre, its turn [rad] and its score (the rms, plus how far a corner
        lies outside). The top face lies within the region's outline: a fit from beyond
        the far side's edges (their mirror image) is taken only if no fit lies within.
        """
        corners = np.asarray(face.corners_cm, dtype=float)
        period = math.radians(face.symmetry_deg)
        best: tuple[tuple[float, float], np.ndarray, float] | None = None
        for k in range(POLYGON_TURNS):
            centre, yaw, rms = _fit_polygon(chosen, corners, c, k * period / POLYGON_TURNS)
            if not np.all(np.isfinite(centre)):
                continue
            cos, sin = math.cos(yaw), math.sin(yaw)
            placed = corners @ np.array([[cos, sin], [-sin, cos]]) + centre
            outside = max(
                -cv2.pointPolygonTest(outline, (float(x), float(y)), measureDist=True)
                for x, y in placed
            )
            key = (max(outside - POLYGON_OUTSIDE_CM, 0.0), rms)
            if best is None or key < best[0]:
                best = (key, centre, yaw)
        if best is None:
            return np.full(2, np.nan), math.nan, math.inf
        return best[1], best[2], best[0][1] + best[0][0]


def solve_pose(
    intrinsics: Intrinsics,
    pixels_px: npt.ArrayLike,
    points_cm: npt.ArrayLike,
    **meta: Any,
) -> Extrinsics:
    """The camera's pose from base-frame points (N ≥ 4, (N, 3) [cm]) and their pixels.

    The pixels are undistorted first; the pose is IPPE's for points on one plane (the
    table), refined by Levenberg–Marquardt on all of them. Of the poses that fit, the
    best one with the camera above the table and every point in front of it is kept.

    Raises:
        CalibrationError: fewer than 4 points, or no pose puts the points in front of
            the camera.
    """
    px = np.asarray(pixels_px, dtype=float).reshape(-1, 2)
    pts = np.asarray(points_cm, dtype=float).reshape(-1, 3)
    if len(px) != len(pts) or len(px) < 4:
        raise CalibrationError(
            f"a camera pose needs at least 4 point pairs, got {len(px)} pixels and "
            f"{len(pts)} points"
        )
    candidates = _pose_candidates(intrinsics, pts, px)
    if not candidates:
        raise CalibrationError("no camera pose fits these points: check the marker positions")
    best = min(candidates, key=lambda c: c[0])
    valid = [c for c in candidates if _in_front_and_above(pts, c[1], c[2])]
    # A mirror image of the markers is fitted only by a camera under the table.
    if not valid or min(c[0] for c in valid) > 2.0 * best[0] + _MIRROR_MARGIN:
        raise CalibrationError(
            "the fitted pose puts the camera below the table or points behind it: the "
            "marker positions do not "
            "match the image (swapped ids or mirrored x/y?)"
        )
    rms, rvec, tvec = min(valid, key=lambda c: c[0])
    meta.setdefault("camera_id", intrinsics.camera_id)
    meta.setdefault("size_px", intrinsics.size_px)
    return Extrinsics.from_rvec_tvec(rvec, tvec, rms_px=rms, **meta)


# Frames the points are handed to IPPE in: the base frame and two half-turns of it.
# OpenCV's IPPE returns a rotation vector from a formula that divides by sin(angle), so
# a camera whose rotation from the frame is a half-turn (every camera looking straight
# down at the table) comes back as garbage. Two half-turns about perpendicular axes
# cannot both leave a half-turn for a camera above the table, so one frame is sound.
_IPPE_FRAMES = (np.eye(3), np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]))
# How much (px) a pose under the table may fit better before the markers are called mirrored.
_MIRROR_MARGIN = 0.5
_LM_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)


def _pose_candidates(
    intrinsics: Intrinsics, pts: np.ndarray, px: np.ndarray
) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """Every pose that may fit, refined by Levenberg–Marquardt: (rms [px], rvec, tvec).

    For points on one plane, both of IPPE's poses in each of :data:`_IPPE_FRAMES` (the
    plane's pose is ambiguous, and the frames work around OpenCV's half-turn); else
    the iterative solver's one.
    """
    xn = intrinsics.undistort(px)
    eye, nodist = np.eye(3), np.zeros(5)
    raw: list[tuple[np.ndarray, np.ndarray]] = []
    if np.ptp(pts[:, 2]) < 1e-9:
        for frame in _IPPE_FRAMES:
            # p = frame @ q, so the camera's rotation of q is R @ frame
            q = np.ascontiguousarray(pts @ frame)
            _, rvecs, tvecs, _ = cv2.solvePnPGeneric(q, xn, eye, nodist, flags=cv2.SOLVEPNP_IPPE)
            for r, t in zip(rvecs, tvecs, strict=True):
                if np.all(np.isfinite(r)) and np.all(np.isfinite(t)):
                    rot, _ = cv2.Rodrigues(np.asarray(r, dtype=float).reshape(3, 1))
                    rvec, _ = cv2.Rodrigues(rot @ frame.T)
                    raw.append((rvec, np.asarray(t, dtype=float).reshape(3, 1)))
    else:
        ok, r, t = cv2.solvePnP(pts, xn, eye, nodist, flags=cv2.SOLVEPNP_ITERATIVE)
        if ok:
            raw.append((r, t))
    out = []
    for rvec, tvec in raw:
        rvec, tvec = cv2.solvePnPRefineLM(pts, xn, eye, nodist, rvec, tvec, _LM_CRITERIA)
        if not (np.all(np.isfinite(rvec)) and np.all(np.isfinite(tvec))):
            continue
        proj, _ = cv2.projectPoints(
            pts, rvec, tvec, intrinsics.camera_matrix, intrinsics.distortion
        )
        rms = float(np.sqrt(np.mean(np.sum((proj.reshape(-1, 2) - px) ** 2, axis=1))))
        if math.isfinite(rms):
            out.append((rms, rvec, tvec))
    return out


def _in_front_and_above(pts: np.ndarray, rvec: np.ndarray, tvec: np.ndarray) -> bool:
    """Whether the pose sees every point in front of it from above the table (z > 0)."""
    rot, _ = cv2.Rodrigues(rvec)
    depth = pts @ rot[2] + float(np.ravel(tvec)[2])
    centre_z = float((-rot.T @ np.ravel(tvec))[2])
    return bool(np.all(depth > 0) and centre_z > 0)
