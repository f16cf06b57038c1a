"""ArUco markers for calibration: find them, draw them, print them (paper §4).

A marker lies flat on the table with its top edge towards +y of the base frame. Its
centre is the intersection of its image diagonals (exact under any homography, unlike
the mean of the corners). Given the table position of each marker's centre — and, if
its printed side is given, its four corners too — :func:`calibration_from_markers`
fits the pixel → table homography.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import cv2
import numpy as np
import numpy.typing as npt

from mearm.config.errors import CalibrationError
from mearm.vision.calibration import Calibration

DEFAULT_DICTIONARY = "DICT_4X4_50"


def get_dictionary(name: str = DEFAULT_DICTIONARY) -> cv2.aruco.Dictionary:
    """The predefined ArUco dictionary ``name`` (e.g. ``"DICT_4X4_50"``).

    Raises:
        CalibrationError: no such dictionary.
    """
    choices = sorted(n for n in dir(cv2.aruco) if n.startswith("DICT_"))
    if name not in choices:
        raise CalibrationError(f"unknown ArUco dictionary {name!r}; choose from {choices}")
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))


def marker_image(marker_id: int, side_px: int, dictionary: str = DEFAULT_DICTIONARY) -> np.ndarray:
    """The marker ``marker_id`` as a (side_px, side_px) uint8 image (black on white)."""
    d = get_dictionary(dictionary)
    n = len(d.bytesList)
    if not 0 <= marker_id < n:
        raise CalibrationError(f"marker id {marker_id} is not in {dictionary} (ids 0..{n - 1})")
    return cv2.aruco.generateImageMarker(d, marker_id, side_px)


def table_corners_cm(center_cm: npt.ArrayLike, side_cm: float) -> np.ndarray:
    """Table positions of a marker's corners in OpenCV's order (TL, TR, BR, BL), (4, 2) [cm].

    The marker's top edge faces +y.
    """
    x, y = np.asarray(center_cm, dtype=float)
    h = side_cm / 2.0
    return np.array([[x - h, y + h], [x + h, y + h], [x + h, y - h], [x - h, y - h]])


def diagonal_center(corners_px: npt.ArrayLike) -> np.ndarray:
    """Intersection of the diagonals TL–BR and TR–BL of a quadrilateral, (2,) [px]."""
    c = np.asarray(corners_px, dtype=float).reshape(4, 2)
    p, r = c[0], c[2] - c[0]
    q, s = c[1], c[3] - c[1]
    denom = r[0] * s[1] - r[1] * s[0]
    if abs(denom) < 1e-12:
        return c.mean(axis=0)
    t = ((q[0] - p[0]) * s[1] - (q[1] - p[1]) * s[0]) / denom
    return p + t * r


#: Candidates of one marker closer than this fraction of its perimeter are one group, of
#: which OpenCV keeps one: the outer and inner contours of its black border (≤ 1 module
#: apart, 1/24 of the perimeter of a 4×4 marker) merge, while the edge of the paper it is
#: printed on, a margin of ≥ 1 module away, stays apart. OpenCV's own default (0.125)
#: would merge a 2-module margin; 0.02 (≈ 3 px for a 36 px marker, as a camera 55 cm up
#: sees a 4 cm one) leaves the two border contours apart, so one id came out twice.
MIN_MARKER_DISTANCE_RATE = 0.05
#: Two detections of one id whose corners all lie within this of each other are one
#: marker seen twice [px]; farther apart they are two markers with one id (an error).
SAME_MARKER_PX = 2.0
#: Edge refinement: the part of each side used (away from the rounded corners), and the
#: half-width of the profile across the edge [modules].
_SIDE_SPAN = (0.15, 0.85)
_PROFILE_HALF_WIDTH = 0.6
#: Least brightness step across an edge for the refinement to trust it [grey levels].
_MIN_EDGE_CONTRAST = 20.0


def _edge_line(
    grey: np.ndarray, a: np.ndarray, b: np.ndarray, outward: np.ndarray, module_px: float
) -> tuple[np.ndarray, np.ndarray] | None:
    """The side a→b of a marker as a line (point, unit direction) fitted to its edge.

    Profiles across the side (dark border inside, white paper outside) are sampled with
    bilinear interpolation; on each the edge is where the brightness crosses halfway
    between its dark and bright ends, which a symmetric blur does not move. ``None`` if
    the edge is not clear (low contrast, off the image).
    """
    h, w = grey.shape
    half = max(1.5, _PROFILE_HALF_WIDTH * module_px)
    offsets = np.arange(-half, half + 1e-9, 0.25)
    n_along = max(8, int(np.linalg.norm(b - a) * (_SIDE_SPAN[1] - _SIDE_SPAN[0])))
    along = np.linspace(*_SIDE_SPAN, n_along)
    base = a[None, :] + along[:, None] * (b - a)[None, :]
    pts = base[:, None, :] + offsets[None, :, None] * outward[None, None, :]
    if (
        pts[..., 0].min() < 0
        or pts[..., 1].min() < 0
        or pts[..., 0].max() > w - 1
        or (pts[..., 1].max() > h - 1)
    ):
        return None
    prof = cv2.remap(
        grey, pts[..., 0].astype(np.float32), pts[..., 1].astype(np.float32), cv2.INTER_LINEAR
    ).astype(float)
    # the levels as the darkest of the inner and the brightest of the outer half (robust
    # to a printed label a little beyond the marker's edge)
    n = len(offsets) // 2
    dark = np.percentile(prof[:, :n], 10, axis=1)
    bright = np.percentile(prof[:, -n:], 90, axis=1)
    edges = []
    for row, lo, hi, p in zip(prof, dark, bright, base, strict=True):
        if hi - lo < _MIN_EDGE_CONTRAST:
            continue
        above = np.nonzero(row >= (lo + hi) / 2)[0]
        if len(above) == 0 or above[0] == 0:
            continue
        i = above[0]  # first sample at or above halfway: the crossing is in (i-1, i]
        f = ((lo + hi) / 2 - row[i - 1]) / (row[i] - row[i - 1])
        edges.append(p + (offsets[i - 1] + f * (offsets[i] - offsets[i - 1])) * outward)
    if len(edges) < max(4, n_along // 2):
        return None
    e = np.array(edges)
    centre = e.mean(axis=0)
    _, _, vt = np.linalg.svd(e - centre)
    return centre, vt[0]


#: The fitted edges' corner replaces OpenCV's sub-pixel one only within this distance
#: [px]: the blur bias it corrects is 0.2–0.3 px; farther, the edges were aliased or
#: cluttered and the fit is the worse of the two.
EDGE_FIT_AGREE_PX = 0.35


def refine_corners(grey: np.ndarray, corners_px: npt.ArrayLike, modules: int) -> np.ndarray:
    """A marker's corners as the intersections of its four fitted outer edges, (4, 2) [px].

    Sub-pixel corner search on a square's corner is pulled inwards by blur (≈ 0.2–0.3 px
    on a 36 px marker); straight edges are not, so their intersections are the corners.
    A corner whose edges are unclear, or which would move by more than
    :data:`EDGE_FIT_AGREE_PX`, keeps its given position.
    """
    c = np.asarray(corners_px, dtype=float).reshape(4, 2)
    module_px = float(np.mean(np.linalg.norm(c - np.roll(c, -1, axis=0), axis=1))) / modules
    mid = c.mean(axis=0)
    lines = []
    for k in range(4):
        a, b = c[k], c[(k + 1) % 4]
        d = (b - a) / max(np.linalg.norm(b - a), 1e-12)
        normal = np.array([-d[1], d[0]])
        if np.dot(normal, (a + b) / 2 - mid) < 0:
            normal = -normal
        lines.append(_edge_line(grey, a, b, normal, module_px))
    out = c.copy()
    for k in range(4):
        l1, l2 = lines[(k - 1) % 4], lines[k]  # the sides ending and starting at corner k
        if l1 is None or l2 is None:
            continue
        (p, r), (q, s) = l1, l2
        denom = r[0] * s[1] - r[1] * s[0]
        if abs(denom) < 0.2:  # sides nearly parallel: no sharp intersection
            continue
        t = ((q[0] - p[0]) * s[1] - (q[1] - p[1]) * s[0]) / denom
        x = p + t * r
        if np.linalg.norm(x - c[k]) <= EDGE_FIT_AGREE_PX:
            out[k] = x
    return out


def detect_markers(
    frame_bgr: np.ndarray, dictionary: str = DEFAULT_DICTIONARY
) -> dict[int, np.ndarray]:
    """Markers found in a frame: id → its 4 corners (TL, TR, BR, BL), (4, 2) [px].

    Each marker is found once (:data:`MIN_MARKER_DISTANCE_RATE`); should one still come
    out twice with its corners within :data:`SAME_MARKER_PX`, the larger is kept. Corners
    are refined to sub-pixel (:func:`refine_corners`).

    Raises:
        CalibrationError: the same id appears at two places.
    """
    d = get_dictionary(dictionary)
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    params.minMarkerDistanceRate = MIN_MARKER_DISTANCE_RATE
    detector = cv2.aruco.ArucoDetector(d, params)
    grey = frame_bgr if frame_bgr.ndim == 2 else cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2GRAY)
    corners, ids, _ = detector.detectMarkers(grey)
    grey_f = grey.astype(np.float32)
    modules = d.markerSize + 2
    found: dict[int, np.ndarray] = {}
    for c, i in zip(corners, [] if ids is None else ids.ravel(), strict=False):
        marker_id = int(i)
        quad = refine_corners(grey_f, np.asarray(c, dtype=float).reshape(4, 2), modules)
        if marker_id in found:
            other = found[marker_id]
            if np.linalg.norm(quad - other, axis=1).max() > SAME_MARKER_PX:
                raise CalibrationError(
                    f"marker {marker_id} appears twice in the image: use each id once"
                )
            if cv2.contourArea(quad.astype(np.float32)) <= cv2.contourArea(
                other.astype(np.float32)
            ):
                continue
        found[marker_id] = quad
    return found


def find_markers(
    frame_bgr: np.ndarray, wanted: Iterable[int], dictionary: str = DEFAULT_DICTIONARY
) -> dict[int, np.ndarray]:
    """:func:`detect_markers`, with every id in ``wanted`` required.

    Raises:
        CalibrationError: a wanted marker is not in the image, or an id appears twice.
    """
    found = detect_markers(frame_bgr, dictionary)
    missing = sorted(set(wanted) - set(found))
    if missing:
        raise CalibrationError(
            f"markers {missing} not found in the image (found {sorted(found)}): check the "
            "lighting, that each marker is flat, whole and in view, and --dictionary"
        )
    return found


def calibration_from_markers(
    frame_bgr: np.ndarray,
    centers_cm: Mapping[int, tuple[float, float]],
    *,
    side_cm: float | None = None,
    dictionary: str = DEFAULT_DICTIONARY,
) -> Calibration:
    """Fit the calibration to ArUco markers at known table positions.

    Args:
        frame_bgr: The camera's view of the table with the markers, (H, W, 3) uint8.
        centers_cm: Marker id → table position (x, y) of its centre [cm].
        side_cm: Printed side of the markers [cm]; when given, their corners are used
            too (4 more pairs per marker, and a reprojection error that means something).
        dictionary: ArUco dictionary name.

    Raises:
        CalibrationError: a marker is missing from the image, or the points are degenerate.
    """
    found = find_markers(frame_bgr, centers_cm, dictionary)
    pixels, table = [], []
    for marker_id, center in sorted(centers_cm.items()):
        corners = found[marker_id]
        pixels.append(diagonal_center(corners))
        table.append(np.asarray(center, dtype=float))
        if side_cm is not None:
            pixels.extend(corners)
            table.extend(table_corners_cm(center, side_cm))
    return Calibration.fit(np.array(pixels), np.array(table))


def draw_marker_on_table(
    frame_bgr: np.ndarray,
    calibration: Calibration,
    marker_id: int,
    center_cm: tuple[float, float],
    side_cm: float,
    dictionary: str = DEFAULT_DICTIONARY,
) -> None:
    """Draw a printed marker (with a white margin) lying on the table into ``frame_bgr``.

    For tests and the simulator: the marker goes where the calibration puts it.
    """
    modules = get_dictionary(dictionary).markerSize + 2  # data bits + black border
    side_px = 40 * modules
    margin = 80  # two modules of white paper around the marker
    sheet = np.full((side_px + 2 * margin, side_px + 2 * margin), 255, np.uint8)
    sheet[margin:-margin, margin:-margin] = marker_image(marker_id, side_px, dictionary)
    full = side_cm * (side_px + 2 * margin) / side_px
    src = np.array(
        [[0, 0], [sheet.shape[1], 0], [sheet.shape[1], sheet.shape[0]], [0, sheet.shape[0]]]
    )
    dst = calibration.table_to_pixel(table_corners_cm(center_cm, full))  # pixel centres
    M = cv2.getPerspectiveTransform(src.astype(np.float32) - 0.5, dst.astype(np.float32))
    h, w = frame_bgr.shape[:2]
    warped = cv2.warpPerspective(sheet, M, (w, h), flags=cv2.INTER_LINEAR, borderValue=0)
    cover = cv2.warpPerspective(np.full_like(sheet, 255), M, (w, h), flags=cv2.INTER_LINEAR)
    alpha = (cover.astype(np.float32) / 255.0)[..., None]
    mixed = alpha * cv2.cvtColor(warped, cv2.COLOR_GRAY2BGR) + (1 - alpha) * frame_bgr
    frame_bgr[...] = np.clip(np.rint(mixed), 0, 255).astype(np.uint8)
