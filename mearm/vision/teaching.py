"""Teaching colours: a class's colour fitted from pixels a user picks on camera frames.

The user clicks once (or more) on an object of each class (``mearm learn-colours``);
the pixels within a few pixels of each click, on the white-balanced frame, give the
class's CIELAB ellipse (:func:`mearm.vision.learned.fit_clicks`: its clicks' pixels
pooled, its chroma floor the least of each click's own). The table is found
around the samples: the frame's pixels near the colour just outside them, the largest
such region's outline is the work area unless the user gives one, and each colour's
ellipse is narrowed to keep the table's colour out. A sample that cannot teach is
refused (:class:`~mearm.vision.errors.SampleError`): outside the image, on a grey or
black pixel, on the table's colour, two classes sampled on one colour or one class on
two, outside the work area given, or with no table around it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from mearm.config.classes import LearnedColour
from mearm.vision.errors import SampleError
from mearm.vision.learned import (
    CHROMA_MIN,
    LIGHTNESS_MIN,
    TABLE_DELTA_E,
    area_mask,
    balance,
    chroma,
    clipped_bgr,
    distance,
    ellipse_distance,
    fit_clicks,
    fit_colour,
    lab_of,
    median_bgr,
)

#: The table's region must cover at least this share of the frame to be the work area.
TABLE_MIN_SHARE = 0.05
#: A learned colour's ellipse keeps the table's colour at least this far out [-].
TABLE_MARGIN = 1.0
#: The narrowest a learned colour's ellipse is made to keep the table out [-].
MIN_DISTANCE = 1.5
#: A colourless click this light [L*] is on white: a highlight, or a cube's top blown out
#: by the camera (a yellow one's, on the real photos), whose colour shows at its sides.
WHITE_LIGHTNESS = 90.0


@dataclass(frozen=True)
class Sample:
    """One click: class ``name`` at pixel (u, v) of image ``image`` (an index).

    Attributes:
        name: The class's name.
        u_px: Column from the left [px].
        v_px: Row from the top [px].
        image: Which of the frames it is on (0 for the first).
        typed: The ``--sample`` as the user typed it (``''``: a click); messages quote
            it, so that ``red=212.0,340@1`` is not shown as ``red=212,340``.
    """

    name: str
    u_px: float
    v_px: float
    image: int = 0
    typed: str = field(default="", compare=False)

    def __str__(self) -> str:
        if self.typed:
            return self.typed
        on = f"@{self.image}" if self.image else ""
        return f"{self.name}={self.u_px:g},{self.v_px:g}{on}"


@dataclass(frozen=True)
class Taught:
    """What the samples taught: each class's colour, the reference colour, the work area.

    Attributes:
        colours: Per class name, its learned colour.
        reference_bgr: The work area's median colour in the first frame (B, G, R).
        work_area_px: The work area's polygon (u, v) [px], or ``None`` (the whole frame).
        table_lab: The table's colour, CIELAB.
    """

    colours: dict[str, LearnedColour]
    reference_bgr: tuple[float, float, float]
    work_area_px: list[tuple[float, float]] | None
    table_lab: tuple[float, float, float]


def _around(
    frame: np.ndarray, u: float, v: float, radius_px: float
) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """The window of ``frame`` holding every pixel within ``radius_px`` of (u, v).

    Returns the window, each of its pixels' squared distance to (u, v) [px²], and the
    pixel (u, v) is in, as (row, col) in the window.
    """
    h, w = frame.shape[:2]
    r = math.ceil(radius_px) + 1
    x0, x1 = max(int(u) - r, 0), min(int(u) + r + 1, w)
    y0, y1 = max(int(v) - r, 0), min(int(v) + r + 1, h)
    ys, xs = np.mgrid[y0:y1, x0:x1]
    own = (min(int(v), h - 1) - y0, min(int(u), w - 1) - x0)
    return frame[y0:y1, x0:x1], (xs - u) ** 2 + (ys - v) ** 2, own


def _disc(frame: np.ndarray, u: float, v: float, radius_px: float) -> np.ndarray:
    """The pixels (N, 3) within ``radius_px`` of (u, v)."""
    r = max(radius_px, 0.5)
    window, d2, own = _around(frame, u, v, r)
    near = d2 <= r * r
    if not near.any():
        near[own] = True
    return window[near]


#: A sample's pixels: those of its disc within this a*b* distance of the clicked pixel.
CLICK_DELTA = 15.0
#: … and within this lightness of it [L*].
CLICK_LIGHTNESS = 100.0


def _like_click(
    frame: np.ndarray, s: Sample, radius_px: float, table_lab: np.ndarray
) -> np.ndarray:
    """CIELAB of the pixels (N, 3) within ``radius_px`` of a click and of its colour.

    The clicked colour is :func:`_clicked_colour`'s; the disc's pixels more than
    :data:`CLICK_DELTA` from it in a*b* or :data:`CLICK_LIGHTNESS` in L* (the white top
    beside a yellow edge, a letter printed on a block, the table beside a small object)
    are not the user's colour.
    """
    lab = lab_of(_disc(frame, s.u_px, s.v_px, radius_px))
    clicked = _clicked_colour(frame, s, radius_px, table_lab)
    near = np.hypot(lab[:, 1] - clicked[1], lab[:, 2] - clicked[2]) <= CLICK_DELTA
    near &= np.abs(lab[:, 0] - clicked[0]) <= CLICK_LIGHTNESS
    return lab[near] if near.any() else clicked[None, :]


def click_lab(frame: np.ndarray, s: Sample, radius_px: float, table_lab: np.ndarray) -> np.ndarray:
    """The colour a click teaches (CIELAB, (3,)): the median of its samples' pixels.

    Those of :func:`_like_click`, so a ``--radius`` wider than the object (up to 50 px)
    does not take the table around it for the object's colour.
    """
    return np.median(_like_click(frame, s, radius_px, table_lab), axis=0)


#: The pixels under the pointer: within this of the click [px] (3 × 3).
POINTER_PX = 1.5
#: A speck's click looks for the commonest colour among at most about this many pixels.
SPECK_CANDIDATES = 256


def _clicked_colour(
    frame: np.ndarray, s: Sample, radius_px: float, table_lab: np.ndarray
) -> np.ndarray:
    """The colour a click picks (CIELAB, (3,)): the median of the pixels under the pointer.

    Unless that colour is a speck: a printed dot, a mark or a glint no larger than the
    pointer, which fewer of the pixels around it (out to ``radius_px``) share, within
    :data:`CLICK_DELTA` in a*b*, than lie under the pointer. A click is on an object, so
    then it picks the object's commonest colour around the pointer: of the pixels there
    with a colour (chroma >= :data:`CHROMA_MIN`) and not the table's (farther than
    :data:`TABLE_DELTA_E` from ``table_lab``), the one with the most others within
    :data:`CLICK_DELTA`, and the median of those.
    """
    window, d2, own = _around(frame, s.u_px, s.v_px, max(radius_px, POINTER_PX))
    under = d2 <= POINTER_PX**2
    if not under.any():
        under[own] = True
    clicked = np.median(lab_of(window[under]), axis=0)
    around = lab_of(window[~under & (d2 <= radius_px**2)])
    same = np.hypot(around[:, 1] - clicked[1], around[:, 2] - clicked[2]) <= CLICK_DELTA
    if same.sum() >= under.sum():
        return clicked
    obj = around[
        (chroma(around) >= CHROMA_MIN)
        & (np.linalg.norm(around - table_lab, axis=1) > TABLE_DELTA_E)
    ]
    if len(obj) == 0:
        return clicked
    ab = obj[:, 1:].astype(np.float32)
    # every pixel a candidate when few; evenly spaced ones in a wide disc (--radius 50)
    candidates = ab[:: max(1, len(ab) // SPECK_CANDIDATES)]
    close = ((candidates[:, None, :] - ab[None, :, :]) ** 2).sum(axis=-1) <= CLICK_DELTA**2
    best = candidates[int(np.argmax(close.sum(axis=1)))]
    return np.median(obj[((ab - best) ** 2).sum(axis=-1) <= CLICK_DELTA**2], axis=0)


def _ring(frame: np.ndarray, samples: Sequence[Sample], inner: float, outer: float) -> np.ndarray:
    """The pixels (N, 3) between ``inner`` and ``outer`` px of the samples."""
    h, w = frame.shape[:2]
    ys, xs = np.mgrid[0:h, 0:w]
    near = np.zeros((h, w), bool)
    far = np.zeros((h, w), bool)
    for s in samples:
        d2 = (xs - s.u_px) ** 2 + (ys - s.v_px) ** 2
        near |= d2 < inner * inner
        far |= d2 <= outer * outer
    return frame[far & ~near]


#: The table is found on a frame shrunk until an object is at most this wide [px]: its
#: closing's kernel is two objects wide, and on a 4000x3000 photo's 200 px objects that
#: made the teaching some twenty times slower.
TABLE_OBJECT_PX = 64.0


def find_table(
    frame: np.ndarray, samples: Sequence[Sample], object_px: float
) -> tuple[np.ndarray, list[tuple[float, float]] | None]:
    """The table's colour (CIELAB, (3,)) and outline (a polygon, or ``None``).

    The table's colour is the median of the ring 1–2.5 objects from the samples; its
    region the pixels within :data:`TABLE_DELTA_E` of it, closed over the objects on it;
    its outline the convex hull of the largest region (``None`` if it covers less than
    :data:`TABLE_MIN_SHARE` of the frame). With no samples, the frame's median colour.
    Objects wider than :data:`TABLE_OBJECT_PX` are looked for on the frame shrunk to
    that (the outline in the frame's own pixels).

    Raises:
        SampleError: no pixel of the frame is in the ring (a frame about one object wide:
            a crop of one cube, a 1 × 1 image): no table to tell the objects from.
    """
    h, w = frame.shape[:2]
    if object_px > TABLE_OBJECT_PX:
        scale = TABLE_OBJECT_PX / object_px
        size = (max(1, round(w * scale)), max(1, round(h * scale)))
        frame = cv2.resize(frame, size, interpolation=cv2.INTER_AREA)
    sx, sy = frame.shape[1] / w, frame.shape[0] / h
    shrunk = [
        Sample(s.name, (s.u_px + 0.5) * sx - 0.5, (s.v_px + 0.5) * sy - 0.5, s.image)
        for s in samples
    ]
    lab = lab_of(frame)
    ring = _ring(frame, shrunk, 1.0 * object_px * sx, 2.5 * object_px * sx)
    if samples and not len(ring):
        raise SampleError(
            str(samples[0]),
            f"the first image ({w}x{h} px) shows no table around the samples (its colour "
            f"is read {object_px:.0f}-{2.5 * object_px:.0f} px from them): give whole "
            "frames of the table with the objects on it",
        )
    # no samples: the frame's median
    table = np.median(lab_of(ring) if len(ring) else lab.reshape(-1, 3), axis=0)
    near = (np.linalg.norm(lab - table, axis=-1) <= TABLE_DELTA_E).astype(np.uint8)
    k = max(3, int(2 * object_px * sx) | 1)
    closed = cv2.morphologyEx(
        near, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
    )
    n, labels, stats, _ = cv2.connectedComponentsWithStats(closed, connectivity=8)
    if n < 2:
        return table, None
    big = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    if stats[big, cv2.CC_STAT_AREA] < TABLE_MIN_SHARE * frame.shape[0] * frame.shape[1]:
        return table, None
    pts = cv2.findNonZero((labels == big).astype(np.uint8))
    hull = cv2.convexHull(pts)
    poly = cv2.approxPolyDP(hull, 2.0, closed=True).reshape(-1, 2)
    # a pixel on the shrunk frame's edge stands for the frame's edge, not the centre of the
    # block it was shrunk from (1.1 px in from it on a 4000x3000 photo): a table found
    # over the whole frame covers the whole frame
    last_u, last_v = frame.shape[1] - 1, frame.shape[0] - 1
    return table, [(_full_px(u, sx, last_u, w), _full_px(v, sy, last_v, h)) for u, v in poly[:64]]


def _full_px(p: int, scale: float, last: int, side: int) -> float:
    """A shrunk frame's pixel ``p`` (its last ``last``) in the frame's own pixels [px]."""
    if p <= 0:
        return 0.0
    if p >= last:
        return float(side - 1)
    return float((p + 0.5) / scale - 0.5)


def teach(
    frames: Sequence[np.ndarray],
    samples: Sequence[Sample],
    *,
    radius_px: float = 4.0,
    object_px: float = 32.0,
    work_area_px: list[tuple[float, float]] | None = None,
    find_area: bool = True,
) -> Taught:
    """Fit each sampled class's colour from its samples' pixels.

    Args:
        frames: The 8-bit BGR frames, (H, W, 3) each.
        samples: The clicks; each class sampled at least once.
        radius_px: Pixels within this of a click are its samples [px].
        object_px: About one object's width in the frames [px] (where the table is).
        work_area_px: The work area, if the user gives one.
        find_area: Find the table's outline as the work area when none is given.

    Raises:
        SampleError: a sample outside its image, on a grey or black pixel or the
            table's colour, two classes sampled on the same colour or one class on two
            colours, a class with no sample inside ``work_area_px``, or a first frame
            with no table around the samples.
    """
    for s in samples:  # before anything is read around them
        h, w = frames[s.image].shape[:2]
        if not (0 <= s.u_px < w and 0 <= s.v_px < h):
            raise SampleError(
                str(s), f"is outside the image ({w}x{h} px): 0 <= U < {w}, 0 <= V < {h}"
            )
    first = frames[0]
    area = work_area_px
    if area is not None:
        _check_work_area(area, frames, samples)
    # the table around the first frame's samples; with none there, around the others'
    # pixels (one camera: the table is where the objects stand)
    around = [s for s in samples if s.image == 0] or list(samples)
    table_lab, found = find_table(first, around, object_px)
    if area is None and find_area:
        area = found
    ref = tuple(float(v) for v in median_bgr(first, area_mask(area, first.shape) if area else None))
    reference = (ref[0], ref[1], ref[2])
    balanced = [balance(f, reference, area_mask(area, f.shape) if area else None) for f in frames]
    pixels: dict[str, list[np.ndarray]] = {}
    for s in samples:
        lab = _like_click(balanced[s.image], s, radius_px, table_lab)
        c, lightness = float(np.median(chroma(lab))), float(np.median(lab[:, 0]))
        if c < CHROMA_MIN or lightness < LIGHTNESS_MIN:
            advice = (
                "it is white, a highlight or a blown-out top: click on the object's coloured side"
                if lightness >= WHITE_LIGHTNESS
                else "click on the object's colour"
            )
            raise SampleError(
                str(s),
                f"is on a grey or black pixel (chroma {c:.0f}, lightness {lightness:.0f}; "
                f"a colour needs chroma >= {CHROMA_MIN:g}): {advice}",
            )
        off_table = float(np.linalg.norm(np.median(lab, axis=0) - table_lab))
        if off_table <= TABLE_DELTA_E:
            raise SampleError(
                str(s),
                f"is on the table's colour (ΔE {off_table:.0f} from it; an object's must "
                f"differ by more than {TABLE_DELTA_E:g}): click on an object of the class",
            )
        pixels.setdefault(s.name, []).append(lab)
    _refuse_two_colours(pixels, samples)
    colours = {name: fit_clicks(p) for name, p in pixels.items()}
    _refuse_shared(colours, samples)
    # the table as the classifier sees it (at the samples' lightness unless clipped)
    table_clipped = clipped_bgr(np.array(reference))
    d_table = {n: float(distance(m, table_lab, table_clipped)) for n, m in colours.items()}
    colours = {
        n: m.model_copy(update={"max_distance": max(MIN_DISTANCE, d_table[n] - TABLE_MARGIN)})
        if d_table[n] < m.max_distance + TABLE_MARGIN
        else m
        for n, m in colours.items()
    }
    ref = (float(reference[0]), float(reference[1]), float(reference[2]))
    return Taught(
        colours, ref, area, (float(table_lab[0]), float(table_lab[1]), float(table_lab[2]))
    )


def _check_work_area(
    area: Sequence[tuple[float, float]], frames: Sequence[np.ndarray], samples: Sequence[Sample]
) -> None:
    """Raise if a given work area holds none of a class's samples.

    Nothing outside the work area is classified: such a config detects nothing of the
    class and says nothing.
    """
    inside: dict[str, bool] = {}
    for s in samples:
        mask = area_mask(area, frames[s.image].shape)
        inside[s.name] = inside.get(s.name, False) or bool(mask[int(s.v_px), int(s.u_px)])
    for name, any_inside in inside.items():
        if not any_inside:
            given = " ".join(str(s) for s in samples if s.name == name)
            raise SampleError(
                given,
                f"class '{name}' has no sample inside --work-area (nothing outside it is "
                "classified): give a work area around the objects, or --whole-frame",
            )


def _refuse_two_colours(pixels: dict[str, list[np.ndarray]], samples: Sequence[Sample]) -> None:
    """Raise if one class was sampled on two colours: one ellipse for both fits neither.

    Each sample's colour is fitted alone (:func:`~mearm.vision.learned.fit_colour`); two
    samples are two colours when neither's centre is a colour of the other, by the
    distance the classifier uses (:func:`~mearm.vision.learned.distance`, open outwards:
    a duller and a more vivid cube of one hue are one colour) beyond the fit's
    ``max_distance``.
    """
    for name, labs in pixels.items():
        clicks = [s for s in samples if s.name == name]
        fits = [fit_colour(lab) for lab in labs]
        centres = [np.array([m.chroma_lightness or 0.0, *m.ab_mean]) for m in fits]
        for i in range(len(fits)):
            for j in range(i + 1, len(fits)):
                apart = min(
                    float(distance(fits[i], centres[j])), float(distance(fits[j], centres[i]))
                )
                if apart > min(fits[i].max_distance, fits[j].max_distance):
                    raise SampleError(
                        f"{clicks[i]} {clicks[j]}",
                        f"class '{name}' was sampled on two different colours (distance "
                        f"{apart:.1f}, one colour within {fits[i].max_distance:g}): sample "
                        "each class on its own objects",
                    )


def _refuse_shared(colours: dict[str, LearnedColour], samples: Sequence[Sample]) -> None:
    """Raise if one class's colour lies inside another's ellipse: sampled on one colour.

    The ellipses closed all round (:func:`~mearm.vision.learned.ellipse_distance`): what
    was sampled, not what each accepts (a dull class open outwards reaches far in chroma;
    where two colours claim a pixel the nearer wins).
    """
    names = list(colours)
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            ma, mb = colours[a], colours[b]
            centre_b = np.array([0.0, *mb.ab_mean])
            centre_a = np.array([0.0, *ma.ab_mean])
            overlap = min(
                float(ellipse_distance(ma, centre_b)), float(ellipse_distance(mb, centre_a))
            )
            la, lb = ma.lightness, mb.lightness
            if overlap <= 1.0 and la[0] < lb[1] and lb[0] < la[1]:
                first = next(s for s in samples if s.name == b)
                raise SampleError(
                    str(first),
                    f"classes '{a}' and '{b}' were sampled on the same colour (their "
                    f"ellipses overlap, distance {overlap:.2f}); sample each class on its own "
                    "objects",
                )
