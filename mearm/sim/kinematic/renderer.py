"""The simulated camera's picture of the table (paper §1, §4).

A frame is drawn in the image through the inverse of the calibration, so an object at
(x, y) cm appears exactly where the calibration says that point is:

1. a table texture: light wood with grain, or grey with mottling (fixed per seed);
2. white paper sheets, if asked for;
3. for each object a soft drop shadow and then its top in its class's colour
   (``draw_rgb``), shape (``shape``: a disc, a square or an equilateral triangle, turned
   by the object's yaw) and size (``diameter_cm``): its coverage of each pixel
   from 4×4 samples mapped to the table (anti-aliased, exact for any homography), its
   top shaded darker towards the rim (symmetric about its centre, so its centroid is
   unbiased);
4. shadows, if asked for (a soft darkening);
5. light: ``brightness`` × a linear gradient of ±``gradient`` from the top-left to the
   bottom-right corner;
6. specular highlights, if asked for (white added, so saturation drops);
7. Gaussian sensor noise of ``noise_std`` levels: a window of a bank of noise drawn once
   per renderer, at an offset seeded by (seed, frame index);
8. rounded (half to even) and clipped to 8 bits.

Steps 1–6 are drawn again only when the discs change, from a kept background (1, 2) and
kept disc patches (3), so a camera looking at an unchanged table pays for the noise only.

The discs are flat: the calibration is taken to hold in the plane of the objects' tops,
as the paper's was measured on the objects (paper §4), so there is no parallax to add.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from mearm.config import CameraConfig, ColorClass
from mearm.config.shape_catalogue import DEFAULT_SHAPE, shape_named
from mearm.errors import ConfigError
from mearm.vision.calibration import Calibration

WOOD_BGR = (95.0, 145.0, 195.0)  # H = 30°, S = 0.51
GREY_BGR = (128.0, 128.0, 128.0)
PAPER_BGR = (238.0, 240.0, 242.0)
_SAMPLES = 4  # per pixel side, for disc coverage


def class_bgr(color_class: ColorClass) -> tuple[int, int, int]:
    """The colour a class's objects are drawn in, 8-bit BGR (OpenCV's order)."""
    r, g, b = color_class.draw_rgb
    return (b, g, r)


@dataclass(frozen=True)
class Disc:
    """A flat object top on the table (a disc by default): an object or a distractor.

    Attributes:
        bgr: Its top's colour (8-bit BGR) in nominal light.
        x_cm: Centre, base frame [cm].
        y_cm: Centre, base frame [cm].
        diameter_cm: Size [cm]: a disc's diameter, a square's or a triangle's side (the
            paper's objects: 2 cm discs, paper §1).
        shape: The shape of the catalogue whose footprint it is
            (:data:`~mearm.config.shape_catalogue.SHAPES`).
        yaw_deg: Its turn about the vertical, base frame [deg]: a square's sides lie
            along x and y at 0, a triangle has a corner towards +y.
    """

    bgr: tuple[int, int, int]
    x_cm: float
    y_cm: float
    diameter_cm: float = 2.0
    shape: str = DEFAULT_SHAPE
    yaw_deg: float = 0.0

    @classmethod
    def of_class(
        cls, color_class: ColorClass, x_cm: float, y_cm: float, yaw_deg: float = 0.0
    ) -> Disc:
        """An object of ``color_class`` at (x, y) [cm]: its colour, size and shape."""
        return cls(
            class_bgr(color_class),
            float(x_cm),
            float(y_cm),
            color_class.diameter_cm,
            color_class.object_shape.name,
            float(yaw_deg),
        )

    def gauge(self, x_cm: np.ndarray, y_cm: np.ndarray) -> np.ndarray:
        """Where table points lie in the footprint: ≤ 1 inside, 1 on the edge, 0 at the centre.

        The footprint's gauge (Minkowski) function: the distance from the centre scaled
        so that the outline is 1 in every direction.
        """
        dx, dy = x_cm - self.x_cm, y_cm - self.y_cm
        footprint = shape_named(self.shape).footprint
        if footprint == "disc":
            return np.hypot(dx, dy) / (self.diameter_cm / 2.0)
        a = np.radians(self.yaw_deg)
        if footprint == "square":
            along = np.cos(a) * dx + np.sin(a) * dy
            across = -np.sin(a) * dx + np.cos(a) * dy
            return np.maximum(np.abs(along), np.abs(across)) / (self.diameter_cm / 2.0)
        inradius = self.diameter_cm / (2.0 * np.sqrt(3.0))
        # the sides' outward normals: away from the corner at yaw + 90° and the other two
        normals = [a - np.pi / 2, a + np.pi / 6, a + 5 * np.pi / 6]
        return np.max([np.cos(n) * dx + np.sin(n) * dy for n in normals], axis=0) / inradius


def class_discs(
    classes: Sequence[ColorClass],
    objects: Iterable[tuple[str, float, float] | tuple[str, float, float, float]],
) -> list[Disc]:
    """Object tops given as (class name, x [cm], y [cm]) or (…, yaw [deg]).

    Raises:
        ConfigError: an object names a class not in ``classes``.
    """
    by_name = {c.name: c for c in classes}
    discs = []
    for name, x, y, *yaw in objects:
        if name not in by_name:
            raise ConfigError(
                None,
                [f"object of class '{name}': not a class (classes: {', '.join(by_name)})"],
            )
        discs.append(Disc.of_class(by_name[name], x, y, *yaw))
    return discs


@dataclass(frozen=True)
class Paper:
    """A white sheet lying on the table: centre, size [cm] and rotation [deg]."""

    x_cm: float
    y_cm: float
    width_cm: float = 21.0
    height_cm: float = 14.8
    angle_deg: float = 0.0


@dataclass(frozen=True)
class Shadow:
    """A soft shadow: light times (1 − depth) inside ``radius_cm``, fading over ``soft_cm``."""

    x_cm: float
    y_cm: float
    radius_cm: float = 4.0
    depth: float = 0.4
    soft_cm: float = 1.5


@dataclass(frozen=True)
class Highlight:
    """A specular highlight: ``strength`` × 255 levels of white, Gaussian of ``sigma_cm``."""

    x_cm: float
    y_cm: float
    sigma_cm: float = 1.0
    strength: float = 0.6


Extra = Disc | Paper | Shadow | Highlight


class TableRenderer:
    """Draw table scenes as the camera sees them.

    The parts of a frame are drawn once and kept: the table (texture and paper), each
    disc's patch and drop shadow. Only a change of the discs draws the lit table again,
    from those parts; the noise of frame *i* is a window of a bank of Gaussian noise
    drawn once per renderer, at an offset drawn from (seed, *i*): every frame has fresh
    noise of ``noise_std``, and the same (discs, frame index) gives the same frame,
    whatever was drawn before.

    Args:
        calibration: Pixel ↔ table map; objects are drawn through its inverse.
        width_px: Frame width [px].
        height_px: Frame height [px].
        table: ``"wood"`` or ``"grey"``.
        noise_std: Sensor noise, standard deviation [8-bit levels].
        brightness: Light level factor [-].
        gradient: Lighting gradient, ± this fraction corner to corner [-].
        seed: Texture seed; frame *i*'s noise uses (seed, i).
        extras: Distractors drawn in every frame: discs of other colours, paper,
            shadows, highlights.
    """

    #: Noise values in the bank beyond one frame's: the range of a frame's offset.
    NOISE_SPARE = 1 << 17
    #: Disc patches and shadows kept (a new scene after this many starts afresh).
    PATCHES_KEPT = 4096

    def __init__(
        self,
        calibration: Calibration,
        width_px: int = 640,
        height_px: int = 480,
        *,
        table: str = "wood",
        noise_std: float = 2.0,
        brightness: float = 1.0,
        gradient: float = 0.15,
        seed: int = 0,
        extras: Sequence[Extra] = (),
    ):
        if table not in ("wood", "grey"):
            raise ValueError(f"table must be 'wood' or 'grey', got {table!r}")
        self.calibration = calibration
        self.size = (int(height_px), int(width_px))
        self.table = table
        self.noise_std = float(noise_std)
        self.brightness = float(brightness)
        self.gradient = float(gradient)
        self.seed = int(seed)
        self.extras = tuple(extras)
        h, w = self.size
        u = np.arange(w, dtype=float)[None, :]
        v = np.arange(h, dtype=float)[:, None]
        ramp = (u / max(w - 1, 1) + v / max(h - 1, 1) - 1.0).astype(np.float32)
        # per channel: a product with a (H, W, 1) factor broadcast over 3 channels is ~10×
        # slower in NumPy than with a contiguous (H, W, 3) one (the same products)
        self._light = _per_channel(self.brightness * (1.0 + self.gradient * ramp))
        background = _texture(self.size, self.table, self.seed)
        if any(isinstance(e, Paper) for e in self.extras):
            background = background.copy()  # the shared texture stays as it is
        for e in self.extras:
            if isinstance(e, Paper):
                self._paper(background, e)
        self._background = background  # texture and paper, before any disc [8-bit levels]
        self._extra_discs = [e for e in self.extras if isinstance(e, Disc)]
        self._patches: dict[
            tuple[object, ...], tuple[tuple[slice, slice], np.ndarray, np.ndarray]
        ] = {}
        self._shades: dict[tuple[float, ...], tuple[tuple[slice, slice], np.ndarray] | None] = {}
        self._scene: tuple[Disc, ...] | None = None
        self._clean = np.empty(0, np.float32)  # the last scene, lit, before noise
        self._noise_bank: np.ndarray | None = None

    @classmethod
    def from_config(
        cls, camera: CameraConfig, calibration: Calibration, extras: Sequence[Extra] = ()
    ) -> TableRenderer:
        """A renderer with the sim settings of the ``camera`` section."""
        return cls(
            calibration,
            camera.width_px,
            camera.height_px,
            table=camera.table,
            noise_std=camera.noise_std,
            brightness=camera.brightness,
            gradient=camera.gradient,
            seed=camera.seed,
            extras=extras,
        )

    def _table_xy(self, roi: tuple[slice, slice] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Table coordinates (x, y) [cm] of the pixels of ``roi`` (all if None), float32.

        Element by element, so a pixel's value does not depend on the box it is in.
        """
        h, w = self.size
        rows, cols = roi if roi is not None else (slice(0, h), slice(0, w))
        u = np.arange(cols.start, cols.stop, dtype=float)[None, :]
        v = np.arange(rows.start, rows.stop, dtype=float)[:, None]
        H = self.calibration.H
        den = H[2, 0] * u + H[2, 1] * v + H[2, 2]
        x = (H[0, 0] * u + H[0, 1] * v + H[0, 2]) / den
        y = (H[1, 0] * u + H[1, 1] * v + H[1, 2]) / den
        return x.astype(np.float32), y.astype(np.float32)

    def render(self, discs: Iterable[Disc], frame_index: int = 0) -> np.ndarray:
        """One frame with ``discs`` (and the renderer's extras) on the table.

        Returns:
            The frame, (H, W, 3) uint8 BGR.
        """
        scene = (*self._extra_discs, *discs)
        if scene != self._scene:
            self._clean = self._redraw(scene)
            self._scene = scene
        if self.noise_std <= 0:
            return np.clip(np.rint(self._clean), 0, 255).astype(np.uint8)
        # cv2.add rounds half to even and saturates, as np.clip(np.rint(·)) does.
        return cv2.add(self._clean, self._noise(frame_index), dtype=cv2.CV_8U)

    def _draw(self, discs: Sequence[Disc]) -> np.ndarray:
        """The table with ``discs`` on it, lit and highlighted, before noise (float32)."""
        h, w = self.size
        img = self._lit(discs, (slice(0, h), slice(0, w)))
        highlights = [e for e in self.extras if isinstance(e, Highlight)]
        if highlights:
            x_cm, y_cm = self._table_xy()
            for e in highlights:
                r2 = (x_cm - e.x_cm) ** 2 + (y_cm - e.y_cm) ** 2
                img += (255.0 * e.strength * np.exp(-0.5 * r2 / e.sigma_cm**2))[..., None]
        return img

    def _redraw(self, discs: Sequence[Disc]) -> np.ndarray:
        """:meth:`_draw` of ``discs``, drawing again only where the last scene changed.

        A sort takes one object at a time: the box of the shadows and tops that came or
        went is drawn again (every step, for every disc there, in the order
        :meth:`_draw` takes), and the rest of the last frame is kept as it is. The same
        pixels, bit for bit.
        """
        box = self._changed_box(discs)
        if box is None:
            return self._draw(discs)
        self._clean[box] = self._lit(discs, box)
        return self._clean

    def _changed_box(self, discs: Sequence[Disc]) -> tuple[slice, slice] | None:
        """The pixel box where ``discs`` differ from the last scene; ``None``: draw all.

        All is drawn again for a first scene, with highlights (they span the frame), and
        when the discs that stay are not in the same order (or some is there twice): a
        pixel two of them cover must see them in the same order as :meth:`_draw`.
        """
        old = self._scene
        if old is None or any(isinstance(e, Highlight) for e in self.extras):
            return None
        if len(set(old)) != len(old) or len(set(discs)) != len(discs):
            return None
        gone, came = set(old) - set(discs), set(discs) - set(old)
        if [d for d in old if d not in gone] != [d for d in discs if d not in came]:
            return None
        boxes = []
        for d in gone | came:
            shade, patch = self._shade(*_drop_shadow(d)), self._patch(d)
            boxes += [part[0] for part in (shade, patch) if part is not None]
        if not boxes:
            return slice(0, 0), slice(0, 0)
        rows = slice(min(b[0].start for b in boxes), max(b[0].stop for b in boxes))
        cols = slice(min(b[1].start for b in boxes), max(b[1].stop for b in boxes))
        return rows, cols

    def _lit(self, discs: Sequence[Disc], box: tuple[slice, slice]) -> np.ndarray:
        """Steps 1–5 of the module docstring in the pixel ``box`` (float32, its shape)."""
        if len(self._patches) > self.PATCHES_KEPT:
            self._patches.clear()
            self._shades.clear()
        img = self._background[box].copy()
        for d in discs:
            _multiply(img, box, self._shade(*_drop_shadow(d)))
        for d in discs:
            patch = self._patch(d)
            if patch is not None:
                roi, keep, paint = patch
                _multiply(img, box, (roi, keep))
                _add(img, box, (roi, paint))
        for e in self.extras:
            if isinstance(e, Shadow):
                _multiply(img, box, self._shade(e.x_cm, e.y_cm, e.radius_cm, e.depth, e.soft_cm))
        img *= self._light[box]
        return img

    def _noise(self, frame_index: int) -> np.ndarray:
        """Frame ``frame_index``'s noise [8-bit levels], (H, W, 3) float32."""
        h, w = self.size
        n = h * w * 3
        if self._noise_bank is None:
            self._noise_bank = _noise_bank(n + self.NOISE_SPARE, self.noise_std, self.seed)
        start = int(np.random.default_rng([self.seed, int(frame_index)]).integers(self.NOISE_SPARE))
        return self._noise_bank[start : start + n].reshape(h, w, 3)

    def _paper(self, img: np.ndarray, p: Paper) -> None:
        x_cm, y_cm = self._table_xy()
        a = np.radians(p.angle_deg)
        dx, dy = x_cm - p.x_cm, y_cm - p.y_cm
        along = np.cos(a) * dx + np.sin(a) * dy
        across = -np.sin(a) * dx + np.cos(a) * dy
        inside = (np.abs(along) <= p.width_cm / 2) & (np.abs(across) <= p.height_cm / 2)
        img[inside] = PAPER_BGR

    def _roi(self, x: float, y: float, reach_cm: float) -> tuple[slice, slice] | None:
        """Pixel box holding the table square of half-side ``reach_cm`` around (x, y)."""
        h, w = self.size
        corners = [[x + sx * reach_cm, y + sy * reach_cm] for sx in (-1, 1) for sy in (-1, 1)]
        px = self.calibration.table_to_pixel(np.array(corners))
        u0, v0 = np.floor(px.min(axis=0)).astype(int) - 2
        u1, v1 = np.ceil(px.max(axis=0)).astype(int) + 3
        u0, v0, u1, v1 = max(u0, 0), max(v0, 0), min(u1, w), min(v1, h)
        if u0 >= u1 or v0 >= v1:
            return None
        return slice(v0, v1), slice(u0, u1)

    def _shade(
        self, x: float, y: float, r: float, depth: float, soft: float
    ) -> tuple[tuple[slice, slice], np.ndarray] | None:
        """A soft darkening's box and the factor the table is multiplied by in it (kept)."""
        key = (x, y, r, depth, soft)
        if key not in self._shades:
            roi = self._roi(x, y, r + soft)
            if roi is None:
                self._shades[key] = None
            else:
                x_cm, y_cm = self._table_xy(roi)
                dist = np.sqrt((x_cm - x) ** 2 + (y_cm - y) ** 2)
                t = np.clip((r + soft / 2 - dist) / max(soft, 1e-6), 0.0, 1.0)
                self._shades[key] = (roi, _per_channel(1.0 - depth * t * t * (3 - 2 * t)))
        return self._shades[key]

    def _patch(self, d: Disc) -> tuple[tuple[slice, slice], np.ndarray, np.ndarray] | None:
        """An object top's box, the share of the table kept and the colour added (kept)."""
        key = (*d.bgr, d.x_cm, d.y_cm, d.diameter_cm, d.shape, d.yaw_deg)
        patch = self._patches.get(key)
        if patch is None:
            patch = self._disc_patch(d)
            if patch is None:
                return None
            self._patches[key] = patch
        return patch

    def _disc_patch(self, d: Disc) -> tuple[tuple[slice, slice], np.ndarray, np.ndarray] | None:
        """An object top's box, the share of the table kept and the colour added in it."""
        roi = self._roi(d.x_cm, d.y_cm, shape_named(d.shape).enclosing_radius_cm(d.diameter_cm))
        if roi is None:
            return None
        (v0, v1), (u0, u1) = (roi[0].start, roi[0].stop), (roi[1].start, roi[1].stop)
        n = _SAMPLES
        offs = (np.arange(n) + 0.5) / n - 0.5
        us = (np.arange(u0, u1)[:, None] + offs).ravel()  # (W·n,)
        vs = (np.arange(v0, v1)[:, None] + offs).ravel()  # (H·n,)
        uu, vv = np.meshgrid(us, vs)
        xy = self.calibration.pixel_to_table(np.stack([uu.ravel(), vv.ravel()], axis=1))
        rho = d.gauge(xy[:, 0], xy[:, 1]).reshape(uu.shape)
        inside = rho <= 1.0
        shade = np.where(inside, 1.0 - 0.12 * rho**2 - 0.15 * (rho > 0.88), 0.0)
        bh, bw = v1 - v0, u1 - u0
        cover = inside.reshape(bh, n, bw, n).mean(axis=(1, 3)).astype(np.float32)
        tone = shade.reshape(bh, n, bw, n).mean(axis=(1, 3)).astype(np.float32)
        color = np.array(d.bgr, np.float32)
        return roi, _per_channel(1.0 - cover), tone[..., None] * color


def _drop_shadow(d: Disc) -> tuple[float, float, float, float, float]:
    """A disc's drop shadow as :meth:`TableRenderer._shade` takes it: (x, y, r, depth, soft)."""
    return d.x_cm + 0.25, d.y_cm - 0.25, d.diameter_cm / 2 + 0.1, 0.3, 0.5


def _overlap(
    box: tuple[slice, slice], roi: tuple[slice, slice]
) -> tuple[tuple[slice, slice], tuple[slice, slice]] | None:
    """Where ``roi`` meets ``box``: as indices into the box, and into the roi's own array."""
    rows, cols = _meet(box[0], roi[0]), _meet(box[1], roi[1])
    if rows is None or cols is None:
        return None
    return (rows[0], cols[0]), (rows[1], cols[1])


def _meet(a: slice, b: slice) -> tuple[slice, slice] | None:
    """Where the ranges ``a`` and ``b`` meet, as indices from a's start and from b's."""
    lo, hi = max(a.start, b.start), min(a.stop, b.stop)
    if lo >= hi:
        return None
    return slice(lo - a.start, hi - a.start), slice(lo - b.start, hi - b.start)


def _multiply(
    img: np.ndarray, box: tuple[slice, slice], part: tuple[tuple[slice, slice], np.ndarray] | None
) -> None:
    """``img`` (the pixels of ``box``) times a part's values where the part's roi meets it."""
    where = None if part is None else _overlap(box, part[0])
    if where is not None:
        img[where[0]] *= part[1][where[1]]  # type: ignore[index]


def _add(
    img: np.ndarray, box: tuple[slice, slice], part: tuple[tuple[slice, slice], np.ndarray]
) -> None:
    """``img`` (the pixels of ``box``) plus a part's values where the part's roi meets it."""
    where = _overlap(box, part[0])
    if where is not None:
        img[where[0]] += part[1][where[1]]


def _per_channel(factor: np.ndarray) -> np.ndarray:
    """A factor per pixel, (H, W), as the same factor for each of 3 channels, (H, W, 3)."""
    return np.repeat(factor[..., None], 3, axis=2)


# A renderer's table texture and noise depend only on these arguments; every renderer of
# one camera (a sort opens one per run, a suite or a sweep hundreds) shares them, read-only.
@functools.lru_cache(maxsize=4)
def _texture(size: tuple[int, int], table: str, seed: int) -> np.ndarray:
    """The table's texture [8-bit levels], (H, W, 3) float32, before light; read-only."""
    rng = np.random.default_rng([seed, 7])
    h, w = size

    def lowfreq(cells: tuple[int, int]) -> np.ndarray:
        grid = rng.standard_normal(cells).astype(np.float32)
        return cv2.resize(grid, (w, h), interpolation=cv2.INTER_CUBIC)

    if table == "grey":
        shade = 1.0 + 0.04 * lowfreq((8, 10)) + 0.02 * lowfreq((48, 64))
        base = np.array(GREY_BGR, np.float32)
    else:
        # Grain: bands across the image, wavy, of varying darkness.
        v = np.arange(h, dtype=np.float32)[:, None]
        warp = 6.0 * lowfreq((4, 6)) + 2.0 * lowfreq((12, 16))
        phase = 2 * np.pi * (v + warp) / 23.0
        grain = 0.5 + 0.5 * np.sin(phase + 0.8 * np.sin(phase / 3.1))
        shade = 1.0 - 0.14 * grain**3 + 0.03 * lowfreq((60, 80))
        shade += 0.05 * lowfreq((6, 8))
        base = np.array(WOOD_BGR, np.float32)
    texture = shade[..., None] * base
    texture.flags.writeable = False
    return texture


@functools.lru_cache(maxsize=4)
def _noise_bank(n: int, noise_std: float, seed: int) -> np.ndarray:
    """``n`` Gaussian noise values of ``noise_std`` [8-bit levels], float32; read-only."""
    bank = np.random.default_rng([seed, 11]).standard_normal(n, dtype=np.float32)
    bank *= np.float32(noise_std)
    bank.flags.writeable = False
    return bank
