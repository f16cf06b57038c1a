r"""Objects stand on the work surface: what is seen around a detection is the table.

An object lies on the table, so what surrounds it, beyond its own sides and the shadow
right at its foot, is the table or other objects. A coloured thing that is not an object
— a bracket on a robot's dark base, glare on the robot's body, a label on a servo — is
surrounded by the robot. Each detection's *ring* is the band from ¼ to ½ of one object's
narrowest width *w*\ :sub:`n` (at the calibration's scale there, as
:mod:`mearm.vision.object_parts` takes it) outside the convex hull of its pixels: close
enough to be its surroundings, far enough to be past its sides and the shadow at its foot.
A ring pixel is *of the surface* when it is:

- the table: within :data:`~mearm.vision.teaching.TABLE_DELTA_E` of the table's colour in
  CIELAB's chroma plane (a*, b*), lit or in shadow (L* at least :data:`SHADOW_SHARE` of
  the table's; a robot's black is far darker) — the table's colour is the reference
  colour the frame is balanced to (``vision.reference_bgr``, the work area's median when
  the colours were taught, which the table fills);
- or an object: of any class's colour (touching objects).

Ring pixels beyond the frame's edge count as the surface, as the quick test below counts
its points there: nothing seen there is against the object, and the share stays one of
the whole ring. Left out, they made the robot along one side of an object near the edge
weigh more than the quarter of the ring it is (a third of the rest when a quarter of the
ring is beyond the edge: the object dropped, where mid-frame it is kept). Ring pixels
outside the work area count as the surface too, for the same reasons: the work area says
where objects can be and nothing is looked for past it, so what is seen there (the
floor, the robot's base beyond the table's outline) is no evidence against an object in
it; the quick test counts its points there as the surface already; and left out, they
weighed the rest of the ring as the frame's edge did. Ring pixels in the excluded mask
(the arm's body, inside the work area) are not counted: the arm is there, seen or not. A
detection is kept when at least :data:`SURFACE_SHARE` of its counted ring is of the
surface. Needs a reference colour and a calibration (one object's size); without either
every detection is kept.

Cost: each colour's verdict (class code, table or not) is looked up in a table of
2^18 colours made once per detector (:func:`surface_table`), and a detection whose box,
grown by the ring's middle, is the surface at its corners and sides' midpoints is kept
without its ring being made (:func:`_surely_on_table`): only the doubtful ones pay for it.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Sequence
from typing import Protocol

import cv2
import numpy as np

from mearm.config import ColorClass, VisionConfig
from mearm.vision.calibration import CameraGeometry
from mearm.vision.detection import Detection
from mearm.vision.learned import lab_of, reference_lab
from mearm.vision.object_parts import ObjectBounds, colours_of, narrowest_px
from mearm.vision.teaching import TABLE_DELTA_E

#: The ring's inner and outer edges, in one object's narrowest widths [-].
RING = (0.25, 0.5)
#: A shadow on the table keeps at least this share of the table's lightness L* [-].
SHADOW_SHARE = 0.5
#: A detection is kept when this share of its ring is the table or objects [-]: two
#: thirds, so a robot (or anything not the table) along one side of it costs nothing.
SURFACE_SHARE = 2.0 / 3.0


class SurfaceDetector(ObjectBounds, Protocol):
    """What the rule needs of a detector (:class:`~mearm.vision.detector.ColorDetector`)."""

    calibration: CameraGeometry | None
    classes: tuple[ColorClass, ...]
    vision: VisionConfig
    class_names: tuple[str, ...]

    def codes_of(self, frame: np.ndarray, gain: np.ndarray | None) -> np.ndarray:
        """Class codes (0: none) of a frame or window after ``gain``."""
        ...

    def work_area(self, shape: Sequence[int]) -> np.ndarray | None:
        """The work area's 0/255 mask for frames of ``shape``, or ``None``: the whole frame."""
        ...


#: Bits of each channel the surface's table is indexed by (as the learned colours').
SURFACE_BITS = 6
#: The flag, in the surface's table, of the table's colour (the low byte: the class code).
TABLE = 0x100
#: A colour's place in the surface's table: (b, g, r) quantised, times these, summed.
_PLACES = np.array([1 << (2 * SURFACE_BITS), 1 << SURFACE_BITS, 1], np.uint32)

# per detector, made once: its colours and reference never change
_SURFACES: weakref.WeakKeyDictionary[SurfaceDetector, np.ndarray] = weakref.WeakKeyDictionary()


def surface_table(detector: SurfaceDetector) -> np.ndarray:
    """Per colour (:data:`SURFACE_BITS` a channel), its class code | :data:`TABLE`, (2^18,).

    Each cell's centre is classified once, as the detector classifies (its class code),
    and tested against the table's colour, ``vision.reference_bgr`` (module docstring).
    """
    known = _SURFACES.get(detector)
    if known is not None:
        return known
    ref = detector.vision.reference_bgr
    assert ref is not None
    table_lab = reference_lab(ref)
    n = 1 << SURFACE_BITS
    step = 1 << (8 - SURFACE_BITS)
    b, g, r = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
    centres = (np.stack([b, g, r], axis=-1) * step + step // 2).astype(np.uint8)
    cells = centres.reshape(n * n, n, 3)  # an image of every cell's centre
    codes = detector.codes_of(cells, None).reshape(-1).astype(np.uint16)
    lab = lab_of(cells).reshape(-1, 3)
    ab = np.hypot(lab[:, 1] - table_lab[1], lab[:, 2] - table_lab[2])
    table = (ab <= TABLE_DELTA_E) & (lab[:, 0] >= SHADOW_SHARE * table_lab[0])
    return _SURFACES.setdefault(detector, codes | np.where(table, TABLE, 0).astype(np.uint16))


def _looked_up(pixels_bgr: np.ndarray, gain: np.ndarray | None, lut: np.ndarray) -> np.ndarray:
    """The surface table's entries (..., ) of 8-bit pixels (..., 3) after ``gain``."""
    px = pixels_bgr if gain is None else np.minimum(np.rint(pixels_bgr * gain), 255)
    q = px.astype(np.uint32) >> (8 - SURFACE_BITS)
    return lut.take(q @ _PLACES)


def surface_share(
    surface: np.ndarray,
    own: np.ndarray,
    counted: np.ndarray | None,
    inner_px: float,
    outer_px: float,
) -> float | None:
    """The share of a region's ring that is the table or objects (module docstring).

    Args:
        surface: Where the window around the region is the table or of a class (bool (h, w)).
        own: The region's pixels in it (bool (h, w)).
        counted: Where ring pixels count (bool (h, w)), or ``None``: everywhere.
        inner_px: The ring's inner distance from the region's convex hull [px].
        outer_px: Its outer distance [px].

    Returns:
        The share [-], or ``None`` when no ring pixel is counted.
    """
    points = cv2.findNonZero(own.astype(np.uint8))
    if points is None:
        return None
    hull = np.zeros(own.shape, np.uint8)
    cv2.fillConvexPoly(hull, cv2.convexHull(points), 1)
    near = cv2.dilate(hull, _disc(inner_px))
    ring = cv2.dilate(hull, _disc(outer_px)) > near
    if counted is not None:
        ring &= counted
    if not ring.any():
        return None
    return float(np.mean(surface[ring]))


def _disc(radius_px: float) -> np.ndarray:
    """A disc-shaped structuring element of ``radius_px`` (at least 1 px)."""
    k = 2 * max(1, round(radius_px)) + 1
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))


def on_table(
    found: list[Detection],
    frame_bgr: np.ndarray,
    detector: SurfaceDetector,
    prepared: tuple[np.ndarray | None, bool, np.ndarray | None],
    narrow_px: np.ndarray | None = None,
) -> list[Detection]:
    """``found`` without the detections not standing on the work surface (module docstring).

    Args:
        found: A frame's detections, in the detector's order.
        frame_bgr: The frame, (H, W, 3) uint8.
        detector: The detector that found them.
        prepared: The area looked in (0/255 (H, W), ``None``: everywhere), whether it is
            the whole frame, and the gains (:meth:`~.ColorDetector.area_and_gain`).
        narrow_px: Each one's object's narrowest width there [px], if known
            (:func:`~mearm.vision.object_parts.narrowest_px`).
    """
    ref = detector.vision.reference_bgr
    if ref is None or detector.calibration is None or not found:
        return found
    area, whole, gain = prepared
    counted = None if whole else area
    work = None if whole else detector.work_area(frame_bgr.shape)
    lut = surface_table(detector)
    narrow = narrowest_px(found, detector, frame_bgr.shape) if narrow_px is None else narrow_px
    sure = _surely_on_table(found, narrow, frame_bgr, counted, gain, lut)
    if sure.all():
        return found
    colours = colours_of(found, detector)
    keep = [
        bool(s)
        or _on_table(d, w, detector.class_names.index(c) + 1, frame_bgr, (counted, work), gain, lut)
        for d, w, c, s in zip(found, narrow, colours, sure, strict=True)
    ]
    return [d for d, k in zip(found, keep, strict=True) if k]


#: The grown box's corners and sides' midpoints, as shares of its width and height.
_ALONG = np.array(
    [[0.0, 0.5, 1.0, 1.0, 1.0, 0.5, 0.0, 0.0], [0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 0.5]]
).T


def _surely_on_table(
    found: Sequence[Detection],
    narrow_px: np.ndarray,
    frame_bgr: np.ndarray,
    counted: np.ndarray | None,
    gain: np.ndarray | None,
    lut: np.ndarray,
) -> np.ndarray:
    """Detections whose box, grown by the ring's middle, is the surface at 8 points, (N,).

    The grown box's corners and sides' midpoints, each one counted the table or an
    object: most objects pass this, for far less than their ring; the rest are judged on
    it (:func:`surface_share`).
    """
    box = np.array([d.bbox_px for d in found], dtype=float)  # (N, 4)
    grow = ((RING[0] + RING[1]) / 2.0 * narrow_px)[:, None, None]
    # (N, 8, 2): each point (u, v), the grown box's corner plus a share of its sides
    at = np.rint(box[:, None, :2] - grow + _ALONG * (box[:, None, 2:] - 1 + 2 * grow))
    height, width = frame_bgr.shape[:2]
    most = np.array([width - 1, height - 1])
    inside = np.all((at >= 0) & (at <= most), axis=2)
    at = at.clip(0, most).astype(np.intp)
    u, v = at[..., 0], at[..., 1]
    if counted is not None:
        inside &= counted[v, u] > 0
    surface = _looked_up(frame_bgr[v, u], gain, lut) > 0
    return np.all(surface | ~inside, axis=1)


def _on_table(
    d: Detection,
    narrow_px: float,
    code: int,
    frame_bgr: np.ndarray,
    areas: tuple[np.ndarray | None, np.ndarray | None],
    gain: np.ndarray | None,
    lut: np.ndarray,
) -> bool:
    """Whether at least :data:`SURFACE_SHARE` of one detection's ring is the surface.

    ``code``: the class code of its colour. ``areas``: the area looked in and the work
    area (0/255 (H, W) each, ``None``: everywhere); ring pixels outside the work area are
    the surface, those in the area looked in or outside the work area are counted
    (module docstring).
    """
    counted, work = areas
    inner, outer = RING[0] * narrow_px, RING[1] * narrow_px
    reach = math.ceil(outer) + 1
    height, width = frame_bgr.shape[:2]
    x, y, bw, bh = d.bbox_px
    x0, y0 = max(x - reach, 0), max(y - reach, 0)
    x1, y1 = min(x + bw + reach, width), min(y + bh + reach, height)
    # the window reaches ``reach`` beyond the box on every side, the frame's edge or not:
    # its part beyond the edge is the surface, and counted (module docstring)
    beyond = (
        (y0 - (y - reach), y + bh + reach - y1),
        (x0 - (x - reach), x + bw + reach - x1),
    )
    seen = _looked_up(frame_bgr[y0:y1, x0:x1], gain, lut)
    where = None if counted is None else counted[y0:y1, x0:x1] > 0
    if work is not None and where is not None:
        # outside the work area as beyond the frame: the surface, and counted
        outside = work[y0:y1, x0:x1] == 0
        seen = np.where(outside, TABLE, seen)
        where |= outside
    entries = np.pad(seen, beyond, constant_values=TABLE)
    own = np.zeros(entries.shape, bool)
    own[reach : reach + bh, reach : reach + bw] = True
    own &= (entries & 0xFF) == code
    where = None if where is None else np.pad(where, beyond, constant_values=True)
    share = surface_share(entries > 0, own, where, inner, outer)
    return share is None or share >= SURFACE_SHARE
