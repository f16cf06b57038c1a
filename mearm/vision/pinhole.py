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

**Files.** Each calibration is its own YAML file (not a config section), versioned:
``format: mearm-camera-calibration``, ``version: 1``, ``kind: intrinsics | extrinsics``,
the camera's id, the frame size and the date, its numbers and its quality (``rms_px``,
the RMS reprojection error). :func:`save_calibration` never replaces a file holding a
better calibration of the same camera (lower ``rms_px``), a different camera's or
resolution's, or anything that is not a calibration, unless forced; a replaced file is
kept beside the new one as ``<name>.bak``.
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, NamedTuple

import cv2
import numpy as np
import numpy.typing as npt
import yaml

from mearm.config.base import short_repr
from mearm.config.errors import CalibrationError
from mearm.errors import ConfigError
from mearm.fileio import write_atomic
from mearm.yamlio import load_yaml_file

FORMAT = "mearm-camera-calibration"
VERSION = 1
Kind = Literal["intrinsics", "extrinsics"]

#: Largest focal length or principal-point coordinate [px] (an image side is ≤ 4096 px).
MAX_PIXELS = 1e5
#: Largest distortion coefficient magnitude (webcams: |k1| < 1).
MAX_DISTORTION = 100.0
#: Largest distance of the camera from the base [cm].
MAX_CAMERA_DISTANCE_CM = 1000.0
#: Outline points on the far side of an object used for the top disc's circle: within
#: this angle of the direction away from the camera's foot point [deg]. The top disc's
#: rim owns at least ±90° of the outline (the base disc, cast onto the top's plane, is
#: smaller and nearer the foot point, so the hull's straight sides touch the top circle
#: beyond ±90°). On the twin's renders 89° gives a third less error than 80° (more of
#: the rim) and 60° twice as much.
FAR_ARC_DEG = 89.0
#: Starting turns of the polygon fit, spread over one period of its symmetry [-].
POLYGON_TURNS = 3
#: A fitted polygon's corner may lie this far outside the region's outline [cm] (the
#: outline's pixels and the corner's own rounding); farther, the fit is the far edges'
#: mirror image.
POLYGON_OUTSIDE_CM = 0.05
#: Undistortion iterations and tolerance (OpenCV's default 5 iterations leave up to
#: 0.1 px at a webcam's corners).
_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-12)
#: Sub-pixel bits of the silhouettes' anti-aliased fill (1/16 px).
_SUBPIXEL_BITS = 4
_SUBPIXEL = 1 << _SUBPIXEL_BITS
#: The silhouette fit: its box's margin [px], iterations and derivative step [cm].
_FIT_PAD_PX = 3
_FIT_ITERATIONS = 20
_FIT_STEP_CM = 0.01


def _matrix(name: str, value: Any, shape: tuple[int, ...], limit: float) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise CalibrationError(f"{name} must be numbers, got {short_repr(value)}") from None
    if arr.shape != shape:
        raise CalibrationError(f"{name} must have shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)) or np.abs(arr).max(initial=0.0) > limit:
        raise CalibrationError(
            f"{name} must be finite numbers within ±{limit:g}, got {short_repr(arr.tolist())}"
        )
    arr.setflags(write=False)
    return arr


def _whole(name: str, value: Any, lo: int, hi: int) -> int:
    """A whole number read from a file, in [lo, hi].

    ``.inf``, NaN, 1.5, text and ``true`` are named, not converted (``int(.inf)`` raised
    OverflowError, ``int(1.5)`` gave 1).
    """
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise CalibrationError(
            f"{name} must be a whole number in {lo} … {hi}, got {short_repr(value)}"
        )
    if not (math.isfinite(value) and float(value).is_integer() and lo <= value <= hi):
        raise CalibrationError(
            f"{name} must be a whole number in {lo} … {hi}, got {short_repr(value)}"
        )
    return int(value)


#: Most board views or markers a calibration records having been fitted to.
MAX_FIT_COUNT = 1_000_000


def _size_px(value: Any) -> tuple[int, int]:
    """A frame size (width, height), each side a whole number in 1 … 65535 px."""
    if not isinstance(value, list | tuple) or len(value) != 2:
        raise CalibrationError(f"resolution must be [width, height] px, got {short_repr(value)}")
    w, h = (_whole("resolution", v, 1, 65535) for v in value)
    return w, h


def _rms(value: Any) -> float:
    """An RMS reprojection error in 0 … 1000 px."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise CalibrationError(f"rms_px must be a number in 0 … 1000 px, got {short_repr(value)}")
    if not (math.isfinite(value) and 0 <= value <= 1e3):
        raise CalibrationError(f"rms_px must be in 0 … 1000 px, got {short_repr(value)}")
    return float(value)


def today() -> str:
    """Now, as the ISO 8601 timestamp calibration files record (UTC, seconds)."""
    return datetime.datetime.now(datetime.UTC).replace(microsecond=0).isoformat()


@dataclass(frozen=True)
class Intrinsics:
    """The camera matrix and lens distortion of one camera at one resolution.

    Attributes:
        camera_matrix: *K* = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] [px], (3, 3).
        distortion: OpenCV's (k1, k2, p1, p2, k3), (5,).
        size_px: The frame size it holds for (width, height) [px].
        rms_px: RMS reprojection error of the board corners [px].
        views: How many board views it was fitted from.
        camera_id: Which camera (a device path, a serial number, ``twin``).
        date: When it was made (ISO 8601).
    """

    camera_matrix: np.ndarray
    distortion: np.ndarray
    size_px: tuple[int, int]
    rms_px: float
    views: int = 0
    camera_id: str = "camera"
    date: str = field(default_factory=today)

    kind = "intrinsics"

    def __post_init__(self) -> None:
        K = _matrix("camera_matrix", self.camera_matrix, (3, 3), MAX_PIXELS)
        if K[0, 0] <= 0 or K[1, 1] <= 0 or K[2, 2] != 1 or K[1, 0] or K[2, 0] or K[2, 1]:
            raise CalibrationError(
                "camera_matrix must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0, "
                f"got {short_repr(K.tolist())}"
            )
        dist = _matrix("distortion", self.distortion, (5,), MAX_DISTORTION)
        w, h = _size_px(self.size_px)
        _rms(self.rms_px)
        object.__setattr__(self, "views", _whole("views", self.views, 0, MAX_FIT_COUNT))
        object.__setattr__(self, "camera_matrix", K)
        object.__setattr__(self, "distortion", dist)
        object.__setattr__(self, "size_px", (w, h))

    def to_dict(self) -> dict[str, Any]:
        """The file's fields (the header is added by :func:`save_calibration`)."""
        return {
            "camera_matrix": [[float(v) for v in row] for row in self.camera_matrix],
            "distortion": [float(v) for v in self.distortion],
            "rms_px": float(self.rms_px),
            "views": int(self.views),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], header: Mapping[str, Any]) -> Intrinsics:
        """Read the fields :meth:`to_dict` writes (``header``: id, size, date)."""
        return cls(
            camera_matrix=data["camera_matrix"],
            distortion=data["distortion"],
            size_px=header["resolution"],
            rms_px=data["rms_px"],
            views=data.get("views", 0),
            camera_id=str(header["camera_id"]),
            date=str(header["date"]),
        )

    def undistort(self, pixels_px: npt.ArrayLike) -> np.ndarray:
        """Normalised image coordinates (x/z, y/z) of pixels, (N, 2) → (N, 2)."""
        px = np.asarray(pixels_px, dtype=np.float64).reshape(-1, 1, 2)
        out = cv2.undistortPoints(
            px, self.camera_matrix, self.distortion, None, None, None, _UNDISTORT_CRITERIA
        )
        return out.reshape(-1, 2)


@dataclass(frozen=True)
class Extrinsics:
    """The camera's pose in the robot base frame.

    Attributes:
        rotation: Camera → base rotation *R*, (3, 3) (columns: the camera's x right,
            y down, z forward axes in the base frame).
        position_cm: The camera's optical centre in the base frame [cm], (3,).
        rms_px: RMS reprojection error of the marker corners it was fitted to [px].
        markers: How many markers it was fitted to.
        camera_id: Which camera.
        size_px: The frame size of the intrinsics it was fitted with.
        date: When it was made (ISO 8601).
        refined_by_arm: Whether the arm's check (:mod:`mearm.task.armcheck`) refined it.
    """

    rotation: np.ndarray
    position_cm: np.ndarray
    rms_px: float
    markers: int = 0
    camera_id: str = "camera"
    size_px: tuple[int, int] = (640, 480)
    date: str = field(default_factory=today)
    refined_by_arm: bool = False

    kind = "extrinsics"

    def __post_init__(self) -> None:
        R = _matrix("rotation", self.rotation, (3, 3), 1.0 + 1e-6)
        if np.abs(R @ R.T - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0:
            raise CalibrationError("rotation must be a rotation matrix (orthonormal, det +1)")
        C = _matrix("position_cm", self.position_cm, (3,), MAX_CAMERA_DISTANCE_CM)
        _rms(self.rms_px)
        object.__setattr__(self, "markers", _whole("markers", self.markers, 0, MAX_FIT_COUNT))
        object.__setattr__(self, "rotation", R)
        object.__setattr__(self, "position_cm", C)
        object.__setattr__(self, "size_px", _size_px(self.size_px))

    @classmethod
    def from_rvec_tvec(cls, rvec: npt.ArrayLike, tvec: npt.ArrayLike, **kw: Any) -> Extrinsics:
        """From OpenCV's pose of the base frame in the camera (solvePnP's rvec, tvec [cm])."""
        R_cam_base, _ = cv2.Rodrigues(np.asarray(rvec, dtype=float).reshape(3, 1))
        t = np.asarray(tvec, dtype=float).reshape(3)
        R = R_cam_base.T
        return cls(rotation=R, position_cm=-R @ t, **kw)

    def rvec_tvec(self) -> tuple[np.ndarray, np.ndarray]:
        """OpenCV's (rvec, tvec [cm]) of the base frame in the camera, for projectPoints."""
        R_cam_base = self.rotation.T
        rvec, _ = cv2.Rodrigues(R_cam_base)
        return rvec.reshape(3), -R_cam_base @ self.position_cm

    def to_dict(self) -> dict[str, Any]:
        """The file's fields (the header is added by :func:`save_calibration`)."""
        return {
            "rotation": [[float(v) for v in row] for row in self.rotation],
            "position_cm": [float(v) for v in self.position_cm],
            "rms_px": float(self.rms_px),
            "markers": int(self.markers),
            "refined_by_arm": bool(self.refined_by_arm),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], header: Mapping[str, Any]) -> Extrinsics:
        """Read the fields :meth:`to_dict` writes (``header``: id, size, date)."""
        return cls(
            rotation=data["rotation"],
            position_cm=data["position_cm"],
            rms_px=data["rms_px"],
            markers=data.get("markers", 0),
            camera_id=str(header["camera_id"]),
            size_px=header["resolution"],
            date=str(header["date"]),
            refined_by_arm=bool(data.get("refined_by_arm", False)),
        )


CalibrationFile = Intrinsics | Extrinsics
_KINDS: dict[str, type[Intrinsics] | type[Extrinsics]] = {
    "intrinsics": Intrinsics,
    "extrinsics": Extrinsics,
}


def calibration_text(cal: CalibrationFile) -> str:
    """The YAML text of a calibration file."""
    header = {
        "format": FORMAT,
        "version": VERSION,
        "kind": cal.kind,
        "camera_id": cal.camera_id,
        "resolution": list(cal.size_px),
        "date": cal.date,
    }
    body = yaml.safe_dump(cal.to_dict(), sort_keys=False, default_flow_style=None, width=100)
    head = yaml.safe_dump(header, sort_keys=False, default_flow_style=None)
    return f"# mearm camera calibration ({cal.kind}); written by mearm, do not edit\n{head}{body}"


def load_calibration(path: str | Path, kind: Kind | None = None) -> CalibrationFile:
    """Read a calibration file.

    Args:
        path: The file.
        kind: The kind it must be; ``None``: either.

    Raises:
        CalibrationError: the file is missing, not YAML, not a mearm camera calibration,
            of a newer version, of the wrong kind, or its numbers are out of range; the
            message names the file and the field.
    """
    try:
        data = load_yaml_file(path, what="calibration")
    except ConfigError as exc:
        raise CalibrationError(str(exc)) from None
    where = str(path)
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise CalibrationError(f"{where}: not a mearm camera calibration (format: {FORMAT})")
    version = data.get("version")
    if version != VERSION:
        raise CalibrationError(
            f"{where}: calibration file version {short_repr(version)}; this mearm reads "
            f"version {VERSION}"
        )
    found = data.get("kind")
    if found not in _KINDS:
        raise CalibrationError(f"{where}: kind must be intrinsics or extrinsics, got {found!r}")
    if kind is not None and found != kind:
        raise CalibrationError(f"{where}: holds {found}, but {kind} are needed here")
    try:
        return _KINDS[found].from_dict(data, data)
    except KeyError as exc:
        raise CalibrationError(f"{where}: missing field {exc.args[0]!r}") from None
    except (TypeError, ValueError, OverflowError) as exc:
        raise CalibrationError(f"{where}: {exc}") from None
    except CalibrationError as exc:
        raise CalibrationError(f"{where}: {exc.reason}") from None


def save_calibration(path: str | Path, cal: CalibrationFile, *, force: bool = False) -> Path:
    """Write ``cal`` to ``path`` unless that would lose a better calibration.

    Without ``force`` an existing file is replaced only when it holds a calibration of
    the same kind, camera and frame size whose ``rms_px`` is no lower than the new
    one's. A replaced file is kept as ``<path>.bak``. The write is atomic.

    Returns:
        The path written.

    Raises:
        CalibrationError: the existing file is better, of another camera, kind or
            resolution, or not a calibration file, and ``force`` is not set.
    """
    target = Path(path)
    if target.exists():
        old_text = target.read_bytes() if target.is_file() else None
        if not force:
            _check_replace(target, cal)
        if old_text is not None:
            write_atomic(target.with_name(target.name + ".bak"), old_text)
    return write_atomic(target, calibration_text(cal))


def _check_replace(target: Path, cal: CalibrationFile) -> None:
    try:
        old = load_calibration(target)
    except CalibrationError as exc:
        raise CalibrationError(
            f"{target} exists and is not a readable camera calibration ({exc.reason}): "
            "pass --force to replace it"
        ) from None
    if old.kind != cal.kind or old.camera_id != cal.camera_id or old.size_px != cal.size_px:
        raise CalibrationError(
            f"{target} holds the {old.kind} of camera {old.camera_id!r} at "
            f"{old.size_px[0]}x{old.size_px[1]} px; the new one is the {cal.kind} of "
            f"{cal.camera_id!r} at {cal.size_px[0]}x{cal.size_px[1]} px: pass --force to "
            "replace it, or write elsewhere"
        )
    if cal.rms_px > old.rms_px:
        raise CalibrationError(
            f"{target} holds a better calibration (rms {old.rms_px:.3f} px, {old.date}) than "
            f"the new one (rms {cal.rms_px:.3f} px): kept; pass --force to replace it"
        )


def _outward_normals(outline: np.ndarray, k: int = 3) -> np.ndarray:
    """Unit normals (N, 2) of a closed pixel outline (N, 2), pointing out of the region.

    The tangent at each point is the chord between its k-th neighbours either side; the
    normal's sign is chosen to point away from the outline's mean.
    """
    tangent = np.roll(outline, -k, axis=0) - np.roll(outline, k, axis=0)
    normal = np.column_stack([tangent[:, 1], -tangent[:, 0]])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = normal / np.where(length < 1e-12, 1.0, length)
    outward = np.sum(normal * (outline - outline.mean(axis=0)), axis=1) >= 0
    return np.where(outward[:, None], normal, -normal)


def subpixel_edges(frame: np.ndarray, outline: np.ndarray) -> np.ndarray:
    """The outline of a region moved onto the image's colour edge, to a fraction of a pixel.

    A mask's outline runs through the centres of its border pixels, up to a pixel from
    the true edge and in steps of whole pixels. Along each point's outward normal the
    frame is sampled (bilinear) from 3 px inside to 3 px outside; each sample's colour is
    scored between the local inside colour (mean of the samples 1–1.5 px inside) and the
    local outside colour (2.5–3 px outside), 1 to 0, and the edge is where the score
    crosses one half (linear interpolation between samples). A point whose profile has
    too little contrast (under 12 levels) or no crossing near the outline keeps its pixel
    position plus half a pixel outward, where a binary mask's edge lies on average.

    Under a lamp (measured on the twin's renders, ``mearm camera-accuracy`` with
    ``twin.lamp``) two choices matter. Colours are compared by their *chroma*, each
    sample less the mean of its channels: a shadow scales a colour and a specular
    highlight adds white to it, which leaves the chroma's direction, so a dark shadow
    just beyond the rim no longer scores as the object (in B, G, R a dark pixel lies
    nearer a saturated green than the lit table does: the rim came out a pixel outwards,
    0.1 cm for 1 cm objects). And the inside colour is the rim's own, 1–1.5 px in, not
    the face's 3 px in: a shadow falling across the rim (a bin's) darkens the rim against
    the lit middle of the face, and the half-way point then lay on the shadow's edge
    on the face.

    Args:
        frame: The image (H, W, 3) uint8 (or (H, W)).
        outline: Outline points (N, 2) [px], ordered along the closed outline.

    Returns:
        The refined points (N, 2) [px].
    """
    pts = np.asarray(outline, dtype=float)
    if len(pts) < 7:
        return pts
    normals = _outward_normals(pts)
    steps = np.arange(-3.0, 3.0001, 0.25)
    xy = pts[:, None, :] + steps[None, :, None] * normals[:, None, :]
    samples = cv2.remap(
        frame,
        xy[..., 0].astype(np.float32),
        xy[..., 1].astype(np.float32),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_REPLICATE,
    ).astype(float)
    if samples.ndim == 2:
        samples = samples[..., None]
    else:  # chroma: a shadow or a highlight moves a colour along (1, 1, 1), not across it
        samples = samples - samples.mean(axis=2, keepdims=True)
    inner = samples[:, 6:9].mean(axis=1)  # t ∈ [-1.5, -1]: the rim's own colour
    outer = samples[:, -3:].mean(axis=1)  # t ∈ [2.5, 3]
    d = inner - outer
    dd = np.sum(d * d, axis=1)
    score = np.einsum("nkc,nc->nk", samples - outer[:, None, :], d) / np.maximum(dd, 1e-9)[:, None]
    above = score >= 0.5
    # the crossing nearest the pixel outline's own edge (t = +0.5) from inside to outside
    cross = above[:, :-1] & ~above[:, 1:]
    t_mid = (steps[:-1] + steps[1:]) / 2.0
    dist = np.where(cross, np.abs(t_mid - 0.5)[None, :], np.inf)
    j = np.argmin(dist, axis=1)
    n = np.arange(len(pts))
    ok = np.isfinite(dist[n, j]) & (np.sqrt(dd) >= 12.0)
    s0, s1 = score[n, j], score[n, j + 1]
    frac = np.clip((s0 - 0.5) / np.where(s0 - s1 == 0, 1.0, s0 - s1), 0.0, 1.0)
    t = np.where(ok, steps[j] + frac * (steps[1] - steps[0]), 0.5)
    return pts + t[:, None] * normals


def _fit_circle(pts: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares circle through points (N ≥ 3, (N, 2)): centre, radius.

    The algebraic (Kåsa) fit, refined by Gauss–Newton on the geometric distances.
    """
    A = np.column_stack([2 * pts, np.ones(len(pts))])
    b = np.sum(pts**2, axis=1)
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    c = sol[:2]
    r = math.sqrt(max(sol[2] + c @ c, 1e-18))
    for _ in range(10):
        d = pts - c
        dist = np.linalg.norm(d, axis=1)
        dist = np.where(dist < 1e-12, 1e-12, dist)
        J = np.column_stack([-d / dist[:, None], -np.ones(len(pts))])
        res = dist - r
        step, *_ = np.linalg.lstsq(J, -res, rcond=None)
        c = c + step[:2]
        r = r + step[2]
        if np.abs(step).max() < 1e-10:
            break
    return c, float(r)


@dataclass(frozen=True)
class TopFace:
    """An upright object's top face seen from above, around its centre [cm].

    Attributes:
        radius_cm: A disc's radius; a polygon's farthest corner from its centre.
        corners_cm: A polygon's corners at no turn, (K, 2); ``None``: a disc.
        symmetry_deg: A polygon looks the same turned by this [deg].
    """

    radius_cm: float
    corners_cm: np.ndarray | None = None
    symmetry_deg: float = 0.0


class TopFit(NamedTuple):
    """An upright object's top face fitted to its outline (:meth:`PerspectiveCamera.fit_top`).

    Attributes:
        centre_cm: Where the object stands, base frame (x, y) [cm], (2,).
        rms_cm: The far side's rms distance from the fitted face [cm] (∞: no fit).
        yaw_deg: A polygon's turn on the table, from the base frame's x axis towards y,
            modulo its symmetry [deg]; ``None`` for a disc or when no fit was made.
    """

    centre_cm: np.ndarray
    rms_cm: float
    yaw_deg: float | None


def _fit_disc(pts: np.ndarray, radius: float, centre: np.ndarray) -> tuple[np.ndarray, float]:
    """The centre of a circle of ``radius`` nearest ``pts`` (Gauss–Newton): centre, rms."""
    c = np.asarray(centre, dtype=float).copy()
    for _ in range(10):
        d = pts - c
        dist = np.maximum(np.linalg.norm(d, axis=1), 1e-12)
        step, *_ = np.linalg.lstsq(-d / dist[:, None], radius - dist, rcond=None)
        c = c + step
        if np.abs(step).max() < 1e-7:
            break
    res = np.linalg.norm(pts - c, axis=1) - radius
    return c, float(math.sqrt(np.mean(res**2)))


def _nearest_on_sides(pts: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Each point's nearest point on the sides of a closed polygon, (N, 2)."""
    a = corners
    ab = np.concatenate([corners[1:], corners[:1]]) - a  # (K, 2)
    ap = pts[:, None, :] - a[None]  # (N, K, 2)
    t = np.clip(np.einsum("nkd,kd->nk", ap, ab) / np.einsum("kd,kd->k", ab, ab), 0.0, 1.0)
    near = a[None] + t[..., None] * ab[None]  # (N, K, 2)
    d2 = np.einsum("nkd,nkd->nk", pts[:, None, :] - near, pts[:, None, :] - near)
    return near[np.arange(len(pts)), np.argmin(d2, axis=1)]


def _fit_polygon(
    pts: np.ndarray, corners: np.ndarray, centre: np.ndarray, yaw0: float
) -> tuple[np.ndarray, float, float]:
    """The pose of a rigid polygon whose sides pass nearest ``pts``: centre, yaw, rms.

    ``corners`` (K, 2) are around its centre at yaw 0; Gauss–Newton on the points'
    distances to their nearest points of the sides (``q``: d|p − q|/dc = −u and
    d|p − q|/dψ = −u · ⊥(q − c), u the unit vector from q to p), step halved while the
    sum of squares does not fall, from ``centre`` and ``yaw0`` [rad].
    """

    def placed(x: np.ndarray) -> np.ndarray:
        c, s = math.cos(x[2]), math.sin(x[2])
        return corners @ np.array([[c, s], [-s, c]]) + x[:2]

    def evaluate(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q = _nearest_on_sides(pts, placed(x))
        return q, np.linalg.norm(pts - q, axis=1)

    x = np.array([centre[0], centre[1], yaw0], dtype=float)
    q, res = evaluate(x)
    for _ in range(30):
        u = (pts - q) / np.maximum(res, 1e-12)[:, None]
        r = q - x[:2]
        J = np.column_stack([-u, -(u[:, 0] * -r[:, 1] + u[:, 1] * r[:, 0])])
        step, *_ = np.linalg.lstsq(J, -res, rcond=None)
        for _ in range(10):
            q_new, trial = evaluate(x + step)
            if float(trial @ trial) <= float(res @ res):
                break
            step = step / 2
        else:
            break
        x, q, res = x + step, q_new, trial
        if np.abs(step).max() < 1e-8:
            break
    return x[:2], float(x[2]), float(math.sqrt(np.mean(res**2)))


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
        # pixels wrong by more than a pixel's blur: a top's pixel (over half covered) with
        # no mask pixel within one pixel, or a mask pixel with no silhouette pixel within
        # one (a mask's edge wanders by up to a pixel with the colour thresholds)
        at = p.reshape(-1, 2)
        hull = self.silhouette_coverage(at, radius_cm, height_cm, origin, region.shape)
        tops = self.silhouette_coverage(
            at, radius_cm, height_cm, origin, region.shape, top_only=True
        )
        near = np.ones((3, 3), np.uint8)
        seen = region.astype(np.uint8)
        seen_near = cv2.dilate(seen, near).view(bool)
        hull_near = cv2.dilate((hull > 0.5).astype(np.uint8), near).view(bool)
        bad = np.count_nonzero((tops > 0.5) & ~seen_near) + np.count_nonzero(
            seen.view(bool) & ~hull_near
        )
        return at, bad / max(float(region.sum()), 1.0)

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
        object's top (module docstring).

        Args:
            mask: The region, a 0/1 (or 0/255) uint8 image of its bounding box.
            origin_px: The box's top-left pixel (x, y) in the frame.
            radius_cm: The object's radius [cm] (used when the arc is too short to fit).
            height_cm: The object's height [cm]: the plane of its top face.
            frame: The whole image the region was found in; if given, the outline is
                moved onto its colour edge to a fraction of a pixel (:func:`subpixel_edges`).
        """
        pts = self._outline_on_plane(mask, origin_px, height_cm, frame)
        c = self._centroid_on_plane(mask, origin_px, height_cm)
        for _ in range(4):
            chosen = self._far_side(pts, c, radius_cm)
            if len(chosen) < 6:
                break
            c_new, _ = _fit_circle(chosen)
            if not np.all(np.isfinite(c_new)):
                break
            moved = float(np.linalg.norm(c_new - c))
            c = c_new
            if moved < 1e-6:
                break
        return np.asarray(c, dtype=float)

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
                -cv2.pointPolygonTest(outline, (float(x), float(y)), True) for x, y in placed
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
    table), refined by Levenberg–Marquardt on all of them.

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
    xn = intrinsics.undistort(px)
    eye, nodist = np.eye(3), np.zeros(5)
    flat = bool(np.ptp(pts[:, 2]) < 1e-9)
    method = cv2.SOLVEPNP_IPPE if flat else cv2.SOLVEPNP_ITERATIVE
    ok, rvec, tvec = cv2.solvePnP(pts, xn, eye, nodist, flags=method)
    if not ok:
        raise CalibrationError("no camera pose fits these points: check the marker positions")
    rvec, tvec = cv2.solvePnPRefineLM(
        pts,
        xn,
        eye,
        nodist,
        rvec,
        tvec,
        (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12),
    )
    proj, _ = cv2.projectPoints(pts, rvec, tvec, intrinsics.camera_matrix, intrinsics.distortion)
    err = np.linalg.norm(proj.reshape(-1, 2) - px, axis=1)
    rms = float(np.sqrt(np.mean(err**2)))
    meta.setdefault("camera_id", intrinsics.camera_id)
    meta.setdefault("size_px", intrinsics.size_px)
    ext = Extrinsics.from_rvec_tvec(rvec, tvec, rms_px=rms, **meta)
    depth = (pts - ext.position_cm) @ ext.rotation[:, 2]
    if not np.all(depth > 0) or ext.position_cm[2] <= 0:
        raise CalibrationError(
            "the fitted pose puts the camera below the table or points behind it: the "
            "marker positions do not "
            "match the image (swapped ids or mirrored x/y?)"
        )
    return ext
