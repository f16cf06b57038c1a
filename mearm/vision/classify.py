r"""Pixel classification by HSV thresholds (paper §4), exact and fast.

The paper's definition, for an 8-bit pixel (r, g, b) with v = max, m = min, d = v − m:

.. math::

    V = v / 255, \quad S = d / v, \quad
    H = 60° \cdot \begin{cases}
        (g - b)/d \bmod 6 & v = r \\ (b - r)/d + 2 & v = g \\ (r - g)/d + 4 & v = b
    \end{cases}

(H = 0 when d = 0), then class *c* when S ≥ S_min, V ≥ V_min and H lies in one of *c*'s
bands; classes are tried in their configured order, so overlapping bands go to the
first. A class map holds code *i* + 1 for class *i* and 0 for no class
(:attr:`~mearm.vision.thresholds.Thresholds.codes`).

:func:`classify_exact` computes this in float64 (exact at integer band edges:
``60·k/d`` is correctly rounded). :class:`PixelClassifier` gets the same answer about
10× faster: OpenCV's 8-bit HSV (hue in 2° bins, S within ±1.5 levels of 255·S) decides
every pixel whose bin lies wholly inside or outside the bands, and only the few pixels
in a bin that straddles a band edge are recomputed exactly. A test checks the two agree
on every one of the 2²⁴ colours.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import numpy.typing as npt

from mearm.vision.thresholds import Thresholds, in_band

# The fast path's 8-bit codes carry this flag: ``_SURE | k`` is surely class k, ``_SURE``
# alone is unsure. ANDed with the floors' 0xFF (pass), 0 (fail) or ``_SURE`` (unsure),
# a sure class stays, fails to 0 or becomes unsure, all in one bitwise AND.
_SURE = 0x80
_UNSURE = _SURE
# Slack on the 8-bit conversion: hue bin b holds true hues within 2b ± (1 + _HUE_SLACK)
# degrees, S level s holds true S within (s ± (0.5 + _S_SLACK)) / 255. OpenCV's
# fixed-point rounding stays well inside these (checked on all 2^24 colours by a test).
_HUE_SLACK_DEG = 1.0
_S_SLACK = 1.0


def equal_mask(a: np.ndarray, value: int) -> np.ndarray:
    """0/255 uint8 mask of ``a == value`` (OpenCV takes arrays of ≤ 4 elements for scalars)."""
    if a.size > 4:
        # OpenCV takes a Python number as a Scalar; its stubs list only array overloads.
        return cv2.compare(a, value, cv2.CMP_EQ)  # type: ignore[call-overload]
    return np.where(a == value, 255, 0).astype(np.uint8)


def and_scalar(a: np.ndarray, value: int) -> np.ndarray:
    """``a & value`` for a uint8 array (see :func:`equal_mask` for why not always OpenCV)."""
    if a.size > 4:
        # OpenCV takes a Python number as a Scalar; its stubs list only array overloads.
        return cv2.bitwise_and(a, value)  # type: ignore[call-overload]
    return a & np.uint8(value)


def hsv_exact(frame_bgr: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact H [deg, 0–360), S [-] and V [-] of 8-bit BGR pixels, float64, shape (...)."""
    px = np.asarray(frame_bgr)
    b, g, r = (px[..., i].astype(np.float64) for i in range(3))
    v = np.maximum(np.maximum(r, g), b)
    d = v - np.minimum(np.minimum(r, g), b)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(v > 0, d / v, 0.0)
        h = np.where(
            v == r,
            np.mod(60.0 * (g - b) / d, 360.0),
            np.where(v == g, 60.0 * (b - r) / d + 120.0, 60.0 * (r - g) / d + 240.0),
        )
    h = np.where(d > 0, h, 0.0)
    return h, s, v / 255.0


def classify_hsv(
    hue_deg: npt.ArrayLike, sat: npt.ArrayLike, val: npt.ArrayLike, thr: Thresholds
) -> np.ndarray:
    """Class codes (*i* + 1 for class *i*, 0 for none), uint8, of HSV in the paper's units.

    Args:
        hue_deg: Hue [deg], in [0, 360).
        sat: Saturation [-], in [0, 1].
        val: Value [-], in [0, 1].
        thr: Bands and floors.
    """
    h = np.asarray(hue_deg, dtype=float)
    ok = (np.asarray(sat) >= thr.saturation_min) & (np.asarray(val) >= thr.value_min)
    out = np.zeros(h.shape, np.uint8)
    for code, bands in reversed(list(enumerate(thr.bands_deg.values(), start=1))):
        hit = np.zeros(h.shape, bool)  # earlier classes win: written last
        for lo, hi in bands:
            hit |= ((h >= lo) & (h <= hi)) if lo <= hi else ((h >= lo) | (h <= hi))
        out[ok & hit] = code
    return out


def classify_exact(frame_bgr: npt.ArrayLike, thr: Thresholds) -> np.ndarray:
    """The paper's classification in float64: class codes, uint8, shape (H, W)."""
    return classify_hsv(*hsv_exact(frame_bgr), thr)


def _class_of_hue(hue_deg: float, thr: Thresholds) -> int:
    for code, bands in enumerate(thr.bands_deg.values(), start=1):
        if any(in_band(hue_deg, band) for band in bands):
            return code
    return 0


def _hue_lut(thr: Thresholds) -> np.ndarray:
    """Per OpenCV hue bin (0–179): the class if every hue the bin may hold agrees.

    ``_SURE | code`` for surely that class, 0 for surely none, else ``_UNSURE``.
    """
    edges = sorted({e for bands in thr.bands_deg.values() for band in bands for e in band})
    lut = np.zeros(256, np.uint8)
    for b in range(180):
        lo, hi = 2.0 * b - 1.0 - _HUE_SLACK_DEG, 2.0 * b + 1.0 + _HUE_SLACK_DEG
        # The class is constant between band edges, so the edges inside [lo, hi], the
        # ends, and the midpoints between them are every case there is.
        crit = [lo, hi] + [e + k for e in edges for k in (-360.0, 0.0, 360.0) if lo < e + k < hi]
        crit.sort()
        probes = crit + [(a + c) / 2 for a, c in zip(crit, crit[1:], strict=False)]
        classes = {_class_of_hue(p % 360.0, thr) for p in probes}
        if len(classes) == 1:
            code = classes.pop()
            lut[b] = _SURE | code if code else 0
        else:
            lut[b] = _UNSURE
    return lut


def _sat_lut(thr: Thresholds) -> np.ndarray:
    """Per 8-bit S level: 0xFF surely S ≥ S_min, 0 surely below, ``_UNSURE`` in between."""
    lut = np.zeros(256, np.uint8)
    for s8 in range(256):
        lo = max(0.0, (s8 - 0.5 - _S_SLACK) / 255.0)
        hi = (s8 + 0.5 + _S_SLACK) / 255.0
        if lo >= thr.saturation_min or thr.saturation_min <= 0.0:
            lut[s8] = 0xFF
        elif hi >= thr.saturation_min:
            lut[s8] = _UNSURE
    return lut


def _val_lut(thr: Thresholds) -> np.ndarray:
    """Per 8-bit V level (exact: OpenCV's V is max(r, g, b)): 0xFF when V ≥ V_min."""
    v = np.arange(256) / 255.0
    return np.where(v >= thr.value_min, 0xFF, 0).astype(np.uint8)


def _levels(lut: np.ndarray) -> tuple[int, int]:
    """The first levels at which a floor's table turns unsure (or passes), and passes.

    The table (:func:`_sat_lut`, :func:`_val_lut`) is 0, then ``_UNSURE``, then 0xFF.
    """
    passes = np.flatnonzero(lut == 0xFF)
    sure = int(passes[0]) if len(passes) else 256
    some = np.flatnonzero(lut != 0)
    first = int(some[0]) if len(some) else 256
    expected = np.zeros(256, np.uint8)
    expected[first:] = _UNSURE
    expected[sure:] = 0xFF
    if not np.array_equal(lut, expected):
        raise AssertionError("a floor's table must be 0, then unsure, then pass")
    return first, sure


def _at_least(channel: np.ndarray, level: int, value: int) -> np.ndarray:
    """``value`` where ``channel`` ≥ ``level`` (0 ≤ level ≤ 256), else 0, uint8."""
    # THRESH_BINARY keeps what is above the threshold: level − 1 (−1: every pixel)
    return cv2.threshold(channel, level - 1, value, cv2.THRESH_BINARY)[1]


def _nonzero(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (u, v) [px] of a 0/255 mask's few set pixels, each (N,), in raster order.

    Only the rows holding one are scanned (a row's sum is one SIMD pass; finding the
    pixels is a scan of every pixel).
    """
    rows = np.flatnonzero(cv2.reduce(mask, 1, cv2.REDUCE_SUM, dtype=cv2.CV_32S))
    xy = cv2.findNonZero(mask[rows]).reshape(-1, 2)  # (N, 2): u and the row's place
    return xy[:, 0], rows[xy[:, 1]]


class PixelClassifier:
    """Fast exact classification of 8-bit BGR frames (see the module docstring).

    Args:
        thresholds: Bands and floors, e.g. ``Thresholds.from_config(classes, vision)``.
    """

    def __init__(self, thresholds: Thresholds):
        self.thresholds = thresholds
        self._hue_lut = _hue_lut(thresholds)
        self._sat_lut = _sat_lut(thresholds)
        self._val_lut = _val_lut(thresholds)
        # the floors are steps: a threshold or two, several times cheaper than a look-up
        self._sat_levels = _levels(self._sat_lut)
        self._val_level = _levels(self._val_lut)[1]
        # The value floor is exact in 8 bits; keep the integer for documentation/tests.
        self.value_min_level = math.ceil(255.0 * thresholds.value_min - 1e-9)

    def classify(self, frame_bgr: np.ndarray) -> np.ndarray:
        """Class codes (*i* + 1 for class *i*, 0 for none) of a (H, W, 3) uint8 BGR frame.

        Returns:
            The class map, uint8 (H, W).
        """
        return self.classify_with_box(frame_bgr)[0]

    def classify_with_box(
        self, frame_bgr: np.ndarray
    ) -> tuple[np.ndarray, tuple[int, int, int, int]]:
        """Class codes as :meth:`classify`, and the box (x, y, w, h) outside which all are 0.

        The box may be loose (it is taken before the exact pass), never too tight.
        """
        h, s, v = cv2.split(cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2HSV))
        codes = cv2.LUT(h, self._hue_lut)
        s_unsure, s_pass = self._sat_levels  # the S table's values, as thresholds
        sat = cv2.bitwise_or(_at_least(s, s_unsure, _UNSURE), _at_least(s, s_pass, 0xFF))
        sv = cv2.bitwise_and(sat, _at_least(v, self._val_level, 0xFF))
        codes = cv2.bitwise_and(codes, sv)  # sure k & pass = k; anything & unsure = unsure
        x, y, w, h_ = cv2.boundingRect(codes)
        if w == 0 or h_ == 0:  # no pixel passes: nothing to refine
            return codes, (0, 0, 0, 0)
        unsure = equal_mask(codes[y : y + h_, x : x + w], _UNSURE)
        codes = and_scalar(codes, 0xFF ^ _SURE)  # drop the flag: unsure → 0, sure → code
        if cv2.countNonZero(unsure):
            us, vs = _nonzero(unsure)
            us, vs = us + x, vs + y
            codes[vs, us] = classify_exact(frame_bgr[vs, us], self.thresholds)
        return codes, (x, y, w, h_)


def median_codes(codes: np.ndarray, kernel: int, count: int) -> tuple[np.ndarray, bool]:
    """Each class's ``kernel``×``kernel`` median filter of a code image, as one code image.

    The same image as filtering each class's 0/255 mask (``codes == k``) with
    ``cv2.medianBlur`` and writing ``k`` where it is set (the filtered masks are
    disjoint: a class holds a majority of the window or not), for one median of the
    codes in the common case. A class holding a majority of a window's pixels fills a
    run of its sorted values that covers the middle one, so the codes' median is that
    class; where a window holds one class and no class, that median is the class exactly
    when it holds a majority. Only a window holding two classes can have a median of a
    class without one; where any does, each class is filtered on its own.

    Args:
        codes: Class codes 1..``count`` (0: none), uint8 (H, W).
        kernel: The median's window side, odd [px].
        count: The number of classes.

    Returns:
        The filtered codes (uint8 (H, W), its own memory), and whether no two classes'
        pixels touch (8-connected) in it: ``True`` when no window held two classes (two
        touching pixels of classes a and b would need a majority of a and one of b in
        overlapping windows, and some window then holds both) or there is one class;
        ``False`` when that is not known.
    """
    if kernel <= 1:
        return codes.copy(), count <= 1
    median = cv2.medianBlur(codes, kernel)
    if count <= 1:
        return median, True
    # A window holds two classes exactly when a pixel of one has a higher class within
    # kernel − 1 pixels (both then fit in one window): the highest code that near,
    # a dilation (its border neutral), above the pixel's own. Less one each, wrapping
    # round, the background (0) becomes 255, above which nothing is.
    reach = np.ones((2 * kernel - 1, 2 * kernel - 1), np.uint8)
    one = np.uint8(1)
    if not cv2.countNonZero(cv2.compare(cv2.dilate(codes, reach) - one, codes - one, cv2.CMP_GT)):
        return median, True
    out = np.zeros_like(codes)
    for code in range(1, count + 1):
        np.bitwise_or(out, and_scalar(cv2.medianBlur(equal_mask(codes, code), kernel), code),
                      out=out)  # fmt: skip
    return out, False
