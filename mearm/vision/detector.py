r"""Colour object detection: the paper's HSV recipe on OpenCV (paper §4).

For each colour class (``task.classes``, in their order): classify pixels
(:mod:`mearm.vision.classify`), a k×k median filter on the class's mask (3×3 in the
paper), 8-connected regions, regions under ``min_area_px`` dropped; each remaining region
is one :class:`Detection` with its pixel area, bounding box and sub-pixel centroid (the
mean of its pixel centres, i.e. the image moments m10/m00, m01/m00).

Two shortcuts make this fast without changing the result. Work is confined to the box
around every classified pixel (grown by the median's reach), outside which every mask
is 0. Regions are labelled once on the union of the filtered masks (after the median
the masks are disjoint: a pixel needs 5 of its 9 neighbours in a mask to stay in it): a
union region holding one class *is* that class's region, and the rare union region
holding several (objects of different classes touching) is split by labelling each
class inside its box. A test checks the result against a plain per-class NumPy/SciPy
implementation (:mod:`mearm.vision.paper_recipe`).

Touching objects of one class form one region. With a calibration the detector knows
the largest image area one object of the class can have at each place, ``A1`` (below);
a region whose area exceeds ``merged_area_ratio`` (1.6) × ``A1`` holds more than one
object and is split (:func:`split_region`): the distance transform of its mask, its
*cores* (pixels deeper than :data:`CORE_DEPTH` × one object's radius: one per disc,
as touching discs meet in a narrow neck), each pixel given to its nearest core. A
split that gives ≥ 2 parts, each of one object's size (at least :data:`MIN_PART` × the
flat disc's area, at most ``merged_area_ratio`` × ``A1``) and shape (elongation under
the limit below), gives one detection per part, with the part's own area, box and
centroid, not flagged. Otherwise the region is reported once, with its real area and
centroid, and flagged ``merged`` (the caller must not pick at that centroid, which lies
between the objects) when any of these holds:

- its area exceeds ``merged_area_ratio`` × ``A1`` — only with a calibration;
- the ratio of its principal axes (from the second central moments) exceeds
  ``merged_elongation`` (1.5) × ``E1`` (``E1`` = 1 without perspective, below): one disc
  gives 1.0, two touching discs √5 ≈ 2.24.

``A1``, one object's largest image area. Without ``camera_height_cm`` the calibration is
taken to hold in the plane of the objects' tops, which the camera sees and nothing else
(the paper's rig, the flat sim camera): ``A1`` is the area of a disc of the class's
``diameter_cm`` at the calibration's scale at that place, and ``E1`` = 1. With
``camera_height_cm`` = *H* (a pinhole looking straight down at the point the frame's
centre maps to, *pp*, with the calibration in the table plane, as a camera calibrated
with markers lying on the table, or the twin's camera), an object of diameter *d* = 2*r*
and height *h* (``height_cm``) whose base is at distance ρ from *pp* shows its top
enlarged by *k* = *H*/(*H* − *h*) and pushed outwards by ρ(*k* − 1), and its side in
between: its silhouette lies in the hull of the base disc and the top disc, whose area
is at most π(*kr*)² + 2*kr*·ρ(*k* − 1) [cm², calibration plane] (the top disc plus the
swept strip), and its principal-axis ratio at most ``E1`` = 1 + ρ(*k* − 1)/(2*r*) (its
length over its width). ρ is taken at the region's centroid, which the perspective
pushes outwards, so it over-estimates ρ: the bound stays a bound.

Detections come in a fixed order: by class in the configured order, each class by
image row then column of the centroid.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import cv2
import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from mearm.config import ColorClass, VisionConfig
from mearm.errors import ConfigError
from mearm.vision.calibration import Calibration, CameraGeometry, camera_geometry
from mearm.vision.classify import PixelClassifier, and_scalar, equal_mask
from mearm.vision.errors import ImageError
from mearm.vision.learned import LearnedClassifier, area_mask, balance_by, gains
from mearm.vision.pinhole import PerspectiveCamera, TopFace, TopFit
from mearm.vision.shadows import grow_into_shadows, weak_classifier
from mearm.vision.shapes import ClassMatcher, measure_shape, table_yaw_deg, touches_border
from mearm.vision.thresholds import Thresholds

if TYPE_CHECKING:
    from mearm.config import Config


@dataclass(frozen=True)
class Detection:
    """One region of one colour class.

    Attributes:
        color: The name of its class (one of ``task.classes``).
        centroid_px: Mean (u, v) of the region's pixel centres [px], (2,), read-only.
        area_px: Number of pixels in the region [px].
        bbox_px: Bounding box (x, y, w, h) [px].
        merged: The region looks like several touching objects (see the module docstring).
        elongation: Ratio of the region's principal axes [-] (1 for a disc).
        table_cm: Where the object stands on the table (x, y), base frame [cm], (2,),
            when the detector has a calibration: the centroid's table point under the
            paper's homography; the centre of its top face's outline under a
            perspective calibration (:meth:`PerspectiveCamera.locate_object`).
        shape: The shape its outline has (:mod:`mearm.vision.shapes`); ``None`` when it
            cannot be told: the region is merged or cut by the image border.
        yaw_px_deg: A cube's sides' direction in the image, from the u axis towards +v,
            in [0, 90) [deg], from the silhouette's smallest rectangle; ``None`` for other
            shapes.
        yaw_deg: A cube's sides' direction on the table, from the base frame's x axis
            towards y, in [0, 90) [deg], when the detector has a calibration: under the
            paper's homography ``yaw_px_deg`` turned through it; under a perspective
            calibration the fitted top square's turn (the silhouette's walls turn its
            rectangle), or for a part of a split region its ``yaw_px_deg`` turned onto
            the table. ``None`` for other shapes, or without a calibration.
    """

    color: str
    centroid_px: np.ndarray = field(compare=False)
    area_px: int
    bbox_px: tuple[int, int, int, int]
    merged: bool = False
    elongation: float = 1.0
    table_cm: np.ndarray | None = field(default=None, compare=False)
    shape: str | None = None
    yaw_px_deg: float | None = None
    yaw_deg: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "centroid_px", _point(self.centroid_px))
        if self.table_cm is not None:
            object.__setattr__(self, "table_cm", _point(self.table_cm))


def _point(value: object) -> np.ndarray:
    """``value`` as a read-only float (2,) array; one already so is kept, not copied.

    Kept only if no one can write it: not writeable, and neither is the array whose
    memory it views (NumPy points a view's ``base`` at that array).
    """
    if (
        isinstance(value, np.ndarray)
        and value.shape == (2,)
        and value.dtype == np.float64
        and not value.flags.writeable
        and (
            value.base is None
            or (isinstance(value.base, np.ndarray) and not value.base.flags.writeable)
        )
    ):
        return value
    p = np.array(value, dtype=float).reshape(2)
    p.setflags(write=False)
    return p


def check_frame(frame: object, source: str = "frame") -> np.ndarray:
    """Return ``frame`` as a C-contiguous (H, W, 3) uint8 BGR array, or raise ImageError."""
    if not isinstance(frame, np.ndarray):
        raise ImageError(source, f"expected a numpy array, got {type(frame).__name__}")
    if frame.dtype != np.uint8:
        raise ImageError(source, f"expected 8-bit pixels (uint8), got {frame.dtype}")
    if frame.ndim != 3 or frame.shape[2] != 3:
        raise ImageError(
            source,
            f"expected a colour image of shape (H, W, 3) in BGR order, got {frame.shape}",
        )
    if frame.shape[0] < 1 or frame.shape[1] < 1:
        raise ImageError(source, f"image is empty, shape {frame.shape}")
    return np.ascontiguousarray(frame)


def _disc_diameter_cm(color_class: ColorClass) -> float:
    """The diameter of the disc with the area of one object's footprint [cm]."""
    area = color_class.object_shape.area_cm2(color_class.diameter_cm)
    return 2.0 * math.sqrt(area / math.pi)


def _top_face(color_class: ColorClass) -> TopFace:
    """A class's top face: a disc of its diameter, or its shape's polygon of its size."""
    spec = color_class.object_shape
    corners = spec.corners_cm(color_class.diameter_cm)
    if corners is None:
        return TopFace(color_class.diameter_cm / 2.0)
    c = np.asarray(corners, dtype=float)
    return TopFace(float(np.max(np.linalg.norm(c, axis=1))), c, spec.symmetry_deg)


#: A region's core: its pixels at least this × one object's radius from its edge.
CORE_DEPTH = 0.6
#: A split's part must have at least this × one flat object's expected area.
MIN_PART = 0.5
#: Perspective: the fitted silhouettes of a split must get at most this share of the
#: region's area wrong (measured: under 0.03 on touching pairs, over 0.15 with one
#: object too few).
SILHOUETTE_WRONG = 0.08
#: Perspective: at most this many objects are fitted to one region.
MAX_SPLIT = 4


def _label(mask: np.ndarray) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    try:  # 16-bit labels are ~3x faster; OpenCV raises if there are too many regions
        return cv2.connectedComponentsWithStats(mask, connectivity=8, ltype=cv2.CV_16U)
    except cv2.error:
        return cv2.connectedComponentsWithStats(mask, connectivity=8, ltype=cv2.CV_32S)


def _elongation(region: np.ndarray) -> float:
    """Principal-axis ratio √(λ_max/λ_min) of a binary region's second central moments."""
    return _axis_ratio(cv2.moments(region, binaryImage=True))


#: Regions whose box is at most this many pixels on each side are measured together,
#: as one stack of windows; larger ones one by one [px].
STACKED_BOX_PX = 96


def _measure_regions(
    index: np.ndarray, labels: np.ndarray, stats: np.ndarray, big: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each region's purity, class code and elongation, all at once, each (N,).

    Pure: every pixel of the region has one class code (then ``code`` is it). The small
    regions (boxes up to :data:`STACKED_BOX_PX`) are read as one stack of equal windows
    over the label image, each at its region's box (moved inwards at the image's edge),
    so their moments are a few array operations per frame, not a call per region; the
    second moments are exact (integer sums).
    """
    count = len(big)
    pure, code, elong = np.zeros(count, bool), np.zeros(count, int), np.ones(count)
    if not count:
        return pure, code, elong
    x, y, w, h, area = stats[big].T
    small = np.flatnonzero((w <= STACKED_BOX_PX) & (h <= STACKED_BOX_PX))
    if len(small):
        ww, hh = int(w[small].max()), int(h[small].max())
        y0 = np.minimum(y[small], labels.shape[0] - hh)
        x0 = np.minimum(x[small], labels.shape[1] - ww)
        own = big[small].astype(labels.dtype)[:, None, None]
        mask = sliding_window_view(labels, (hh, ww))[y0, x0] == own  # (n, hh, ww)
        codes = sliding_window_view(index, (hh, ww))[y0, x0] * mask
        top = codes.max(axis=(1, 2))
        pure[small] = np.count_nonzero(codes == top[:, None, None], axis=(1, 2)) == area[small]
        code[small] = top
        # float32 sums are exact: each is an integer below 2**24 (96**2 pixels × 96**2)
        m = mask.astype(np.float32)
        cols, rows = m.sum(axis=1), m.sum(axis=2)
        gx, gy = np.arange(ww, dtype=np.float32), np.arange(hh, dtype=np.float32)
        sx, sxx = (cols @ gx).astype(float), (cols @ (gx * gx)).astype(float)
        sy, syy = (rows @ gy).astype(float), (rows @ (gy * gy)).astype(float)
        sxy = ((m @ gx) @ gy).astype(float)
        n = area[small].astype(float)
        elong[small] = _axis_ratios(sxx - sx * sx / n, sxy - sx * sy / n, syy - sy * sy / n)
    for k in np.flatnonzero((w > STACKED_BOX_PX) | (h > STACKED_BOX_PX)).tolist():
        roi = (slice(y[k], y[k] + h[k]), slice(x[k], x[k] + w[k]))
        region = (labels[roi] == big[k]).view(np.uint8)
        lo, hi, _, _ = cv2.minMaxLoc(index[roi], mask=region)
        pure[k], code[k], elong[k] = lo == hi, int(lo), _elongation(region)
    return pure, code, elong


def _axis_ratios(mu20: np.ndarray, mu11: np.ndarray, mu02: np.ndarray) -> np.ndarray:
    """Principal-axis ratios √(λ_max/λ_min) of regions' second central moments, (N,).

    1 for a single pixel (both eigenvalues 0), ``inf`` for a line (the smaller one 0).
    """
    root = np.sqrt(np.maximum((mu20 - mu02) ** 2 + 4.0 * mu11 * mu11, 0.0))
    lam_max, lam_min = (mu20 + mu02 + root) / 2.0, (mu20 + mu02 - root) / 2.0
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.sqrt(lam_max / lam_min)
    ratio = np.where(lam_min <= 1e-12, np.inf, ratio)  # a line
    return np.where(lam_max <= 1e-12, 1.0, ratio)  # a single pixel


def _region_mask(
    source: int | np.ndarray, labels: np.ndarray, box: tuple[int, int, int, int], ox: int, oy: int
) -> np.ndarray:
    """A region's 0/1 mask over its box: its label's pixels, or a split piece's own mask."""
    if isinstance(source, np.ndarray):
        return source
    x, y, w, h = box[0] - ox, box[1] - oy, box[2], box[3]
    return (labels[y : y + h, x : x + w] == source).view(np.uint8)


def _axis_ratio(m: dict[str, float]) -> float:
    """Principal-axis ratio √(λ_max/λ_min) from a region's image moments (:func:`_axis_ratios`)."""
    one = _axis_ratios(np.array([m["mu20"]]), np.array([m["mu11"]]), np.array([m["mu02"]]))
    return float(one[0])


@dataclass(frozen=True)
class Part:
    """One object of a split region, in the region's box pixels.

    Attributes:
        area_px: Its pixel count.
        centroid_px: Mean (u, v) of its pixel centres, in the box [px].
        bbox_px: Its bounding box (x, y, w, h) in the box [px].
        elongation: Its principal-axis ratio [-].
        mask: Its pixels, a 0/1 uint8 image of its bounding box.
    """

    area_px: int
    centroid_px: tuple[float, float]
    bbox_px: tuple[int, int, int, int]
    elongation: float
    mask: np.ndarray = field(repr=False, compare=False)


def split_region(
    region: np.ndarray,
    radius_px: float,
    min_area_px: float,
    max_area_px: float,
    max_elongation: float,
) -> list[Part] | None:
    """The objects of a region holding several touching ones, or ``None`` if not sure.

    Args:
        region: The region, 0/1 uint8 image of its bounding box.
        radius_px: One object's radius there [px] (its flat disc's).
        min_area_px: A part smaller than this is no object: no split.
        max_area_px: A part larger than this is not one object: no split.
        max_elongation: A part longer than this is not one object: no split.

    Returns:
        The parts (≥ 2, pixels given to the nearest core), or ``None`` when the region
        has fewer than two cores or a part fails the size or shape test.
    """
    padded = cv2.copyMakeBorder(region, 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0)
    depth = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    cores = (depth >= CORE_DEPTH * radius_px).view(np.uint8)
    n, _, _, _ = _label(cores)
    if n < 3:  # background and one core (or none)
        return None
    _, nearest = cv2.distanceTransformWithLabels(
        1 - cores, cv2.DIST_L2, cv2.DIST_MASK_5, labelType=cv2.DIST_LABEL_CCOMP
    )
    nearest = nearest[1:-1, 1:-1]
    parts = []
    for lab in np.unique(nearest[region.view(bool)]):
        piece = ((nearest == lab) & region.view(bool)).view(np.uint8)
        m = cv2.moments(piece, binaryImage=True)
        area = m["m00"]
        if not min_area_px <= area <= max_area_px:
            return None
        elongation = _axis_ratio(m)
        if elongation > max_elongation:
            return None
        x, y, w, h = cv2.boundingRect(piece)
        centroid = (m["m10"] / area, m["m01"] / area)
        parts.append(
            Part(int(area), centroid, (x, y, w, h), elongation, piece[y : y + h, x : x + w])
        )
    return parts if len(parts) >= 2 else None


class ColorDetector:
    """Find the objects of each colour class in BGR frames.

    Args:
        vision: Floors and filter settings (the ``vision`` section of the config).
        calibration: Enables the area rule of the merged test (the expected area of one
            object at each place); ``None``: only the elongation rule applies.
        classes: The colour classes (``task.classes``): their hue bands, their order
            (class, then row, then column is the order of the detections) and their
            objects' diameter and height (one object's largest area, ``A1``).
        camera_height_cm: The camera's height above the table [cm] when the
            calibration holds in the table plane and the camera sees the objects in
            perspective (see the module docstring); ``None``: the calibration holds in
            the plane of the objects' tops (no perspective growth).

    Raises:
        ConfigError: no classes, too many, or a name listed twice; a camera height
            not above every class's objects.
    """

    def __init__(
        self,
        vision: VisionConfig,
        calibration: CameraGeometry | None,
        classes: Sequence[ColorClass],
        camera_height_cm: float | None = None,
    ):
        self.classes = tuple(classes)
        self.vision = vision
        self.calibration = calibration
        self.thresholds = Thresholds.from_config(self.classes, vision)
        self.classifier = PixelClassifier(self.thresholds)
        learned = self.thresholds.learned
        codes = self.thresholds.codes
        #: The learned colours' classifier (:mod:`mearm.vision.learned`), if any.
        self.learned = (
            LearnedClassifier({codes[n]: m for n, m in learned.items()}) if learned else None
        )
        self._banded = any(n not in learned for n in self.thresholds.class_names)
        self._areas: dict[tuple[int, int], np.ndarray] = {}
        shadow = vision.shadow_value_min
        # hysteresis on value is for hue bands on raw frames: not with learned colours,
        # a reference colour or a work area
        plain = not learned and vision.reference_bgr is None and vision.work_area_px is None
        self._weak = (
            None if shadow is None or not plain else weak_classifier(self.thresholds, shadow)
        )
        #: The colours the pixels are classified into (one per class without shapes).
        self.class_names = self.thresholds.class_names
        self.matcher = ClassMatcher(self.classes)
        # Per colour, its classes' largest object: the diameter of the disc of its
        # footprint's area (a cube's is 1.13 sides), and the tallest height.
        size = {c.name: c for c in self.classes}
        self._class_of = size
        members = {g: names for g, (_, names) in self.matcher.groups.items()}
        self._diameter_cm = {
            g: max(_disc_diameter_cm(size[n]) for n in names) for g, names in members.items()
        }
        self._height_cm = {g: max(size[n].height_cm for n in names) for g, names in members.items()}
        if camera_height_cm is not None:
            tallest = max(self._height_cm.values(), default=0.0)
            if not math.isfinite(camera_height_cm) or camera_height_cm <= tallest:
                raise ConfigError(
                    None,
                    [
                        f"camera height {camera_height_cm} cm: must be above the tallest "
                        f"objects ({tallest} cm)"
                    ],
                )
        self.camera_height_cm = camera_height_cm

    @classmethod
    def from_config(cls, config: Config) -> ColorDetector:
        """The detector of a whole config: ``task.classes``, ``vision``, ``calibration``."""
        return cls(config.vision, camera_geometry(config), config.task.classes)

    def work_area(self, shape: Sequence[int]) -> np.ndarray | None:
        """The work area's 0/255 mask for frames of ``shape`` (H, W, ...), or ``None``."""
        if self.vision.work_area_px is None:
            return None
        key = (int(shape[0]), int(shape[1]))
        if key not in self._areas:
            self._areas[key] = area_mask(self.vision.work_area_px, key)
        return self._areas[key]

    def _classify(self, frame: np.ndarray) -> tuple[np.ndarray, tuple[int, int, int, int]]:
        """Class codes of a frame and the box outside which all are 0 (may be loose).

        The frame is white-balanced first when the config holds a reference colour, the
        learned colours' codes take their pixels before the hue bands', and nothing
        outside the work area is kept (:mod:`mearm.vision.learned`).
        """
        area = self.work_area(frame.shape)
        ref = self.vision.reference_bgr
        gain = None if ref is None else gains(frame, ref, area)
        if self.learned is None and area is None:
            balanced = frame if gain is None else balance_by(frame, gain)
            return self.classifier.classify_with_box(balanced)
        if self._banded:
            balanced = frame if gain is None else balance_by(frame, gain)
            codes, _ = self.classifier.classify_with_box(balanced)
        else:
            codes = np.zeros(frame.shape[:2], np.uint8)
        if self.learned is not None:
            taught = self.learned.classify_with_highlights(frame, gain)
            codes = taught if not self._banded else np.where(taught > 0, taught, codes)
        if area is not None:
            codes = cv2.bitwise_and(codes, area)
        x, y, w, h = cv2.boundingRect(codes)
        return codes, (x, y, w, h)

    def _filtered(self, frame_bgr: np.ndarray) -> tuple[dict[str, np.ndarray], int, int]:
        """Filtered masks of the box around every classified pixel, and the box origin.

        Outside that box (grown by the median's reach) every mask is 0, so working
        inside it gives the full frame's result exactly, for less work.
        """
        frame = check_frame(frame_bgr)
        codes, (x, y, w, h) = self._classify(frame)
        if self._weak is not None:  # regions grown into their shadows (mearm.vision.shadows)
            weak, (x, y, w, h) = self._weak.classify_with_box(frame)
            codes = grow_into_shadows(codes, weak, len(self.class_names))
        k = self.vision.median_kernel
        if w == 0 or h == 0:
            x, y, w, h = 0, 0, 1, 1
        reach = k // 2
        x0, y0 = max(x - reach, 0), max(y - reach, 0)
        x1, y1 = min(x + w + reach, codes.shape[1]), min(y + h + reach, codes.shape[0])
        box = codes[y0:y1, x0:x1]
        out: dict[str, np.ndarray] = {}
        for code, name in enumerate(self.class_names, start=1):
            mask = equal_mask(box, code)
            out[name] = cv2.medianBlur(mask, k) if k > 1 else mask
        return out, x0, y0

    def masks(self, frame_bgr: np.ndarray) -> dict[str, np.ndarray]:
        """Per class name, its median-filtered mask over the whole frame (uint8 0/255, (H, W)).

        Raises:
            ImageError: the frame is not an 8-bit 3-channel image.
        """
        frame = check_frame(frame_bgr)
        boxed, x0, y0 = self._filtered(frame)
        out: dict[str, np.ndarray] = {}
        for name, m in boxed.items():
            full = np.zeros(frame.shape[:2], np.uint8)
            full[y0 : y0 + m.shape[0], x0 : x0 + m.shape[1]] = m
            out[name] = full
        return out

    def detect(self, frame_bgr: np.ndarray) -> list[Detection]:
        """Detections in ``frame_bgr`` ((H, W, 3) uint8 BGR), in the documented order.

        The regions are measured one by one (class, area, box, elongation), the rest per
        image (merged test, table positions, order); each detection is made once, at
        the end. Regions to split and perspective calibrations take the general path
        (:meth:`_resolve`, :meth:`_located`).

        Raises:
            ImageError: the frame is not an 8-bit 3-channel image.
        """
        masks, ox, oy = self._filtered(frame_bgr)
        # One image of class codes 1..N (0 = none); the filtered masks are disjoint.
        index = np.zeros_like(next(iter(masks.values())))
        for code, name in enumerate(self.class_names, start=1):
            index = cv2.bitwise_or(index, and_scalar(masks[name], code))
        n, labels, stats, centroids = _label(index)
        min_area = self.vision.min_area_px
        big = np.flatnonzero(stats[1:n, cv2.CC_STAT_AREA] >= min_area) + 1
        # (smaller union regions hold smaller class regions still)
        # Per region, in label order: class code, area, box in the frame, centroid in
        # working-box pixels, elongation, and its label (its mask: the label's pixels in
        # its box); the pieces of regions where classes touch follow, each with its mask.
        pure, region_code, elong = _measure_regions(index, labels, stats, big)
        keep = big[pure]
        codes: list[int] = region_code[pure].tolist()
        areas: list[int] = stats[keep, cv2.CC_STAT_AREA].tolist()
        boxes = [(x + ox, y + oy, w, h) for x, y, w, h in stats[keep, :4].tolist()]
        elongations: list[float] = elong[pure].tolist()
        sources: list[int | np.ndarray] = list(keep.tolist())
        centres = [centroids[keep]]
        for lab in big[~pure].tolist():  # different classes touch: split them
            x, y, w, h, _ = stats[lab].tolist()
            roi = (slice(y, y + h), slice(x, x + w))
            region = (labels[roi] == lab).view(np.uint8)
            lo, hi, _, _ = cv2.minMaxLoc(index[roi], mask=region)
            for i in range(int(lo), int(hi) + 1):
                sub = equal_mask(index[roi], i)
                sub = cv2.bitwise_and(sub, sub, mask=region)
                m, sub_labels, sub_stats, sub_centroids = _label(sub)
                for s in range(1, m):
                    sx, sy, sw, sh, sarea = sub_stats[s].tolist()
                    if sarea >= min_area:
                        piece = (sub_labels[sy : sy + sh, sx : sx + sw] == s).view(np.uint8)
                        codes.append(i)
                        areas.append(sarea)
                        boxes.append((x + sx + ox, y + sy + oy, sw, sh))
                        centres.append((sub_centroids[s] + (x, y))[None, :])
                        elongations.append(_elongation(piece))
                        sources.append(piece)
        if not codes:
            return []
        centroid = np.concatenate(centres) + (ox, oy)  # (N, 2) [px]
        centroid.setflags(write=False)  # its rows are the detections' own (read-only)
        colors = [self.class_names[c - 1] for c in codes]
        elongation = np.array(elongations)
        merged = elongation > self.vision.merged_elongation
        cal = self.calibration
        table: np.ndarray | None = None
        if cal is not None:
            _, largest, stretch = self.one_object_bounds(centroid, colors, frame_bgr.shape)
            over = np.array(areas) > self.vision.merged_area_ratio * largest
            if over.any() or not isinstance(cal, Calibration):
                regions = [
                    _region_mask(r, labels, b, ox, oy) for r, b in zip(sources, boxes, strict=True)
                ]
                return self._general(colors, centroid, areas, boxes, merged, elongations,
                                     regions, frame_bgr)  # fmt: skip
            merged = elongation > self.vision.merged_elongation * stretch
            table = np.array(cal.pixel_to_table(centroid))  # its own memory, then read-only
            table.setflags(write=False)
        flags = merged.tolist()
        found = [
            Detection(
                color=colors[j],
                centroid_px=centroid[j],
                area_px=areas[j],
                bbox_px=boxes[j],
                merged=flags[j],
                elongation=elongations[j],
                table_cm=None if table is None else table[j],
            )
            for j in range(len(codes))
        ]
        regions = [_region_mask(r, labels, b, ox, oy) for r, b in zip(sources, boxes, strict=True)]
        return self._classed(found, regions, frame_bgr.shape)

    def _general(
        self,
        colors: list[str],
        centroid: np.ndarray,
        areas: list[int],
        boxes: list[tuple[int, int, int, int]],
        merged: np.ndarray,
        elongations: list[float],
        regions: list[np.ndarray],
        frame: np.ndarray,
    ) -> list[Detection]:
        """The detections of regions of which some must be split or are in perspective."""
        found = [
            Detection(color, c, a, b, bool(m), e)
            for color, c, a, b, m, e in zip(
                colors, centroid, areas, boxes, merged, elongations, strict=True
            )
        ]
        found, regions = self._resolve(found, regions, frame)
        fits = self._top_fits(found, regions, frame)
        tops = None if fits is None else [None if f is None else self._best_shape(f) for f in fits]
        classed = _classify_regions(self.matcher, found, regions, frame.shape, tops)
        return self._ordered(self._located(classed, frame, fits))

    def _top_fits(
        self, found: list[Detection], regions: list[np.ndarray], frame: np.ndarray
    ) -> list[dict[str, TopFit] | None] | None:
        """In perspective, each region's top face fitted as each class it may be of.

        The silhouette a perspective camera sees adds the side walls to the top face, and
        a tall object's fill leaves its shape's band (2.5 cm cylinders read as squares).
        Where a region's colour has classes that name shapes, each of their top faces
        (a disc, a square, a triangle of the class's size, at its height) is fitted to
        the far half of the outline (:meth:`PerspectiveCamera.fit_top`) and the closest
        fit names the shape (:meth:`_best_shape`); the region is then located by its
        class's fit. ``None`` for a region merged or cut by the border, or of a colour
        whose classes name no shape: the silhouette's measure stands. Each fit is keyed
        by its class's name.
        """
        cal = self.calibration
        if not isinstance(cal, PerspectiveCamera) or not found:
            return None
        h, w = frame.shape[:2]
        out: list[dict[str, TopFit] | None] = []
        for d, region in zip(found, regions, strict=True):
            names = self.matcher.candidates[d.color]
            classes = [self._class_of[n] for n in names]
            if d.merged or touches_border(d.bbox_px, w, h) or all(c.shape is None for c in classes):
                out.append(None)
                continue
            origin = (d.bbox_px[0], d.bbox_px[1])
            out.append(
                {c.name: cal.fit_top(region, origin, _top_face(c), c.height_cm, frame)
                 for c in classes}
            )  # fmt: skip
        return out

    def _best_shape(self, fits: dict[str, TopFit]) -> str:
        """The shape whose class's top face fits a region's outline best (least rms)."""
        return min((f.rms_cm, self._class_of[n].object_shape.name) for n, f in fits.items())[1]

    def _classed(
        self, found: list[Detection], regions: list[np.ndarray], frame_shape: Sequence[int]
    ) -> list[Detection]:
        """Each region's shape and class (its colour's and shape's), in the documented order.

        ``found`` are the regions of each colour (``color`` is the colour's name);
        regions of no class (a shape no class of its colour has) are dropped.
        """
        classed = _classify_regions(self.matcher, found, regions, frame_shape)
        cal = self.calibration
        out = [d for _, d, _ in classed]
        if isinstance(cal, Calibration):
            out = [_with_table_yaw(d, cal) for d in out]
        return self._ordered(out)

    def _ordered(self, out: list[Detection]) -> list[Detection]:
        """``out`` in the documented order: by class, then top to bottom, left to right."""
        order = {c.name: i for i, c in enumerate(self.classes)}
        out.sort(key=lambda d: (order[d.color], d.centroid_px[1], d.centroid_px[0]))
        return out

    def one_object_bounds(
        self, centroids_px: np.ndarray, colors: Sequence[str], frame_shape: Sequence[int]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One object's flat area, largest area and largest elongation at each centroid.

        Args:
            centroids_px: Region centroids (u, v) in the frame [px], (N, 2).
            colors: Each region's class name, (N,).
            frame_shape: The frame's shape (H, W, ...): its centre is under the camera.

        Returns:
            ``(flat, A1, E1)``, each (N,): the flat disc's area [px], one object's largest
            area ``A1`` [px] and its largest principal-axis ratio over
            ``merged_elongation``, ``E1`` [-] (see the module docstring). Needs the
            calibration.
        """
        assert self.calibration is not None
        cal = self.calibration
        diameter = np.array([self._diameter_cm[c] for c in colors])
        flat = cal.expected_disc_area_px(centroids_px, diameter)
        if isinstance(cal, PerspectiveCamera):  # the calibrated camera's own outline
            height = np.array([self._height_cm[c] for c in colors])
            at = cal.pixel_to_plane(centroids_px, height / 2.0)
            bounds = [
                cal.object_image(p, d / 2.0, hh)
                for p, d, hh in zip(at, diameter, height, strict=True)
            ]
            area, ratio = (
                np.array(v, dtype=float).reshape(len(flat)) for v in zip(*bounds, strict=True)
            )
            return flat, area, ratio
        if self.camera_height_cm is None:
            return flat, flat, np.ones(len(flat))
        height = np.array([self._height_cm[c] for c in colors])
        r = diameter / 2.0
        k = self.camera_height_cm / (self.camera_height_cm - height)
        h, w = frame_shape[0], frame_shape[1]
        pp = cal.pixel_to_table(np.array([w / 2.0, h / 2.0]))
        rho = np.linalg.norm(cal.pixel_to_table(centroids_px) - pp, axis=1)
        sweep = rho * (k - 1.0)
        area_cm2 = math.pi * (k * r) ** 2 + 2.0 * k * r * sweep
        return flat, area_cm2 / cal.pixel_area_cm2(centroids_px), 1.0 + sweep / (2.0 * r)

    def _located(
        self,
        classed: list[tuple[int, Detection, np.ndarray]],
        frame: np.ndarray,
        fits: Sequence[dict[str, TopFit] | None] | None = None,
    ) -> list[Detection]:
        """Each detection of a class with its table position and a cube's table yaw.

        ``classed`` holds each detection's index in ``fits`` (:meth:`_top_fits`) and its
        region. In perspective a disc is located by its top's rim, a square or a triangle
        by its top's outline (:meth:`PerspectiveCamera.fit_top`, the fit already made for
        its class where there is one) once its shape is measured (a merged region's or
        one cut by the border is taken as a disc); a cube's yaw is its top's turn.
        """
        found = [d for _, d, _ in classed]
        cal = self.calibration
        if cal is None or not found:
            return found
        if isinstance(cal, Calibration):
            xy = cal.pixel_to_table(np.array([d.centroid_px for d in found]))
            return [
                _with_table_yaw(replace(d, table_cm=p), cal) for d, p in zip(found, xy, strict=True)
            ]
        out = []
        for k, d, region in classed:
            if d.table_cm is not None:  # placed by the silhouette fit of a split
                out.append(_with_table_yaw(d, cal))  # its part of the silhouette's yaw
                continue
            origin = (d.bbox_px[0], d.bbox_px[1])
            cls = self._class_of[d.color]
            spec = cls.object_shape
            if d.shape == spec.name and spec.corners_cm(cls.diameter_cm) is not None:
                of_region = None if fits is None else fits[k]
                fit = None if of_region is None else of_region.get(cls.name)
                if fit is None:  # its shape came from the silhouette: no fit made yet
                    fit = cal.fit_top(region, origin, _top_face(cls), cls.height_cm, frame)
                yaw = fit.yaw_deg if spec.name == "cube" else None
                out.append(replace(d, table_cm=fit.centre_cm, yaw_deg=yaw))
            else:
                r = _disc_diameter_cm(cls) / 2.0
                at = cal.locate_object(region, origin, r, cls.height_cm, frame)
                out.append(replace(d, table_cm=at))
        return out

    def _resolve(
        self, found: list[Detection], regions: list[np.ndarray], frame: np.ndarray
    ) -> tuple[list[Detection], list[np.ndarray]]:
        """Split the regions holding several objects; flag those that cannot be split.

        Needs the calibration (one object's area); without it only the elongation rule
        (applied in :meth:`_detection`) flags. Returns the detections and their regions.
        """
        if self.calibration is None or not found:
            return found, regions
        centroids = np.array([d.centroid_px for d in found])
        flat, largest, stretch = self.one_object_bounds(
            centroids, [d.color for d in found], frame.shape
        )
        ratio, elong = self.vision.merged_area_ratio, self.vision.merged_elongation
        limit = ratio * largest
        out: list[Detection] = []
        masks: list[np.ndarray] = []
        for d, region, a_flat, a_max, e_max in zip(
            found, regions, flat, limit, elong * stretch, strict=True
        ):
            if d.area_px <= a_max:
                out.append(replace(d, merged=bool(d.elongation > e_max)))
                masks.append(region)
                continue
            if isinstance(self.calibration, PerspectiveCamera):
                parts, at = self._split_by_silhouettes(d, region, a_max, frame)
            else:
                radius = math.sqrt(a_flat / math.pi)
                lo = max(MIN_PART * a_flat, self.vision.min_area_px)
                parts, at = split_region(region, radius, lo, a_max, e_max), None
            if parts is None:
                out.append(replace(d, merged=True))
                masks.append(region)
                continue
            x0, y0 = d.bbox_px[0], d.bbox_px[1]
            for i, p in enumerate(parts):
                px, py, pw, ph = p.bbox_px
                masks.append(p.mask)
                out.append(
                    replace(
                        d,
                        centroid_px=np.add(p.centroid_px, (x0, y0)),
                        area_px=p.area_px,
                        bbox_px=(x0 + px, y0 + py, pw, ph),
                        merged=False,
                        elongation=p.elongation,
                        table_cm=None if at is None else at[i],
                    )
                )
        return out, masks

    def _split_by_silhouettes(
        self, d: Detection, region: np.ndarray, a_max: float, frame: np.ndarray
    ) -> tuple[list[Part] | None, np.ndarray | None]:
        """A region of touching objects seen in perspective: its parts and their places.

        Fits 2, 3, … objects' silhouettes to the region
        (:meth:`PerspectiveCamera.fit_silhouettes`) and takes the fewest that explain it
        (at most :data:`SILHOUETTE_WRONG` of its area wrong); each pixel goes to the
        nearest fitted object that covers it. ``(None, None)`` if no count explains it.
        """
        cal = self.calibration
        assert isinstance(cal, PerspectiveCamera)
        r, h = self._diameter_cm[d.color] / 2.0, self._height_cm[d.color]
        origin = (d.bbox_px[0], d.bbox_px[1])
        most = min(MAX_SPLIT, max(2, math.ceil(d.area_px / a_max * self.vision.merged_area_ratio)))
        for count in range(2, most + 1):
            centres, wrong = cal.fit_silhouettes(region, origin, r, h, count)
            if wrong <= SILHOUETTE_WRONG:
                break
        else:
            return None, None
        centres = cal.rim_centres(region, origin, centres, r, h, frame)
        # each pixel: the nearest (on the plane of the tops) of the objects covering it
        ys, xs = np.nonzero(region)
        pixels = np.column_stack([xs + origin[0], ys + origin[1]]).astype(float)
        on_top = cal.pixel_to_plane(pixels, h)
        dist = np.linalg.norm(on_top[:, None, :] - centres[None, :, :], axis=2)
        covers = np.stack(
            [cal.silhouette_coverage(c, r, h, origin, region.shape)[ys, xs] > 0.5 for c in centres],
            axis=1,
        )
        owner = np.argmin(np.where(covers, dist, dist + 1e6), axis=1)
        parts = []
        for i in range(len(centres)):
            piece = np.zeros_like(region)
            piece[ys[owner == i], xs[owner == i]] = 1
            m = cv2.moments(piece, binaryImage=True)
            if m["m00"] < self.vision.min_area_px:
                return None, None
            x, y, w, hh = cv2.boundingRect(piece)
            parts.append(
                Part(
                    int(m["m00"]),
                    (m["m10"] / m["m00"], m["m01"] / m["m00"]),
                    (x, y, w, hh),
                    _axis_ratio(m),
                    piece[y : y + hh, x : x + w],
                )
            )
        return parts, centres


def _with_table_yaw(d: Detection, cal: CameraGeometry) -> Detection:
    """``d`` with a cube's image yaw (the silhouette's) turned onto the table."""
    if d.yaw_px_deg is None:
        return d
    return replace(d, yaw_deg=table_yaw_deg(cal.pixel_to_table, d.centroid_px, d.yaw_px_deg))


def _classify_regions(
    matcher: ClassMatcher,
    found: Sequence[Detection],
    regions: Sequence[np.ndarray],
    frame_shape: Sequence[int],
    tops: Sequence[str | None] | None = None,
) -> list[tuple[int, Detection, np.ndarray]]:
    """Detections of colours (``color`` a colour's name) as detections of classes.

    Each region's shape is measured (:func:`measure_shape`) unless it is merged or cut
    by the image border (then ``shape`` is ``None``), and its class is
    :meth:`ClassMatcher.match`'s; regions of no class are left out.

    Args:
        matcher: The classes.
        found: The regions' detections, ``color`` the colour's name.
        regions: Each one's mask over its box, 0/1 uint8.
        frame_shape: The frame's (H, W, ...).
        tops: Each region's shape judged by its top face in perspective, where known
            (:meth:`ColorDetector._top_fits`): it stands for the silhouette's.

    Returns:
        Each detection of a class, with its index in ``found`` and its region.
    """
    height, width = int(frame_shape[0]), int(frame_shape[1])
    out = []
    for k, (d, region) in enumerate(zip(found, regions, strict=True)):
        measured = None
        if not d.merged and not touches_border(d.bbox_px, width, height):
            measured = measure_shape(region)
        shape = None if measured is None else measured.shape
        if tops is not None and tops[k] is not None:
            shape = tops[k]
        name = matcher.match(d.color, shape)
        if name is None:
            continue
        yaw = None if measured is None or shape != "cube" else measured.yaw_px_deg
        out.append((k, replace(d, color=name, shape=shape, yaw_px_deg=yaw), region))
    return out
