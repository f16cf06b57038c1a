"""ChArUco boards for the camera's intrinsics: the board, its picture, its corners.

A ChArUco board is a chessboard whose white squares hold ArUco markers: the markers
name each chessboard corner, so a corner is found even when the board is partly out of
view or at a steep angle, and the chessboard corners (saddle points) are located to a
fraction of a pixel. Views of the board from many angles give the camera matrix and the
lens distortion (``cv2.calibrateCamera``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np
import numpy.typing as npt

from mearm.config.errors import CalibrationError
from mearm.vision.aruco import get_dictionary
from mearm.vision.errors import ImageError
from mearm.vision.pinhole import Intrinsics


@dataclass(frozen=True)
class BoardSpec:
    """A ChArUco board.

    Attributes:
        squares: Chessboard squares across and down (columns, rows).
        square_cm: Side of one chessboard square as printed [cm].
        marker_cm: Side of the ArUco marker inside a white square [cm].
        dictionary: ArUco dictionary of the markers (ids 0, 1, … in reading order).
    """

    squares: tuple[int, int] = (7, 5)
    square_cm: float = 3.0
    marker_cm: float = 2.2
    dictionary: str = "DICT_5X5_100"

    @property
    def size_cm(self) -> tuple[float, float]:
        """The board's printed width and height [cm]."""
        return (self.squares[0] * self.square_cm, self.squares[1] * self.square_cm)

    @property
    def corners(self) -> int:
        """Number of inner chessboard corners."""
        return (self.squares[0] - 1) * (self.squares[1] - 1)

    def board(self) -> cv2.aruco.CharucoBoard:
        """The OpenCV board (lengths in cm, so calibrated poses are in cm)."""
        return cv2.aruco.CharucoBoard(
            self.squares, self.square_cm, self.marker_cm, get_dictionary(self.dictionary)
        )


#: The board the project prints and calibrates with: 7 × 5 squares of 3 cm (21 × 15 cm,
#: fits on A4 with a margin), 2.2 cm markers of DICT_5X5_100 (not the table markers'
#: DICT_4X4_50, so a board and a sheet in one view are never confused).
DEFAULT_BOARD = BoardSpec()


def board_image(spec: BoardSpec = DEFAULT_BOARD, px_per_square: int = 100) -> np.ndarray:
    """The board as a grey uint8 image, ``px_per_square`` pixels to a square, no margin."""
    w, h = spec.squares
    return spec.board().generateImage((w * px_per_square, h * px_per_square), marginSize=0)


# ---------------------------------------------------------------------- detection

#: Half-side of the window ``cv2.cornerSubPix`` refines a corner in [px] (a 7 × 7 px
#: window), on the frame smoothed by a Gaussian of σ = ``SUBPIX_BLUR_PX``. On synthetic
#: views (σ = 2 grey-level noise, 18 views) this cuts OpenCV's own ChArUco corners'
#: calibration RMS from 0.07 px to 0.04 px; without the smoothing the refinement gains
#: little (0.07 px), and wider windows reach the markers on small or steep views.
SUBPIX_HALF_WINDOW_PX = 3
#: Smoothing before the sub-pixel refinement [px] (noise, not the corner, is averaged).
SUBPIX_BLUR_PX = 1.0
#: A refined corner that moved further than this from OpenCV's is kept where OpenCV put
#: it [px]: on a steep view the window can catch a marker's corner instead (seen: a
#: 2.9 px jump), while OpenCV's own corners are within 0.4 px of the truth.
SUBPIX_MAX_SHIFT_PX = 1.0
_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-5)


@lru_cache(maxsize=8)
def _detector(spec: BoardSpec) -> cv2.aruco.CharucoDetector:
    return cv2.aruco.CharucoDetector(spec.board())


def _grey(frame: npt.ArrayLike, source: str) -> np.ndarray:
    img = np.asarray(frame)
    if img.dtype != np.uint8 or not (img.ndim == 2 or (img.ndim == 3 and img.shape[2] in (1, 3))):
        raise ImageError(
            source,
            f"a frame must be 8-bit grey (H, W) or BGR (H, W, 3), got {img.dtype} "
            f"of shape {img.shape}",
        )
    if img.ndim == 3:
        img = img[:, :, 0] if img.shape[2] == 1 else cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    return np.ascontiguousarray(img)


def detect_board(
    frame: npt.ArrayLike, spec: BoardSpec = DEFAULT_BOARD
) -> tuple[np.ndarray, np.ndarray]:
    """The board's inner corners seen in a frame, refined to a fraction of a pixel.

    Args:
        frame: An 8-bit grey (H, W) or BGR (H, W, 3) image.
        spec: The board to look for.

    Returns:
        ``(corners_px, ids)``: the corners' pixels (N, 2) and their ids (N,) (index into
        ``spec.board().getChessboardCorners()``); N = 0 when the board is not seen.

    Raises:
        ImageError: the frame is not an 8-bit grey or BGR image.
    """
    grey = _grey(frame, "frame")
    none = np.zeros((0, 2)), np.zeros(0, dtype=int)
    if min(grey.shape) < 2 * SUBPIX_HALF_WINDOW_PX + 5:
        return none
    corners, ids, _, _ = _detector(spec).detectBoard(grey)
    if ids is None or len(ids) == 0:
        return none
    found = corners.reshape(-1, 2).astype(np.float32)
    refined = cv2.cornerSubPix(
        cv2.GaussianBlur(grey, (0, 0), SUBPIX_BLUR_PX),
        found.reshape(-1, 1, 2).copy(),
        (SUBPIX_HALF_WINDOW_PX, SUBPIX_HALF_WINDOW_PX),
        (-1, -1),
        _SUBPIX_CRITERIA,
    ).reshape(-1, 2)
    jumped = np.linalg.norm(refined - found, axis=1) > SUBPIX_MAX_SHIFT_PX
    refined[jumped] = found[jumped]
    return refined.astype(float), ids.reshape(-1).astype(int)


@dataclass(frozen=True)
class BoardView:
    """The board's corners found in one frame.

    Attributes:
        name: The frame's name in messages (a file name, ``frame 3``).
        corners_px: Corner pixels (N, 2) [px].
        ids: Corner ids (N,).
    """

    name: str
    corners_px: np.ndarray
    ids: np.ndarray


# -------------------------------------------------------------------- calibration

#: Fewest views a calibration is fitted from: 9 unknowns of the camera (fx, fy, cx, cy,
#: five distortion coefficients) and 6 of each view's pose are pinned down well only by
#: several views at different tilts; OpenCV's docs advise 10 or more, 6 is the floor.
MIN_VIEWS = 6
#: Fewest corners a view must show to be used: 12 of the default board's 24, so a view
#: holds half the board and constrains its own 6 pose unknowns many times over.
MIN_CORNERS = 12
#: Smallest share of the frame the convex hull of all views' corners must cover [-]:
#: distortion grows towards the edges, and a fit that never saw them extrapolates there.
MIN_COVERAGE = 0.5
#: Largest acceptable final RMS reprojection error [px]: sharp corners of a flat,
#: printed board fit to 0.1 … 0.5 px; more means blur, a bent board or a wrong board.
MAX_RMS_PX = 1.0
#: A view whose RMS error exceeds this many times the median view's is an outlier
#: (motion blur, a bent sheet, a misdetected corner) and is dropped before one refit.
OUTLIER_FACTOR = 3.0
#: …and only when its RMS is also above this [px]: in a fit of 0.05 px views, a 0.15 px
#: view is good, not an outlier.
OUTLIER_FLOOR_PX = 0.3
#: Largest relative difference of fx and fy [-]: webcams have square pixels (fx = fy to
#: within a percent); 10 % means the views did not pin the focal length down.
MAX_ASPECT_DEVIATION = 0.1
_CALIB_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)


@dataclass(frozen=True)
class ViewFit:
    """How well one view fits the calibration.

    Attributes:
        name: The view's name.
        corners: Corners it contributed.
        rms_px: RMS reprojection error of its corners [px] (of the first fit for a
            dropped view).
        dropped: Whether it was dropped as an outlier.
    """

    name: str
    corners: int
    rms_px: float
    dropped: bool = False


@dataclass(frozen=True)
class CalibrationReport:
    """A fitted calibration and how it was reached.

    Attributes:
        intrinsics: The result.
        views: Every view with enough corners, in input order, with its error.
        skipped: Views with too few corners (or no board) to be used.
        coverage: Share of the frame inside the convex hull of the used corners [-].
    """

    intrinsics: Intrinsics
    views: tuple[ViewFit, ...]
    skipped: tuple[str, ...] = ()
    coverage: float = 0.0

    @property
    def dropped(self) -> tuple[str, ...]:
        """Names of the views dropped as outliers."""
        return tuple(v.name for v in self.views if v.dropped)

    def lines(self) -> list[str]:
        """A human-readable summary: error, per-view errors, K and distortion."""
        cal = self.intrinsics
        K, d = cal.camera_matrix, cal.distortion
        used = len(self.views) - len(self.dropped)
        out = [
            f"rms {cal.rms_px:.3f} px from {used} views "
            f"({sum(v.corners for v in self.views if not v.dropped)} corners), "
            f"corners cover {100 * self.coverage:.0f} % of the {cal.size_px[0]}x"
            f"{cal.size_px[1]} px frame",
        ]
        for v in self.views:
            note = "  dropped: outlier" if v.dropped else ""
            out.append(f"  {v.name}: {v.corners} corners, rms {v.rms_px:.3f} px{note}")
        if self.skipped:
            out.append(f"  skipped (too few corners): {', '.join(self.skipped)}")
        out += [
            f"camera matrix: fx {K[0, 0]:.2f}  fy {K[1, 1]:.2f}  cx {K[0, 2]:.2f}  "
            f"cy {K[1, 2]:.2f} px",
            "distortion k1 k2 p1 p2 k3: " + " ".join(f"{v:.5f}" for v in d),
        ]
        return out


def _coverage(points_px: np.ndarray, size_px: tuple[int, int]) -> tuple[float, list[str]]:
    """Hull share of the frame [-] and the frame quadrants without a corner."""
    w, h = size_px
    hull = cv2.convexHull(points_px.astype(np.float32))
    share = float(cv2.contourArea(hull)) / (w * h)
    right, below = points_px[:, 0] >= w / 2, points_px[:, 1] >= h / 2
    quadrants = {
        "top left": ~right & ~below,
        "top right": right & ~below,
        "bottom left": ~right & below,
        "bottom right": right & below,
    }
    return share, [q for q, m in quadrants.items() if not m.any()]


def _fit(
    obj: list[np.ndarray], img: list[np.ndarray], size_px: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``cv2.calibrateCamera``: K, distortion (5,), per-view RMS (V,)."""
    try:
        _, K, dist, rvecs, tvecs = cv2.calibrateCamera(
            obj, img, size_px, None, None, flags=0, criteria=_CALIB_CRITERIA
        )
    except cv2.error as exc:
        raise CalibrationError(
            f"the calibration fit failed ({' '.join(str(exc).split())[-120:]}): take views of "
            "the whole board from several angles"
        ) from None
    rms = np.empty(len(obj))
    for k, (o, i, r, t) in enumerate(zip(obj, img, rvecs, tvecs, strict=True)):
        proj, _ = cv2.projectPoints(o, r, t, K, dist)
        rms[k] = math.sqrt(float(np.mean(np.sum((proj - i) ** 2, axis=-1))))
    return K, dist.reshape(-1)[:5], rms


def _checked_coverage(points_px: np.ndarray, size_px: tuple[int, int]) -> float:
    """The corners' coverage of the frame; CalibrationError if too little or a quarter empty."""
    coverage, empty = _coverage(points_px, size_px)
    if coverage < MIN_COVERAGE or empty:
        where = f"; none in the {', '.join(empty)} quarter" if empty else ""
        raise CalibrationError(
            f"the board's corners cover {100 * coverage:.0f} % of the frame{where}; at least "
            f"{100 * MIN_COVERAGE:.0f} % and every quarter are needed to fit the distortion: "
            "add views with the board near each corner of the frame"
        )
    return coverage


def _fit_without_outliers(
    obj: list[np.ndarray], img: list[np.ndarray], size_px: tuple[int, int], min_views: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Fit, then refit once without the views that fit badly: K, distortion, RMS per view, outliers.

    An outlier's RMS stays that of the first fit.
    """
    K, dist, rms = _fit(obj, img, size_px)
    median = float(np.median(rms))
    outlier = (rms > OUTLIER_FACTOR * median) & (rms > OUTLIER_FLOOR_PX)
    first_rms = rms
    if outlier.any():
        keep = np.flatnonzero(~outlier)
        if len(keep) < min_views:
            raise CalibrationError(
                f"{int(outlier.sum())} of {len(obj)} views fit badly (rms above "
                f"{OUTLIER_FACTOR:g} × the median {median:.2f} px); the {len(keep)} left are "
                f"fewer than {min_views}: take sharper views of the flat board"
            )
        K, dist, rms_kept = _fit([obj[k] for k in keep], [img[k] for k in keep], size_px)
        rms = first_rms.copy()
        rms[keep] = rms_kept
    return K, dist, rms, outlier


def _check_plausible(
    K: np.ndarray, total: float, spec: BoardSpec, size_px: tuple[int, int]
) -> None:
    """CalibrationError on a poor fit or a camera matrix no real camera has."""
    if total > MAX_RMS_PX:
        raise CalibrationError(
            f"the calibration is too poor: rms {total:.2f} px, more than {MAX_RMS_PX:g} px: "
            "use sharp, evenly lit views of a flat board and check it is the "
            f"{spec.squares[0]}x{spec.squares[1]} board of {spec.square_cm:g} cm squares"
        )
    w, h = size_px
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    if abs(fx / fy - 1.0) > MAX_ASPECT_DEVIATION:
        raise CalibrationError(
            f"implausible camera matrix: fx {fx:.1f} px and fy {fy:.1f} px differ by more "
            f"than {100 * MAX_ASPECT_DEVIATION:.0f} %: add views with the board tilted "
            "in different directions"
        )
    if not (w / 4 <= cx <= 3 * w / 4 and h / 4 <= cy <= 3 * h / 4):
        raise CalibrationError(
            f"implausible camera matrix: the principal point ({cx:.1f}, {cy:.1f}) px is "
            f"outside the middle half of the {w}x{h} px frame: add views with the board "
            "tilted in different directions and covering the whole frame"
        )


def fit_views(
    views: Sequence[BoardView],
    size_px: tuple[int, int],
    spec: BoardSpec = DEFAULT_BOARD,
    camera_id: str = "camera",
    min_views: int = MIN_VIEWS,
    min_corners: int = MIN_CORNERS,
) -> CalibrationReport:
    r"""Fit the camera matrix and distortion to board corners seen in several views.

    ``cv2.calibrateCamera`` with OpenCV's five coefficients (k1, k2, p1, p2, k3)
    minimises the reprojection error over all corners:

    .. math:: \min_{K, d, \{R_v, t_v\}} \sum_v \sum_i \|\pi(K, d, R_v X_i + t_v) - x_{vi}\|^2

    A view whose RMS error is above ``OUTLIER_FACTOR`` × the median (and above
    ``OUTLIER_FLOOR_PX``) is dropped and the fit repeated once.

    Args:
        views: The corners found in each frame (:func:`detect_board`).
        size_px: The frames' size (width, height) [px].
        spec: The board they show.
        camera_id: The camera, recorded in the result.
        min_views: Fewest usable views [-].
        min_corners: Fewest corners a view needs to be used [-].

    Raises:
        CalibrationError: too few usable views, corners that do not cover the frame, a
            final RMS above ``MAX_RMS_PX``, or an implausible camera matrix; the message
            says what to do.
    """
    w, h = size_px
    board = spec.board()
    used = [v for v in views if len(v.ids) >= min_corners]
    skipped = tuple(v.name for v in views if len(v.ids) < min_corners)
    if len(used) < min_views:
        raise CalibrationError(
            f"only {len(used)} of {len(views)} views show the board with at least "
            f"{min_corners} corners; at least {min_views} are needed: take more views of "
            "the whole board, from different angles and distances"
        )
    corners_cm = np.asarray(board.getChessboardCorners(), np.float32)  # (C, 3), z = 0
    obj = [corners_cm[v.ids].reshape(-1, 1, 3) for v in used]
    img = [v.corners_px.astype(np.float32).reshape(-1, 1, 2) for v in used]
    coverage = _checked_coverage(np.concatenate([v.corners_px for v in used]), size_px)
    K, dist, rms, outlier = _fit_without_outliers(obj, img, size_px, min_views)
    kept = ~outlier
    n = np.array([len(o) for o in obj])
    total = math.sqrt(float(np.sum(n[kept] * rms[kept] ** 2) / np.sum(n[kept])))
    report_views = tuple(
        ViewFit(v.name, int(n[k]), float(rms[k]), bool(outlier[k])) for k, v in enumerate(used)
    )
    _check_plausible(K, total, spec, size_px)
    try:
        intrinsics = Intrinsics(
            camera_matrix=K,
            distortion=dist,
            size_px=(w, h),
            rms_px=total,
            views=int(kept.sum()),
            camera_id=camera_id,
        )
    except CalibrationError as exc:
        raise CalibrationError(f"implausible calibration: {exc.reason}") from None
    return CalibrationReport(intrinsics, report_views, skipped, coverage)


def same_size(
    label: str, size_px: tuple[int, int], first_px: tuple[int, int] | None, first: str
) -> tuple[int, int]:
    """The views' common frame size: ``first_px``, or ``size_px`` for the first view.

    Raises:
        CalibrationError: ``label`` is not the size of the first view, ``first``.
    """
    if first_px is None or size_px == first_px:
        return size_px
    w, h = size_px
    raise CalibrationError(
        f"{label} is {w}x{h} px but the first view, {first}, is "
        f"{first_px[0]}x{first_px[1]} px: every view must come from the same camera at the "
        "same resolution"
    )


def calibrate_report(
    frames: Sequence[npt.ArrayLike],
    spec: BoardSpec = DEFAULT_BOARD,
    camera_id: str = "camera",
    min_views: int = MIN_VIEWS,
    min_corners: int = MIN_CORNERS,
    names: Sequence[str] | None = None,
) -> CalibrationReport:
    """Detect the board in each frame and fit (:func:`fit_views`); the full report.

    Args:
        frames: 8-bit grey or BGR images, all of one size.
        spec: The board they show.
        camera_id: The camera, recorded in the result.
        min_views: Fewest usable views [-].
        min_corners: Fewest corners a view needs to be used [-].
        names: A name per frame for messages (default ``frame 0``, ``frame 1``, …).

    Raises:
        CalibrationError: frames of different sizes, or as :func:`fit_views`.
        ImageError: a frame is not an 8-bit grey or BGR image.
    """
    labels = list(names) if names is not None else [f"frame {k}" for k in range(len(frames))]
    if len(labels) != len(frames):
        raise ValueError(f"{len(labels)} names for {len(frames)} frames")
    if not frames:
        raise CalibrationError(f"no frames given; at least {min_views} views are needed")
    views, size = [], None
    for label, frame in zip(labels, frames, strict=True):
        grey = _grey(frame, label)
        h, w = grey.shape
        size = same_size(label, (w, h), size, labels[0])
        corners, ids = detect_board(grey, spec)
        views.append(BoardView(label, corners, ids))
    assert size is not None
    return fit_views(views, size, spec, camera_id, min_views, min_corners)


def calibrate(
    frames: Sequence[npt.ArrayLike],
    spec: BoardSpec = DEFAULT_BOARD,
    camera_id: str = "camera",
    min_views: int = MIN_VIEWS,
    min_corners: int = MIN_CORNERS,
) -> Intrinsics:
    """The camera's intrinsics from frames showing the board (:func:`calibrate_report`)."""
    return calibrate_report(frames, spec, camera_id, min_views, min_corners).intrinsics
