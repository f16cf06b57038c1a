r"""Colour object detection: the paper's HSV recipe on OpenCV (paper §4).

For each colour class (``task.classes``, in their order): classify pixels
(:mod:`mearm.vision.classify`), a k×k median filter on the class's mask (3×3 in the
paper), 8-connected regions, regions under ``min_area_px`` dropped; each remaining region
is one :class:`Detection` with its pixel area, bounding box and sub-pixel centroid (the
mean of its pixel centres, i.e. the image moments m10/m00, m01/m00).

Three shortcuts make this fast without changing the result. Work is confined to the box
around every classified pixel (grown by the median's reach), outside which every mask
is 0. The classes' filtered masks are one median of the image of class codes where no
window holds two classes (:func:`~mearm.vision.classify.median_codes`). Regions are
labelled once on the union of the filtered masks (after the median the masks are
disjoint: a pixel needs 5 of its 9 neighbours in a mask to stay in it): a union region
holding one class *is* that class's region, and the rare union region holding several
(objects of different classes touching) is split by labelling each class inside its box.
A test checks the result against a plain per-class NumPy/SciPy implementation
(:mod:`mearm.vision.paper_recipe`).

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
  gives 1.0, two touching discs √5 ≈ 2.24 — and, with a calibration, its area could hold
  two (:func:`~mearm.vision.plausible.may_hold_two`: two seen objects show at least one
  flat footprint, so a smaller region is one object, e.g. a disc tipped onto its side,
  unless the arm's body borders it and may hide the rest).

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
from collections.abc import Callable, Iterable, Sequence

import cv2
import numpy as np

from mearm.config import (
    CalibrationConfig,
    CameraConfig,
    ColorClass,
    TaskConfig,
    VisionConfig,
)
from mearm.config.errors import CalibrationError
from mearm.errors import ConfigError, whole_config, wrong_argument
from mearm.vision.calibration import Calibration, CameraGeometry, camera_geometry
from mearm.vision.classify import PixelClassifier, equal_mask, median_codes
from mearm.vision.detection import Detection, _point, _with_table_yaw, check_frame
from mearm.vision.errors import ImageError
from mearm.vision.flat_detection import Regions, find_regions, seen_from_above
from mearm.vision.highlights import highlight_classifier, union_box, with_highlights
from mearm.vision.learned import LearnedClassifier, area_mask, balance_by, gains
from mearm.vision.perspective_detection import (
    MAX_SPLIT,
    SILHOUETTE_WRONG,
    _classify_regions,
    _disc_diameter_cm,
    _top_face,
    best_shape,
    locate_in_perspective,
    object_image_bounds,
    split_by_silhouettes,
    top_fits,
)
from mearm.vision.pinhole import PerspectiveCamera, TopFit
from mearm.vision.plausible import may_hold_two, plausible, surely_plausible, widths_cm
from mearm.vision.regions import (
    CORE_DEPTH,
    MIN_PART,
    STACKED_BOX_PX,
    Part,
    _axis_ratio,
    _axis_ratios,
    _elongation,
    _label,
    _measure_regions,
    _region_mask,
    split_region,
)
from mearm.vision.shadows import grow_into_shadows, weak_classifier
from mearm.vision.shapes import ClassMatcher, touches_border
from mearm.vision.thresholds import Thresholds

#: Where objects are looked for (0/255, ``None``: everywhere), whether that is the whole
#: frame, and the colour-constancy gains (B, G, R) or ``None``.
Prepared = tuple[np.ndarray | None, bool, np.ndarray | None]

__all__ = [
    "CORE_DEPTH",
    "MAX_SPLIT",
    "MIN_PART",
    "SILHOUETTE_WRONG",
    "STACKED_BOX_PX",
    "ColorDetector",
    "Detection",
    "Part",
    "_axis_ratio",
    "_axis_ratios",
    "_classify_regions",
    "_disc_diameter_cm",
    "_elongation",
    "_label",
    "_measure_regions",
    "_point",
    "_region_mask",
    "_top_face",
    "_with_table_yaw",
    "check_frame",
    "exclude_mask",
    "split_region",
]


def exclude_mask(exclude: object, frame_shape: Sequence[int]) -> np.ndarray:
    """An excluded-pixels mask as 0/255 uint8 (H, W): nonzero means excluded.

    ``exclude`` may be of bool dtype or any integer dtype (``True``/1/255 alike).

    Raises:
        ImageError: ``exclude`` is not a NumPy array, not 2-D of the frame's height and
            width, or not of a bool or integer dtype.
    """
    h, w = int(frame_shape[0]), int(frame_shape[1])
    if not isinstance(exclude, np.ndarray):
        raise ImageError(
            "exclude",
            f"expected a numpy array (H, W) of bool or integers, got {type(exclude).__name__}",
        )
    if exclude.ndim != 2 or exclude.shape != (h, w):
        raise ImageError(
            "exclude",
            f"mask of shape {exclude.shape}: must be 2-D (H, W) of the frame's size, "
            f"({h}, {w}) for this {w}x{h} px frame",
        )
    kind = exclude.dtype.kind
    if kind not in "biu":
        raise ImageError(
            "exclude",
            f"mask of dtype {exclude.dtype}: must be bool or integer (nonzero is excluded)",
        )
    excluded = exclude if kind == "b" else exclude != 0
    return excluded.view(np.uint8) * np.uint8(255)


def _require_section(value: object, kind: type, section: str, user: str) -> None:
    """Raise :class:`ConfigError` unless ``value`` is the config's section ``section``."""
    if not isinstance(value, kind):
        fix = f"config.{section}" if whole_config(value) else None
        needs = f"a {kind.__name__} (the config's {section} section)"
        raise ConfigError(None, [wrong_argument(user, needs, value, fix)])


def _require_classes(classes: object, user: str) -> tuple[ColorClass, ...]:
    """``classes`` as a tuple of :class:`ColorClass`, or :class:`ConfigError`.

    A config or its task section (iterable, as every pydantic model is, over its fields)
    is named, with the classes to pass instead.
    """
    named = whole_config(classes) or isinstance(classes, (TaskConfig, str, bytes))
    found = tuple(classes) if isinstance(classes, Iterable) and not named else None
    if found is None or not all(isinstance(c, ColorClass) for c in found):
        fix = (
            "config.task.classes"
            if whole_config(classes) or isinstance(classes, TaskConfig)
            else None
        )
        needs = "the colour classes, a sequence of ColorClass (config.task.classes)"
        raise ConfigError(None, [wrong_argument(user, needs, classes, fix)])
    return found


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
        table_area_px: The work area when ``vision`` gives none: the calibrated table's
            outline (:func:`~mearm.vision.work_area.default_work_area`), a polygon (u, v)
            [px]; ``None``: the whole frame.

    Raises:
        ConfigError: no classes, too many, or a name listed twice; a camera height
            not above every class's objects; ``vision`` not the vision section or
            ``classes`` not a sequence of :class:`ColorClass` (e.g. a whole config: the
            message names the section to pass).
        CalibrationError: ``calibration`` is neither ``None`` nor a camera geometry (a
            :class:`Calibration` or a :class:`PerspectiveCamera`, as
            :func:`camera_geometry` makes from the config's sections; or build the
            detector with :meth:`from_config`).
    """

    def __init__(
        self,
        vision: VisionConfig,
        calibration: CameraGeometry | None,
        classes: Sequence[ColorClass],
        camera_height_cm: float | None = None,
        *,
        table_area_px: Sequence[tuple[float, float]] | None = None,
    ):
        _require_section(vision, VisionConfig, "vision", "ColorDetector")
        self.classes = _require_classes(classes, "ColorDetector")
        if calibration is not None and not isinstance(
            calibration, (Calibration, PerspectiveCamera)
        ):
            fix = (
                "camera_geometry(config.calibration, config.camera), or build the detector "
                "with ColorDetector.from_config"
                if isinstance(calibration, CalibrationConfig) or whole_config(calibration)
                else None
            )
            needs = "a camera geometry or None (camera_geometry(config.calibration, config.camera))"
            raise CalibrationError(wrong_argument("ColorDetector", needs, calibration, fix))
        self.vision = vision
        self.calibration = calibration
        self.thresholds = Thresholds.from_config(self.classes, vision)
        self.classifier = PixelClassifier(self.thresholds)
        learned = self.thresholds.learned
        codes = self.thresholds.codes
        #: The learned colours' classifier (:mod:`mearm.vision.learned`), if any.
        self.learned = (
            LearnedClassifier({codes[n]: m for n, m in learned.items()}, vision.reference_bgr)
            if learned
            else None
        )
        self._banded = any(n not in learned for n in self.thresholds.class_names)
        self._areas: dict[tuple[int, int], np.ndarray] = {}
        self._whole: dict[tuple[int, int], bool] = {}  # the work area is the whole frame
        given = vision.work_area_px
        self._area_px = list(given) if given is not None else table_area_px
        shadow = vision.shadow_value_min
        # hysteresis on value is for hue bands on raw frames: not with learned colours
        # (their lightness range reaches into shadows already) or a reference colour (the
        # strong pixels are classified on the balanced frame); a work area or the
        # excluded pixels bound the weak pixels as they do the strong ones (_filtered)
        plain = not learned and vision.reference_bgr is None
        self._weak = (
            None if shadow is None or not plain else weak_classifier(self.thresholds, shadow)
        )
        # blown-out tops (mearm.vision.highlights): hue bands on raw frames too
        bright = vision.highlight_saturation_min
        self._highlights = (
            None if bright is None or not plain else highlight_classifier(self.thresholds, bright)
        )
        #: The colours the pixels are classified into (one per class without shapes).
        self.class_names = self.thresholds.class_names
        self.matcher = ClassMatcher(self.classes)
        self._rank = {c.name: i for i, c in enumerate(self.classes)}  # the classes' order
        # Per colour, its classes' largest object: the diameter of the disc of its
        # footprint's area (a cube's is 1.13 sides), and the tallest height.
        size = {c.name: c for c in self.classes}
        self._class_of = size
        members = {g: names for g, (_, names) in self.matcher.groups.items()}
        self._diameter_cm = {
            g: max(_disc_diameter_cm(size[n]) for n in names) for g, names in members.items()
        }
        self._height_cm = {g: max(size[n].height_cm for n in names) for g, names in members.items()}
        self._widths_cm = {g: widths_cm(size[n] for n in names) for g, names in members.items()}
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
    def from_config(
        cls,
        vision: VisionConfig,
        calibration: CalibrationConfig,
        camera: CameraConfig,
        classes: Sequence[ColorClass],
        *,
        geometry: CameraGeometry | None = None,
    ) -> ColorDetector:
        """The detector of a config's sections: ``vision``, ``calibration``, ``camera``, classes.

        The calibration selects the camera's geometry (:func:`camera_geometry`; or
        ``geometry``, already made from it); with a perspective calibration and no
        ``vision.work_area_px`` the work area is the calibrated table's outline
        (:func:`~mearm.vision.work_area.default_work_area`).

        Raises:
            ConfigError: a section is not the one named (e.g. a whole config: the message
                names the section to pass), or :class:`ColorDetector`'s.
            CalibrationError: the calibration cannot be used (:func:`camera_geometry`).
        """
        from mearm.vision.work_area import default_work_area

        user = "ColorDetector.from_config"
        _require_section(vision, VisionConfig, "vision", user)
        _require_section(calibration, CalibrationConfig, "calibration", user)
        _require_section(camera, CameraConfig, "camera", user)
        classes = _require_classes(classes, user)
        if geometry is None:
            geometry = camera_geometry(calibration, camera)
        table = default_work_area(vision, geometry, calibration, camera, classes)
        return cls(vision, geometry, classes, table_area_px=table)

    def work_area(self, shape: Sequence[int]) -> np.ndarray | None:
        """The work area's 0/255 mask for frames of ``shape`` (H, W, ...), or ``None``."""
        if self._area_px is None:
            return None
        key = (int(shape[0]), int(shape[1]))
        if key not in self._areas:
            self._areas[key] = area_mask(self._area_px, key)
            self._whole[key] = cv2.countNonZero(self._areas[key]) == key[0] * key[1]
        return self._areas[key]

    def _classify(
        self, frame: np.ndarray, prepared: Prepared
    ) -> tuple[np.ndarray, tuple[int, int, int, int]]:
        """Class codes of a frame and the box outside which all are 0 (may be loose).

        The frame is white-balanced first when the config holds a reference colour, the
        learned colours' codes take their pixels before the hue bands', and nothing
        outside the area looked in (the work area less the excluded pixels) is kept
        (:mod:`mearm.vision.learned`). ``prepared``: :meth:`area_and_gain`'s.
        """
        area, whole, gain = prepared
        if self.learned is None and area is None:
            balanced = frame if gain is None else balance_by(frame, gain)
            return self.classifier.classify_with_box(balanced)
        codes = self.codes_of(frame, gain)
        if area is not None and not whole:
            codes = cv2.bitwise_and(codes, area)
        x, y, w, h = cv2.boundingRect(codes)
        return codes, (x, y, w, h)

    def area_and_gain(self, frame: np.ndarray, exclude: np.ndarray | None = None) -> Prepared:
        """Where objects are looked for, whether that is the whole frame, and the gains.

        The area is the work area's 0/255 mask less ``exclude`` (:func:`exclude_mask`:
        nonzero is excluded; ``None``: everywhere); the gains (B, G, R) take the frame's
        median there to ``vision.reference_bgr`` (``None`` without a reference colour).

        Raises:
            ImageError: ``exclude`` is not a bool or integer (H, W) mask of the frame's size.
        """
        area = self.work_area(frame.shape)
        # a work area of the whole frame (a taught one, often) keeps every pixel
        whole = exclude is None and self._whole.get(frame.shape[:2], False)
        if exclude is not None:
            keep = cv2.bitwise_not(exclude_mask(exclude, frame.shape))
            area = keep if area is None else cv2.bitwise_and(area, keep)
        ref = self.vision.reference_bgr
        gain = None if ref is None else gains(frame, ref, None if whole else area)
        return area, whole, gain

    def codes_of(self, frame: np.ndarray, gain: np.ndarray | None) -> np.ndarray:
        """Class codes (uint8 (H, W), 0: none) of a frame or a window of one, after ``gain``.

        Learned colours first, then the hue bands; no work area applied.
        """
        if self._banded:
            balanced = frame if gain is None else balance_by(frame, gain)
            codes, _ = self.classifier.classify_with_box(balanced)
        else:
            codes = np.zeros(frame.shape[:2], np.uint8)
        if self.learned is not None:
            taught = self.learned.classify_with_highlights(frame, gain)
            codes = taught if not self._banded else np.where(taught > 0, taught, codes)
        return codes

    def _filtered(
        self,
        frame_bgr: np.ndarray,
        exclude: np.ndarray | None = None,
        prepared: Prepared | None = None,
    ) -> tuple[np.ndarray, int, int, bool]:
        """The median-filtered class codes of the box around every classified pixel, its origin.

        Codes 1..N (0: none), uint8: each class's mask median-filtered
        (``vision.median_kernel``), the masks disjoint, and whether no two classes'
        pixels touch in it (:func:`median_codes`). Outside that box (grown by the
        median's reach) every code is 0, so working inside it gives the full frame's
        result exactly, for less work. With
        ``vision.shadow_value_min`` the regions are grown into their shadows inside the
        area looked in only, as the strong pixels are classified there: a shadow is not
        followed out of the work area or into the arm's mask. With
        ``vision.highlight_saturation_min`` a pixel at the clip of a class's hue counts
        from that lower saturation floor (:mod:`mearm.vision.highlights`), inside the
        same area.
        """
        frame = check_frame(frame_bgr)
        prepared = prepared or self.area_and_gain(frame, exclude)
        codes, (x, y, w, h) = self._classify(frame, prepared)
        area, whole, _ = prepared
        bright = None
        if self._highlights is not None:  # blown-out tops (mearm.vision.highlights)
            bright, box = self._highlights.classify_with_box(frame)
            if area is not None and not whole:
                bright = cv2.bitwise_and(bright, area)
            codes = with_highlights(codes, bright)
            x, y, w, h = union_box((x, y, w, h), box)
        if self._weak is not None:  # regions grown into their shadows (mearm.vision.shadows)
            weak, box = self._weak.classify_with_box(frame)
            if area is not None and not whole:  # no shadow grown past the work area
                weak = cv2.bitwise_and(weak, area)
            if bright is not None:  # every strong pixel a weak one of its class
                weak = with_highlights(weak, bright)
            x, y, w, h = union_box((x, y, w, h), box)
            codes = grow_into_shadows(codes, weak, len(self.class_names))
        k = self.vision.median_kernel
        if w == 0 or h == 0:
            x, y, w, h = 0, 0, 1, 1
        reach = k // 2
        x0, y0 = max(x - reach, 0), max(y - reach, 0)
        x1, y1 = min(x + w + reach, codes.shape[1]), min(y + h + reach, codes.shape[0])
        index, apart = median_codes(codes[y0:y1, x0:x1], k, len(self.class_names))
        return index, x0, y0, apart

    def masks(self, frame_bgr: np.ndarray) -> dict[str, np.ndarray]:
        """Per class name, its median-filtered mask over the whole frame (uint8 0/255, (H, W)).

        Raises:
            ImageError: the frame is not an 8-bit 3-channel image.
        """
        frame = check_frame(frame_bgr)
        index, x0, y0, _ = self._filtered(frame)
        out: dict[str, np.ndarray] = {}
        for code, name in enumerate(self.class_names, start=1):
            full = np.zeros(frame.shape[:2], np.uint8)
            full[y0 : y0 + index.shape[0], x0 : x0 + index.shape[1]] = equal_mask(index, code)
            out[name] = full
        return out

    def detect(
        self, frame_bgr: np.ndarray, *, exclude: np.ndarray | None = None
    ) -> list[Detection]:
        """The objects in a BGR frame, in the documented order (see the module docstring).

        :meth:`_detect`'s detections, parts of objects judged (:mod:`.object_parts`).
        With a reference colour (the table's, taught), only detections standing on the
        work surface are kept (:mod:`.on_table`).

        Args:
            frame_bgr: The frame, (H, W, 3) uint8 BGR.
            exclude: Pixels where no object is looked for, e.g. the arm's body
                (:class:`~mearm.vision.arm_mask.ArmInView`): an (H, W) mask of the frame's
                size, of bool or integer dtype, where nonzero means excluded (``True``,
                1 and 255 alike); ``None``: nothing is excluded.

        Raises:
            ImageError: the frame is not an 8-bit 3-channel image, or ``exclude`` is not a
                bool or integer (H, W) mask of the frame's size.
        """
        from mearm.vision.object_parts import whole_objects_and_widths

        if exclude is not None:  # as 0/255, as the plausibility rules and _detect read it
            exclude = exclude_mask(exclude, check_frame(frame_bgr).shape)
        prepared = None
        if self.vision.reference_bgr is not None and self.calibration is not None:
            prepared = self.area_and_gain(check_frame(frame_bgr), exclude)
        found = self._detect(frame_bgr, exclude=exclude, prepared=prepared)
        found, narrow = whole_objects_and_widths(found, self, frame_bgr.shape)
        if prepared is None:
            return found
        # imported by a detector that knows the table's colour only (with the teaching
        # it takes its threshold from): a sort by hue bands never needs them
        from mearm.vision.on_table import on_table  # noqa: PLC0415

        return on_table(found, frame_bgr, self, prepared, narrow)

    def _detect(
        self,
        frame_bgr: np.ndarray,
        *,
        exclude: np.ndarray | None = None,
        prepared: Prepared | None = None,
    ) -> list[Detection]:
        """Detections in ``frame_bgr`` ((H, W, 3) uint8 BGR), in the documented order.

        ``exclude``: pixels where no object is looked for (:func:`exclude_mask`: an (H, W)
        bool or integer mask, nonzero excluded), e.g. the arm's body
        (:class:`~mearm.vision.arm_mask.ArmInView`).

        The regions are measured one by one (class, area, box, elongation), the rest per
        image (merged test, table positions, order); each detection is made once, at
        the end. Regions to split and perspective calibrations take the general path
        (:meth:`_resolve`, :meth:`_located`).

        Raises:
            ImageError: the frame is not an 8-bit 3-channel image, or ``exclude`` is not
                of its size.
        """
        if exclude is not None:
            exclude = exclude_mask(exclude, check_frame(frame_bgr).shape)
        index, ox, oy, apart = self._filtered(frame_bgr, exclude, prepared)
        found = find_regions(index, (ox, oy), self.vision.min_area_px, apart=apart)
        codes, areas, boxes, elongations = found.codes, found.areas, found.boxes, found.elongations
        sources, centroid, labels = found.sources, found.centroid, found.labels
        if not codes:
            return []
        colors = [self.class_names[c - 1] for c in codes]
        elongation = np.array(elongations)
        merged = elongation > self.vision.merged_elongation
        cal = self.calibration
        table: np.ndarray | None = None
        if cal is not None:
            flat, largest, stretch = self.one_object_bounds(centroid, colors, frame_bgr.shape)
            over = np.array(areas) > self.vision.merged_area_ratio * largest
            if over.any() or not isinstance(cal, Calibration):
                regions = [
                    _region_mask(r, labels, b, 0, 0)
                    for r, b in zip(sources, found.label_boxes, strict=True)
                ]
                return self._general(colors, centroid, areas, boxes, merged, elongations,
                                     regions, frame_bgr, exclude)  # fmt: skip
            merged = (elongation > self.vision.merged_elongation * stretch) & may_hold_two(
                np.array(areas, float), flat, boxes, exclude
            )
            table = np.array(cal.pixel_to_table(centroid))  # its own memory, then read-only
            table.setflags(write=False)

        def region_of(j: int) -> np.ndarray:
            return _region_mask(sources[j], labels, found.label_boxes[j], 0, 0)

        keep = None
        if table is not None:
            keep = self._plausible_keep(
                colors, np.array(areas, float), np.array(boxes, float), region_of,
                frame_bgr.shape, (flat, stretch),
            )  # fmt: skip
        measured = Regions(colors, centroid, areas, boxes, merged.tolist(), elongations, table,
                           sources, found.outlines, found.label_boxes)  # fmt: skip
        chosen = range(len(codes)) if keep is None else np.flatnonzero(keep).tolist()
        to_table = cal.pixel_to_table if isinstance(cal, Calibration) else None
        return seen_from_above(measured, chosen, labels, frame_bgr.shape, self.matcher,
                               self._rank, to_table)  # fmt: skip

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
        exclude: np.ndarray | None = None,
    ) -> list[Detection]:
        """The detections of regions of which some must be split or are in perspective."""
        found = [
            Detection(color, c, a, b, bool(m), e)
            for color, c, a, b, m, e in zip(
                colors, centroid, areas, boxes, merged, elongations, strict=True
            )
        ]
        found, regions = self._resolve(found, regions, frame, exclude)
        found, regions = self._objects_only(found, regions, frame.shape)
        fits = self._top_fits(found, regions, frame)
        tops = (
            None
            if fits is None
            else [None if f is None else best_shape(f, self._class_of) for f in fits]
        )
        classed = _classify_regions(self.matcher, found, regions, frame.shape, tops)
        return self._ordered(self._located(classed, frame, fits))

    def _objects_only(
        self,
        found: list[Detection],
        regions: list[np.ndarray],
        frame_shape: Sequence[int],
        bounds: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> tuple[list[Detection], list[np.ndarray]]:
        """The regions that can be objects of their colour's size and shape, and their masks.

        :func:`~mearm.vision.plausible.plausible` at each region's place, after its box's
        sure pass (:func:`~mearm.vision.plausible.surely_plausible`); regions cut by the
        frame's border are kept (only part of them is seen). Needs the calibration (the
        objects' size in pixels); without it every region is kept. ``bounds``: the flat
        area and largest elongation at each region (:meth:`one_object_bounds`), if known.
        """
        if self.calibration is None or not found:
            return found, regions
        colors = [d.color for d in found]
        if bounds is None:
            centroids = np.array([d.centroid_px for d in found])
            flat, _, stretch = self.one_object_bounds(centroids, colors, frame_shape)
            bounds = flat, stretch
        keep = self._plausible_keep(
            colors,
            np.array([d.area_px for d in found], dtype=float),
            np.array([d.bbox_px for d in found], dtype=float),
            regions.__getitem__,
            frame_shape,
            bounds,
        )
        if keep is None:
            return found, regions
        return (
            [d for d, k in zip(found, keep, strict=True) if k],
            [r for r, k in zip(regions, keep, strict=True) if k],
        )

    def _plausible_keep(
        self,
        colors: Sequence[str],
        area_px: np.ndarray,
        box_px: np.ndarray,
        region_of: Callable[[int], np.ndarray],
        frame_shape: Sequence[int],
        bounds: tuple[np.ndarray, np.ndarray],
    ) -> list[bool] | None:
        """Which regions :meth:`_objects_only` keeps; ``None``: every one.

        ``area_px`` (N,) and ``box_px`` (N, 4) as floats; ``region_of(j)`` gives region
        ``j``'s mask, asked only for those the sure pass does not settle.
        """
        flat, stretch = bounds
        disc_cm2 = np.array([math.pi * self._diameter_cm[c] ** 2 / 4.0 for c in colors])
        scale = np.sqrt(flat / disc_cm2)
        widths = np.array([self._widths_cm[c] for c in colors])  # (N, 2)
        sure = surely_plausible(area_px, box_px[:, 2], box_px[:, 3], scale, flat, widths, stretch)
        if sure.all():
            return None
        height, width = int(frame_shape[0]), int(frame_shape[1])
        keep = sure.tolist()
        for j in np.flatnonzero(~sure).tolist():
            x, y, w, h = (int(v) for v in box_px[j])
            keep[j] = touches_border((x, y, w, h), width, height) or plausible(
                region_of(j), area_px[j], scale[j], flat[j], self._widths_cm[colors[j]], stretch[j]
            )
        return None if all(keep) else keep

    def _top_fits(
        self, found: list[Detection], regions: list[np.ndarray], frame: np.ndarray
    ) -> list[dict[str, TopFit] | None] | None:
        """In perspective, each region's top face fitted as each class it may be of.

        :func:`~mearm.vision.perspective_detection.top_fits`; ``None`` without a
        perspective camera.
        """
        cal = self.calibration
        if not isinstance(cal, PerspectiveCamera) or not found:
            return None
        return top_fits(cal, self.matcher, self._class_of, found, regions, frame)

    def _ordered(self, out: list[Detection]) -> list[Detection]:
        """``out`` in the documented order: by class, then top to bottom, left to right."""
        order = self._rank
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
            return flat, *object_image_bounds(cal, centroids_px, diameter, height)
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
                _with_table_yaw(d.evolve(table_cm=p), cal) for d, p in zip(found, xy, strict=True)
            ]
        assert isinstance(cal, PerspectiveCamera)
        return locate_in_perspective(cal, self._class_of, classed, frame, fits)

    def _resolve(
        self,
        found: list[Detection],
        regions: list[np.ndarray],
        frame: np.ndarray,
        exclude: np.ndarray | None = None,
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
                two = may_hold_two(np.array([d.area_px], float), np.array([a_flat]),
                                   [d.bbox_px], exclude)[0]  # fmt: skip
                out.append(d.evolve(merged=bool(d.elongation > e_max and two)))
                masks.append(region)
                continue
            if isinstance(self.calibration, PerspectiveCamera):
                parts, at = self._split_by_silhouettes(d, region, a_max, frame)
            else:
                radius = math.sqrt(a_flat / math.pi)
                lo = max(MIN_PART * a_flat, self.vision.min_area_px)
                parts, at = split_region(region, radius, lo, a_max, e_max), None
            if parts is None:
                out.append(d.evolve(merged=True))
                masks.append(region)
                continue
            x0, y0 = d.bbox_px[0], d.bbox_px[1]
            for i, p in enumerate(parts):
                px, py, pw, ph = p.bbox_px
                masks.append(p.mask)
                out.append(
                    d.evolve(
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

        :func:`~mearm.vision.perspective_detection.split_by_silhouettes`, fitting up to
        as many objects as the region's area suggests (at most :data:`MAX_SPLIT`).
        """
        cal = self.calibration
        assert isinstance(cal, PerspectiveCamera)
        most = min(MAX_SPLIT, max(2, math.ceil(d.area_px / a_max * self.vision.merged_area_ratio)))
        return split_by_silhouettes(
            cal,
            d,
            region,
            frame,
            radius_cm=self._diameter_cm[d.color] / 2.0,
            height_cm=self._height_cm[d.color],
            most=most,
            min_area_px=self.vision.min_area_px,
        )
