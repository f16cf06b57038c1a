"""One camera calibration file: the intrinsics or the extrinsics, versioned YAML.

Each calibration is its own YAML file (not a config section), versioned:
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
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import cv2
import numpy as np
import numpy.typing as npt
import yaml

from mearm.config.base import short_repr
from mearm.config.errors import CalibrationError
from mearm.errors import ConfigError
from mearm.fileio import keep_backup, write_atomic
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
#: Undistortion iterations and tolerance (OpenCV's default 5 iterations leave up to
#: 0.1 px at a webcam's corners).
_UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-12)


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
        raised_cm: The height of the raised view's support when it was fitted to markers
            there too [cm] (``None``: to the table's only); such a pose holds above the
            table, which a rotation fitted to one plane does not.
    """

    rotation: np.ndarray
    position_cm: np.ndarray
    rms_px: float
    markers: int = 0
    camera_id: str = "camera"
    size_px: tuple[int, int] = (640, 480)
    date: str = field(default_factory=today)
    refined_by_arm: bool = False
    raised_cm: float | None = None

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
        if self.raised_cm is not None:
            h = float(_matrix("raised_cm", [self.raised_cm], (1,), MAX_CAMERA_DISTANCE_CM)[0])
            if h <= 0:
                raise CalibrationError(f"raised_cm must be above the table, got {h:g}")
            object.__setattr__(self, "raised_cm", h)

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
        fields = {
            "rotation": [[float(v) for v in row] for row in self.rotation],
            "position_cm": [float(v) for v in self.position_cm],
            "rms_px": float(self.rms_px),
            "markers": int(self.markers),
            "refined_by_arm": bool(self.refined_by_arm),
        }
        if self.raised_cm is not None:  # absent from a table-only pose's file, as before
            fields["raised_cm"] = float(self.raised_cm)
        return fields

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
            raised_cm=data.get("raised_cm"),
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


def save_calibration(
    path: str | Path,
    cal: CalibrationFile,
    *,
    force: bool = False,
    on_backup: Callable[[Path], None] | None = None,
) -> Path:
    """Write ``cal`` to ``path`` unless that would lose a better calibration.

    Without ``force`` an existing file is replaced only when it holds a calibration of
    the same kind, camera and frame size whose ``rms_px`` is no lower than the new
    one's. A replaced file is kept first (:func:`~mearm.fileio.keep_backup`: as
    ``<path>.bak``, or ``<path>.bak.N`` beside an earlier backup, which it never
    replaces; not one that holds these bytes already), and ``on_backup`` is told where.
    The write is atomic.

    Returns:
        The path written.

    Raises:
        CalibrationError: the existing file is better, of another camera, kind or
            resolution, or not a calibration file, and ``force`` is not set.
        OSError: the backup or the file cannot be written.
    """
    target = Path(path)
    text = calibration_text(cal)
    if target.exists():
        if not force:
            _check_replace(target, cal)
        backup = keep_backup(target, text)
        if backup is not None and on_backup is not None:
            on_backup(backup)
    return write_atomic(target, text)


def _raised(cal: CalibrationFile) -> bool:
    return isinstance(cal, Extrinsics) and cal.raised_cm is not None


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
    if _raised(cal) and not _raised(old):
        return  # a pose that holds above the table beats a lower rms on the table alone
    if isinstance(old, Extrinsics) and old.raised_cm is not None and not _raised(cal):
        raise CalibrationError(
            f"{target} holds a pose fitted on the table and {old.raised_cm:g} cm above it "
            f"({old.date}), which holds above the table; the new one is fitted on the table "
            "only: kept; add the raised view (--raised-image), or pass --force to replace it"
        )
    if cal.rms_px > old.rms_px:
        raise CalibrationError(
            f"{target} holds a better calibration (rms {old.rms_px:.3f} px, {old.date}) than "
            f"the new one (rms {cal.rms_px:.3f} px): kept; pass --force to replace it"
        )
