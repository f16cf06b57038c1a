r"""Colours taught from camera frames: colour constancy, CIELAB ellipses, a work area.

A webcam's hues move with its white balance and exposure, and the HSV bands typed into a
config do not hold on its pixels (orange and pink fall into red's band, a blown-out
yellow top into none). Here a class's colour is fitted from pixels a user picks on the
camera's own frames (``mearm learn-colours``) and classified in CIELAB, where equal
distances are roughly equal perceived differences:

- *Colour constancy.* Each frame's channels are scaled (von Kries) so that its median
  colour inside the work area matches the one the colours were learned under
  (``vision.reference_bgr``): a lamp, a brighter day or a camera's auto white balance
  moves the table and the objects alike, and the gains undo it. A gain on 8-bit sRGB is
  a gain on the linear light too ((g·x)^γ = g^γ·x^γ), so this is white balance, not a
  curve.
- *The model.* A colour is an ellipse in the chroma plane (a*, b*) — the samples' mean
  and covariance, widened to a floor so that one click's few pixels still give a usable
  spread — with the lightness L* handled apart, as a range: shading moves L* far more
  than it moves a*b*. A pixel is of the colour when its Mahalanobis distance to the
  ellipse is at most ``max_distance``, its L* is in range and its chroma reaches 0.65 of the
  samples' at equal lightness (a shadow or glare on a white table is faintly tinted, never
  that much; with several clicks, the least of each click's own); where two colours claim
  a pixel the nearer wins. A pixel more coloured
  than the ellipse's centre is measured at the centre's chroma, along its own hue: the
  ellipse is open outwards, so the cube the user clicked need not be the most vivid of
  its class. What lies in no ellipse is no class: an orange cube is not red.
- *Chroma at equal lightness.* In CIELAB a*, b* and L* + 16 are all cube roots of the
  light, so dimming a colour by any factor scales its chroma and L* + 16 alike: the floor
  is the samples' chroma share at their lightness, scaled by (L* + 16) / (L₀ + 16), and a
  pixel's distance to the ellipse is measured with its a*, b* taken to L₀ the same way.
  A dark face of an object keeps its class (its chroma falls with its lightness), and a
  pastel of the hue (lighter and less coloured: salmon or pink beside red) does not. A
  pixel brighter than the samples with a channel clipped is measured as it is: the
  clipping, not the light, took its chroma.
- *Highlights.* A blown-out pixel (a channel clipped) keeps only a faint tint; it joins
  a region of the colour whose hue it has that it touches, so a yellow cube whose top is
  blown out to white is found whole from its yellow edges.
- *The work area.* Nothing outside ``vision.work_area_px`` is classified.

Classification is one table look-up per pixel: the frame's colour, with the gains
applied and 6 bits a channel, indexes a table of class codes built once per set of
colours (detectors of the same colours in one process share it).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence

import cv2
import numpy as np
import numpy.typing as npt

from mearm.config.classes import LearnedColour
from mearm.vision.classify import and_scalar
from mearm.vision.shadows import grow_into_shadows

#: Smallest spread of a learned colour in a* and b* [-]: one click's pixels are nearly
#: one colour, and an object's shaded sides and the camera's noise spread more.
AB_SIGMA_MIN = 5.0
#: How far below and above its samples' lightness a colour reaches [L*]: an object's
#: sides are darker than its top, a highlight lighter.
LIGHTNESS_MARGIN = 20.0
#: Lowest lightness any learned colour takes [L*]: below it no hue is measurable.
LIGHTNESS_MIN = 6.0
#: A learned colour's Mahalanobis radius [-].
MAX_DISTANCE = 3.0
#: Smallest chroma a sample may have [-]: below it the pixel is grey, white or black.
CHROMA_MIN = 12.0
#: A learned colour accepts chroma down to this share of its samples' median chroma, at
#: their lightness (chosen on the development photos, docs/vision.md: 0.5 let bluish
#: shadows in).
CHROMA_SHARE = 0.65
#: L* + this is what a*, b* scale with when the light does (CIELAB's cube root) [L*].
LIGHTNESS_OFFSET = 16.0
#: Largest gain colour constancy applies to a channel (and smallest, its inverse).
MAX_GAIN = 4.0
#: Every this-many-th row and column gives the frame's median colour.
MEDIAN_STRIDE = 8
#: A blown-out pixel joins a region of a colour whose hue it has within this [deg] …
HIGHLIGHT_HUE_DEG = 30.0
#: … when its chroma reaches this [-].
HIGHLIGHT_CHROMA = 4.0
#: The flag, in the classifier's table, of a blown-out colour that may join a region.
HIGHLIGHT = 0x80
#: Bits of each channel the learned classifier's table is indexed by.
COLOUR_BITS = 6
#: A channel at this level or above is clipped [8-bit]: the top cell of the classifier's
#: table (:data:`COLOUR_BITS`).
CLIPPED = 256 - (1 << (8 - COLOUR_BITS))
#: The table's colour: pixels within this CIELAB distance of the colour around the samples.
TABLE_DELTA_E = 14.0
#: OpenCV's remap takes images under this many pixels a side (SHRT_MAX).
REMAP_MAX_PX = 32767


def reference_lab(reference_bgr: Sequence[float]) -> np.ndarray:
    """CIELAB of the table's colour (``vision.reference_bgr``, float B, G, R), (3,)."""
    return lab_of(np.clip(np.round(np.asarray(reference_bgr, dtype=float)), 0, 255))


def lab_of(pixels_bgr: npt.ArrayLike) -> np.ndarray:
    """CIELAB (L* in [0, 100], a*, b*) of 8-bit BGR pixels, float, shape (..., 3)."""
    px = np.asarray(pixels_bgr, dtype=np.uint8)
    flat = px.reshape(1, -1, 3).astype(np.float32) / 255.0
    return cv2.cvtColor(flat, cv2.COLOR_BGR2Lab).reshape(px.shape).astype(float)


def chroma(lab: npt.ArrayLike) -> np.ndarray:
    """Chroma √(a*² + b*²) of CIELAB colours (..., 3) [-]."""
    c = np.asarray(lab, dtype=float)
    return np.hypot(c[..., 1], c[..., 2])


def fit_colour(lab: npt.ArrayLike, *, max_distance: float = MAX_DISTANCE) -> LearnedColour:
    """The colour of sample pixels: their a*b* ellipse and lightness range.

    Args:
        lab: The samples' CIELAB colours, (N, 3), N ≥ 1.
        max_distance: The ellipse's Mahalanobis radius [-].
    """
    c = np.asarray(lab, dtype=float).reshape(-1, 3)
    ab = c[:, 1:]
    mean = ab.mean(axis=0)
    cov = np.cov(ab.T) if len(ab) > 2 else np.zeros((2, 2))
    cov = cov + AB_SIGMA_MIN**2 * np.eye(2)
    lo, hi = np.percentile(c[:, 0], [5, 95])
    return LearnedColour(
        ab_mean=(float(mean[0]), float(mean[1])),
        ab_cov=(float(cov[0, 0]), float(cov[0, 1]), float(cov[1, 1])),
        lightness=(
            float(max(LIGHTNESS_MIN, lo - LIGHTNESS_MARGIN)),
            float(min(100.0, hi + LIGHTNESS_MARGIN)),
        ),
        max_distance=max_distance,
        chroma_min=float(max(CHROMA_MIN, CHROMA_SHARE * np.median(chroma(c)))),
        chroma_lightness=float(np.clip(np.median(c[:, 0]), 0.0, 100.0)),
    )


def fit_clicks(
    clicks: Sequence[npt.ArrayLike], *, max_distance: float = MAX_DISTANCE
) -> LearnedColour:
    """A class's colour from its clicks: their samples pooled, the chroma floor the least.

    :func:`fit_colour` of every click's samples together, but its chroma floor the least
    of each click's own. Each click is a cube the user says is of the class; a floor at
    0.65 of the pooled samples' median chroma lay over a clicked cube duller than that
    share of the others (a second click on a duller cube, the remedy for one click's
    floor, did not make that cube found). Each click's floor (:func:`fit_colour`'s, at its
    own samples' lightness) is taken to the pooled samples' lightness L₀ as
    :func:`chroma_floor` scales it with the lightness, and the least is the class's. One
    click: :func:`fit_colour`'s colour, unchanged.

    Args:
        clicks: Each click's samples' CIELAB colours, (N_i, 3) each, N_i ≥ 1; at least one.
        max_distance: The ellipse's Mahalanobis radius [-].
    """
    labs = [np.asarray(lab, dtype=float).reshape(-1, 3) for lab in clicks]
    pooled = fit_colour(np.concatenate(labs), max_distance=max_distance)
    floors = []
    for lab in labs:
        own = fit_colour(lab, max_distance=max_distance)
        assert own.chroma_lightness is not None and pooled.chroma_lightness is not None
        scale = (pooled.chroma_lightness + LIGHTNESS_OFFSET) / (
            own.chroma_lightness + LIGHTNESS_OFFSET
        )
        floors.append(own.chroma_min * scale)
    return pooled.model_copy(update={"chroma_min": float(min(floors))})


def distance(
    model: LearnedColour, lab: npt.ArrayLike, clipped: npt.ArrayLike | None = None
) -> np.ndarray:
    """Distance of CIELAB colours (..., 3) to a colour, at its samples' lightness [-].

    A colour is first taken to the samples' lightness L₀: its a*, b* times
    (L₀ + 16) / (L* + 16), as dimming or brightening the light scales them (module
    docstring), so a shaded face of an object is its own colour, and a pastel (lighter
    and less coloured) is farther off than it looks. Not a pixel brighter than the
    samples with a channel clipped (``clipped``, (...,) bool; :func:`clipped_bgr`): the
    clipping took its chroma, so it is measured at its own lightness. Then a colour more
    coloured than the ellipse's centre is brought in along its own hue to the centre's
    chroma: a more coloured pixel of the taught hue (a brighter lamp, a camera's
    saturation, a more vivid cube of the class) is more of the colour, never another one;
    the hue decides. A less coloured one is measured as it is (the ellipse and the chroma
    floor keep out pastels, glare and shadows). :func:`ellipse_distance` of the colour so
    brought in.
    """
    c = np.asarray(lab, dtype=float)
    a, b = c[..., 1], c[..., 2]
    if model.chroma_lightness is not None:
        lit = (model.chroma_lightness + LIGHTNESS_OFFSET) / (
            np.maximum(c[..., 0], 0.0) + LIGHTNESS_OFFSET
        )
        if clipped is not None:
            lit = np.where(np.asarray(clipped, dtype=bool) & (lit < 1.0), 1.0, lit)
        a, b = a * lit, b * lit
    c0 = float(np.hypot(model.ab_mean[0], model.ab_mean[1]))
    cc = np.hypot(a, b)
    # a centre too faint to have a hue (chroma under CHROMA_MIN) is measured as it is
    scale = np.where((cc > c0) & (c0 >= CHROMA_MIN), c0 / np.maximum(cc, 1e-12), 1.0)
    return _mahalanobis(model, a * scale, b * scale)


def clipped_bgr(pixels_bgr: npt.ArrayLike) -> np.ndarray:
    """Whether 8-bit BGR pixels (..., 3) have a channel clipped: at :data:`CLIPPED` or above."""
    return np.asarray(pixels_bgr).max(axis=-1) >= CLIPPED


def ellipse_distance(model: LearnedColour, lab: npt.ArrayLike) -> np.ndarray:
    """Mahalanobis distance of CIELAB colours (..., 3) to a colour's a*b* ellipse [-].

    The ellipse closed all round: how far a colour is from what the samples were.
    """
    c = np.asarray(lab, dtype=float)
    return _mahalanobis(model, c[..., 1], c[..., 2])


def _mahalanobis(model: LearnedColour, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    saa, sab, sbb = model.ab_cov
    det = saa * sbb - sab * sab
    da, db = a - model.ab_mean[0], b - model.ab_mean[1]
    return np.sqrt(np.maximum((sbb * da * da - 2 * sab * da * db + saa * db * db) / det, 0.0))


def chroma_floor(model: LearnedColour, lightness: npt.ArrayLike) -> np.ndarray:
    """The least chroma the colour accepts at each lightness L* (...,) [-].

    ``chroma_min`` at the samples' lightness L₀, times (L* + 16) / (L₀ + 16): the chroma
    the samples' colour keeps when the light dims or brightens it (module docstring);
    never under :data:`CHROMA_MIN`, where a pixel is grey. Without L₀, ``chroma_min``.
    """
    lit = np.asarray(lightness, dtype=float)
    if model.chroma_lightness is None:
        return np.full(lit.shape, model.chroma_min)
    scale = (np.maximum(lit, 0.0) + LIGHTNESS_OFFSET) / (model.chroma_lightness + LIGHTNESS_OFFSET)
    return np.maximum(model.chroma_min * scale, min(CHROMA_MIN, model.chroma_min))


def accepts(
    model: LearnedColour, lab: npt.ArrayLike, clipped: npt.ArrayLike | None = None
) -> np.ndarray:
    """Whether CIELAB colours (..., 3) are of the colour: in its ellipse and lightness.

    ``clipped``: where the pixels have a channel clipped (:func:`distance`).
    """
    c = np.asarray(lab, dtype=float)
    lo, hi = model.lightness
    floor = chroma_floor(model, c[..., 0])
    inside = (distance(model, c, clipped) <= model.max_distance) & (chroma(c) >= floor)
    return inside & (c[..., 0] >= lo) & (c[..., 0] <= hi)


def area_mask(polygon_px: Sequence[tuple[float, float]] | None, shape: Sequence[int]) -> np.ndarray:
    """0/255 uint8 mask (H, W) of a work-area polygon (u, v) [px]; all 255 for ``None``."""
    h, w = int(shape[0]), int(shape[1])
    if polygon_px is None:
        return np.full((h, w), 255, np.uint8)
    mask = np.zeros((h, w), np.uint8)
    pts = np.round(np.asarray(polygon_px, dtype=float)).astype(np.int32)
    cv2.fillPoly(mask, [pts], 255)
    return mask


def median_bgr(frame_bgr: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
    """The median colour (B, G, R) of a frame's pixels inside ``mask``, (3,).

    Read on every :data:`MEDIAN_STRIDE`-th row and column; the whole frame's if the mask
    is empty.
    """
    step = MEDIAN_STRIDE
    inside = None
    if mask is not None:
        inside = (mask[::step, ::step] > 0).view(np.uint8)
        if not cv2.countNonZero(inside):
            inside = None
    width = frame_bgr.shape[1]
    if width % step == 0 and frame_bgr.strides[1:] == (3, 1):
        # every step-th row read as width/step pixels of 3·step channels, of which the
        # first three are the sampled pixel's: its histograms without a copy
        rows = frame_bgr[::step].reshape(-1, width // step, 3 * step)
        count = rows.shape[0] * rows.shape[1] if inside is None else cv2.countNonZero(inside)
        hist = [cv2.calcHist([rows], [c], inside, [256], [0, 256]).ravel() for c in range(3)]
    else:
        sub = frame_bgr[::step, ::step].reshape(-1, 3)
        if inside is not None:
            sub = sub[inside.reshape(-1) > 0]
        count = len(sub)
        hist = [np.bincount(sub[:, c], minlength=256) for c in range(3)]
    # np.median's value, from each channel's histogram (8-bit levels: no sort needed):
    # the mean of the two middle levels, (N − 1)//2-th and N//2-th (one when N is odd)
    cum = np.cumsum(hist, axis=1)
    lo, hi = np.argmax(cum > (count - 1) // 2, axis=1), np.argmax(cum > count // 2, axis=1)
    return (lo + hi) / 2.0


def gains(
    frame_bgr: np.ndarray, reference_bgr: Sequence[float], mask: np.ndarray | None = None
) -> np.ndarray:
    """Per-channel gains (3,) that take the frame's median (in ``mask``) to ``reference_bgr``.

    Held within [1/:data:`MAX_GAIN`, :data:`MAX_GAIN`].
    """
    med = np.maximum(median_bgr(frame_bgr, mask), 1.0)
    return np.clip(np.asarray(reference_bgr, dtype=float) / med, 1.0 / MAX_GAIN, MAX_GAIN)


def _channel_lut(gain: np.ndarray, shift: int = 0) -> np.ndarray:
    """OpenCV's 3-channel look-up table (256, 1, 3) uint8.

    Each level times its channel's gain, clipped, then shifted right by ``shift`` bits.
    """
    levels = np.clip(np.round(np.arange(256, dtype=float)[:, None] * gain[None, :]), 0, 255)
    return (levels.astype(np.uint8) >> shift).reshape(256, 1, 3)


def balance(
    frame_bgr: np.ndarray, reference_bgr: Sequence[float], mask: np.ndarray | None = None
) -> np.ndarray:
    """``frame_bgr`` with each channel scaled so its median (in ``mask``) is ``reference_bgr``.

    The gains are :func:`gains`'; values clip at 255.
    """
    return balance_by(frame_bgr, gains(frame_bgr, reference_bgr, mask))


def balance_by(frame_bgr: np.ndarray, gain: npt.ArrayLike) -> np.ndarray:
    """``frame_bgr`` with each channel times its gain (B, G, R), clipped at 255."""
    return cv2.LUT(frame_bgr, _channel_lut(np.asarray(gain, dtype=float)))


@functools.lru_cache(maxsize=1)
def _cells() -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """The table's cells, worked out once a process.

    Their centres' CIELAB colours (2^18, 3) and chroma (2^18,), whether a channel is
    clipped there (2^18,), and their places in the table (rows, columns). Colour
    (b, g, r) lies at row r, column b + 256·g: where a pixel's bytes b, g, r, 0, read as
    two 16-bit integers, point (x, y), as OpenCV's remap reads them.
    """
    step = 1 << (8 - COLOUR_BITS)
    levels = np.arange(1 << COLOUR_BITS)
    b, g, r = np.meshgrid(levels, levels, levels, indexing="ij")
    centre = (np.stack([b, g, r], axis=-1) * step + (step - 1) / 2.0).reshape(-1, 3)
    flat = (centre / 255.0).astype(np.float32).reshape(1, -1, 3)
    lab = cv2.cvtColor(flat, cv2.COLOR_BGR2Lab).reshape(-1, 3).astype(float)
    places = (r.reshape(-1), (b | (g << 8)).reshape(-1))
    arrays = (lab, chroma(lab), clipped_bgr(centre), *places)
    for a in arrays:
        a.flags.writeable = False
    return lab, arrays[1], arrays[2], places


@functools.lru_cache(maxsize=8)
def _table_of(models: tuple[tuple[int, LearnedColour], ...]) -> np.ndarray:
    """:class:`LearnedClassifier`'s table of ``models`` ((code, colour), ...), read-only.

    Each of the 2^18 cells' centres is classified as :func:`accepts` and :func:`distance`
    would, but the distance is worked out only for the cells that pass the cheap tests
    first (the lightness range and the chroma floor), and once a colour, not twice. A
    process that makes detectors of the same colours again (an experiment's trials, a
    bench's repeats) shares the table: it is never written.
    """
    lab, c, clipped, places = _cells()
    lightness = lab[:, 0]
    best = np.full(len(lab), np.inf)
    codes = np.zeros(len(lab), np.uint8)
    for code, model in models:
        lo, hi = model.lightness
        cheap = (c >= chroma_floor(model, lightness)) & (lightness >= lo) & (lightness <= hi)
        at = np.flatnonzero(cheap)
        d = distance(model, lab[at], clipped[at])
        inside = d <= model.max_distance
        at, d = at[inside], d[inside]
        nearer = d < best[at]
        codes[at[nearer]], best[at[nearer]] = code, d[nearer]
    # blown-out pixels: a channel clipped, the hue of a colour, a little chroma
    highlight = np.zeros(len(lab), np.uint8)
    at = np.flatnonzero(clipped & (c >= HIGHLIGHT_CHROMA) & (codes == 0))
    hue = np.arctan2(lab[at, 2], lab[at, 1])
    for code, model in models:
        h0 = np.arctan2(model.ab_mean[1], model.ab_mean[0])
        near = np.abs(np.angle(np.exp(1j * (hue - h0)))) <= np.radians(HIGHLIGHT_HUE_DEG)
        highlight[at[near]] = code
    # one byte a colour: its code, or HIGHLIGHT | the code of the colour it may join
    table = np.zeros((1 << COLOUR_BITS, 1 << (8 + COLOUR_BITS)), np.uint8)
    table[places] = np.where(codes > 0, codes, np.where(highlight > 0, HIGHLIGHT | highlight, 0))
    table.flags.writeable = False
    return table


class LearnedClassifier:
    """Class codes of the learned colours, one table look-up per pixel.

    The table is indexed by the pixel's colour with :data:`COLOUR_BITS` bits a channel
    (after the frame's gains): each of its 2^18 colours is classified once, at the
    centre of its cell, when the first classifier of these colours is made (later ones
    share its table, :func:`_table_of`); a frame is then one colour transform (gains and
    quantisation of the three channels at once), and a look-up of each pixel's cells,
    read as a place in the table, by ``remap``.

    Args:
        models: Per colour's code (1…), its learned colour.
        table_bgr: The table's colour the gains take the frame to
            (``vision.reference_bgr``), for the blown-out pixels of a brighter frame
            (:meth:`_clipped_as_seen`); ``None``: those are read as gained.
    """

    def __init__(
        self, models: Mapping[int, LearnedColour], table_bgr: Sequence[float] | None = None
    ):
        self.models = dict(models)
        self._table = _table_of(tuple(self.models.items()))
        self._table_ab = None if table_bgr is None else reference_lab(table_bgr)[1:]

    def classify(self, frame_bgr: np.ndarray, gain: npt.ArrayLike | None = None) -> np.ndarray:
        """Class codes (0: none) of an 8-bit BGR frame, uint8 (H, W).

        Args:
            frame_bgr: The frame, (H, W, 3) uint8.
            gain: Per-channel gains (B, G, R) to apply first (:func:`gains`); ``None``: 1.
        """
        looked_up = self._looked_up(frame_bgr, gain)
        return cv2.threshold(looked_up, HIGHLIGHT - 1, 0, cv2.THRESH_TOZERO_INV)[1]

    def classify_with_highlights(
        self, frame_bgr: np.ndarray, gain: npt.ArrayLike | None = None
    ) -> np.ndarray:
        """Class codes as :meth:`classify`, each region grown into its blown-out pixels.

        A pixel with a channel clipped (a highlight, a top blown out to white) keeps a
        faint tint of its colour's hue: such a pixel, within :data:`HIGHLIGHT_HUE_DEG`
        of a colour's hue and of chroma at least :data:`HIGHLIGHT_CHROMA`, joins a region
        of that colour it touches (:func:`mearm.vision.shadows.grow_into_shadows`: a
        highlight alone never becomes an object).
        """
        looked_up = self._looked_up(frame_bgr, gain)
        g = None if gain is None else np.asarray(gain, dtype=float)
        if g is not None and (g < 1.0).any() and self._table_ab is not None:
            self._clipped_as_seen(frame_bgr, g, looked_up)
        if cv2.minMaxLoc(looked_up)[1] < HIGHLIGHT:  # no blown-out pixel
            return looked_up
        strong = cv2.threshold(looked_up, HIGHLIGHT - 1, 0, cv2.THRESH_TOZERO_INV)[1]
        weak = and_scalar(looked_up, HIGHLIGHT - 1)
        return grow_into_shadows(strong, weak, max(self.models, default=0))

    def _clipped_as_seen(
        self, frame_bgr: np.ndarray, gain: np.ndarray, looked_up: np.ndarray
    ) -> None:
        """Blown-out pixels that a gain below 1 took under the clip, as highlights (in place).

        A channel the camera clipped holds its level or more. A gain below 1 (a frame
        brighter than the one the colours were taught on) takes that channel under the
        clip, though its light was never measured, and the pixel reads greyer than it is:
        a red top blown out to (238, 242, 255) in a frame 20 % brighter read as grey, and
        the red kept only 0.6 of its area. A pixel of no class that the gains do not take
        to the table's colour (a* and b* farther than :data:`TABLE_DELTA_E` from it) is
        looked up again as the camera gave it, as in a frame the gains leave alone (the
        same pixel there is read so); what that finds may only join a region of its colour
        as a highlight (:meth:`classify_with_highlights`), never make one. A pixel the
        gains take to the table's colour is the table (a wood table's clipped red), and
        one of a class keeps it (an over-exposed object whose gained level its class
        accepts). Only with the table's colour (``table_bgr``): the gains need it anyway.
        """
        dimmed = gain < 1.0
        clipped = np.zeros(looked_up.shape, dtype=bool)
        for c in np.flatnonzero(dimmed).tolist():
            clipped |= frame_bgr[..., c] >= CLIPPED
        clipped &= looked_up == 0
        ys, xs = np.nonzero(clipped)
        if not len(ys):
            return
        # each channel's cell after the gains, as :meth:`_looked_up` finds it
        cells = _channel_lut(gain, 8 - COLOUR_BITS)[frame_bgr[ys, xs], 0, [0, 1, 2]]
        b, g, r = cells.astype(np.int64).T
        at = (b << (2 * COLOUR_BITS)) | (g << COLOUR_BITS) | r
        not_table = np.hypot(*(_cells()[0][at, 1:] - self._table_ab).T) > TABLE_DELTA_E
        # as the camera gave it: the table's cell of each level (the gains' rounding at 1)
        seen = frame_bgr[ys[not_table], xs[not_table]].astype(np.int64) >> (8 - COLOUR_BITS)
        entry = self._table[seen[:, 2], seen[:, 0] | (seen[:, 1] << 8)]
        looked_up[ys[not_table], xs[not_table]] = np.where(entry > 0, entry | HIGHLIGHT, 0)

    def _looked_up(self, frame_bgr: np.ndarray, gain: npt.ArrayLike | None) -> np.ndarray:
        """Each pixel's entry in the table, uint8 (H, W).

        Each channel's cell is its level times its gain, rounded, then shifted right by
        8 − :data:`COLOUR_BITS` bits (as :func:`_channel_lut`'s): that is the level times
        the gain over the cell's width, less ``3/8``, rounded, and held at the top cell,
        which OpenCV's ``transform`` computes for all three channels at once (in single
        precision: a level within a millionth of a cell's edge may fall in either cell).
        The cells' bytes b, g, r and a 0 are then, read as two 16-bit integers, the
        colour's place in the table, which ``remap`` reads (nearest, no interpolation).
        """
        g = np.ones(3) if gain is None else np.asarray(gain, dtype=float)
        width = 1 << (8 - COLOUR_BITS)
        scale = np.zeros((3, 4))
        scale[[0, 1, 2], [0, 1, 2]] = g / width
        scale[:, 3] = 0.5 / width - 0.5  # floor((x + 1/2) / width), as a rounding
        top = (1 << COLOUR_BITS) - 1
        quads = cv2.cvtColor(cv2.transform(frame_bgr, scale), cv2.COLOR_BGR2BGRA)
        if quads.size > 4:
            # OpenCV takes a tuple as a Scalar; its stubs before 5.1 list only array
            # overloads (5.1's take it: the ignore is unused there)
            cv2.min(quads, (top, top, top, 0), dst=quads)  # type: ignore[call-overload, unused-ignore]
        else:  # one pixel's four bytes, which OpenCV would take for a Scalar
            np.minimum(quads, np.array([top, top, top, 0], np.uint8), out=quads)
        places = quads.view(np.int16).reshape(*quads.shape[:2], 2)  # (x, y) a pixel
        height, cols = places.shape[:2]
        if max(height, cols) < REMAP_MAX_PX:
            return self._remap(places)
        out = np.empty((height, cols), np.uint8)  # a frame too large for one remap: tiles
        for y in range(0, height, REMAP_MAX_PX - 1):
            for x in range(0, cols, REMAP_MAX_PX - 1):
                tile = places[y : y + REMAP_MAX_PX - 1, x : x + REMAP_MAX_PX - 1]
                out[y : y + tile.shape[0], x : x + tile.shape[1]] = self._remap(tile)
        return out

    def _remap(self, places: np.ndarray) -> np.ndarray:
        """The table's entries at ``places`` ((h, w, 2) int16 (x, y)), uint8 (h, w)."""
        # no second map: the (x, y) pairs are whole in the first (the stubs before OpenCV
        # 5.1 ask for one; 5.1's do not: the ignore is unused there)
        return cv2.remap(self._table, places, None, cv2.INTER_NEAREST)  # type: ignore[call-overload, unused-ignore]
