"""Where the bins' feet show in a frame, against where the calibration puts them.

The bins stand still while the arm works, where ``task.classes[].bin_cm`` says, and a
bin's wall meets the table on the table's plane: where the calibration maps that line
into the frame, the camera sees it, whatever the wall's height, on each side whose outer
face the camera looks at (on the other sides the wall's top, nearer the camera, hides the
foot). So the foot of such a side seen away from its place means the view moved: a
knocked camera, which the objects alone cannot tell with one object on the table, before
the first look, along a row of one class by its pitch, or up or down (docs/twin.md).

A side is measured along :data:`PROFILES` short lines across it, on the table plane, from
:data:`REACH_CM` outside to as far inside: walking in, past what is not table (a
neighbouring bin), the foot is where at least :data:`TABLE_CM` of table ends (a pixel no
longer table-like: saturated and lit, as the twin's wooden table is, in the light or a
faint shadow; a bin's white walls and dark faces are neither) and the bin begins, for at least
:data:`FOOT_CM`, unsaturated within :data:`SHADE_CM` of it (the table in a shadow is as
saturated as the lit one, only darker). A line the arm's body crosses, one whose foot is
off the frame or on another bin and one without such a clean step (an object lying
against the wall, a table the bins do not stand out from, a bin's shadow cast across the
line by a lamp low to one side) say nothing; a side with fewer than :data:`MIN_PROFILES`
lines that do says nothing. Nor does a side whose lines saw little table before its foot
(under :data:`TABLE_SHARE` of what they saw there: an object on a grey table). On a table
that is not saturated or with bins that are, no side is measured and nothing is checked.
A view moved farther than :data:`REACH_CM` leaves the feet out of the lines: the objects
show it (:func:`~mearm.task.table_tracking.check_view`).

Measured on the MuJoCo twin's frames (simulated): unbumped, every side's foot lay within
0.15 cm of its place on each look of 12-object sorts of ``sim_mujoco``,
``sim_mujoco_perspective``, ``sim_mujoco_lamp``, ``sim_mujoco_kits`` (with and without a
lamp) and of the 5-DOF, MeArm v1 and shapes twins, but where the arm's body, which a
homography cannot place in the frame, stood before one bin's foot (1.1 cm in
``sim_mujoco_kits_paper``, 3.1 cm by the MeArm v1 at home; never two bins alike); a
camera moved 2 cm along the table moved the feet by 2.0 cm, one moved 2 cm up by
0.45–0.55 cm. A frame costs a median 0.3–0.8 ms of CPU (up to 20 ms the first of a
process).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mearm.config import ColorClass
from mearm.kinematics.bodies import bin_half_outer_m
from mearm.kinematics.chain import M_PER_CM
from mearm.vision.calibration import CameraGeometry
from mearm.vision.pinhole import PerspectiveCamera

#: How far outside and inside a side's foot a line across it looks [cm].
REACH_CM = 4.0
#: The spacing of the samples along a line [cm] (under a pixel at the paper's 0.0625 cm).
STEP_CM = 0.05
#: Lines across each side, spread over the middle 80 % of it (the corners left out).
PROFILES = 9
#: A side is measured when at least this many of its lines find its foot.
MIN_PROFILES = 3
#: How far past the foot a line must see no table for it to be the bin's [cm]: the wall.
FOOT_CM = 0.25
#: ... and at least this much table before it [cm] (a line may start in a neighbouring bin).
TABLE_CM = 0.5
#: Past the foot, the bin's wall (no saturated pixel, lit or not, for :data:`FOOT_CM`)
#: begins within this [cm]: what lies between is the table in the bin's own shadow, too
#: dark to be table-like, or a pixel blending the two. A wider shadow leaves the line
#: saying nothing: a lamp low to one side casts each bin's shadow alike, and the feet were
#: seen where the shadows ended (2.35 cm off, all three bins alike: a moved view, simulated).
SHADE_CM = 0.2
#: A line's samples on another bin, or this near one [cm], are not looked at: what lies in
#: a neighbouring bin is not table, though its colours may be (a stack of red objects in
#: a bin 0.4 cm away moved its neighbour's foot 2.7 cm: ``sim_5dof_mujoco_perspective``,
#: simulated). Its walls, taller than what it holds, hide that where they show beyond it.
NEIGHBOUR_CM = 0.2
#: A pixel is table-like when its HSV saturation and value reach these (0–255).
TABLE_SATURATION_MIN = 60
TABLE_VALUE_MIN = 40
#: A side is measured only where at least this share of what its lines saw before its foot
#: (in the frame, off the other bins) is table-like: the table stands out from the bins there.
#: On a grey table the only saturated things are the objects, and a line from an object
#: onto the grey table beside it looked like a foot: a kinematic sort of 24 objects
#: stopped at its first look, two bins "2.75 cm" off, each on one side of three lines
#: crossing one object (simulated).
TABLE_SHARE = 0.5


def _on_a_bin(pts: np.ndarray, bins: list[tuple[np.ndarray, float]]) -> np.ndarray:
    """Which table points, (..., 2) [cm], lie on one of ``bins`` or within :data:`NEIGHBOUR_CM`.

    ``bins``: each one's centre [cm], (2,), and half its outer width [cm].
    """
    on = np.zeros(pts.shape[:-1], dtype=bool)
    for centre, half in bins:
        on |= np.all(np.abs(pts - centre) <= half + NEIGHBOUR_CM, axis=-1)
    return on


@dataclass(frozen=True)
class BinSide:
    """One side of a bin whose foot the camera sees.

    Attributes:
        class_name: The bin's class.
        normal: The side's outward normal on the table, (2,).
        offset_cm: How far outside its place the foot is seen [cm] (negative: inside):
            the median of its lines'.
        lines: How many lines found the foot.
        from_eye_cm: How far its foot's middle lies from the point under the camera, along
            ``normal`` [cm] (negative: the sides seen face the camera). A camera moved up
            or down sees the table scaled about that point: each foot moves in proportion.
    """

    class_name: str
    normal: tuple[float, float]
    offset_cm: float
    lines: int
    from_eye_cm: float = 0.0


class BinFeet:
    """The bins' feet a calibrated camera sees, measured in its frames.

    The lines across the sides are laid once (the calibration and the bins are fixed);
    a frame costs a remap of those few thousand samples.

    Args:
        geometry: The camera's calibration.
        classes: The classes, each with its bin.
        size_px: The frames' (width, height) [px].
    """

    def __init__(
        self, geometry: CameraGeometry, classes: list[ColorClass], size_px: tuple[int, int]
    ):
        w, h = size_px
        if isinstance(geometry, PerspectiveCamera):
            eye = np.asarray(geometry.centre_cm, dtype=float)[:2]
        else:  # a homography's camera looks straight down on the frame's centre
            centre = np.array([[(w - 1) / 2, (h - 1) / 2]])
            eye = np.asarray(geometry.pixel_to_table(centre), dtype=float).reshape(2)
        t = np.arange(REACH_CM, -REACH_CM - STEP_CM / 2, -STEP_CM)  # outside → inside
        self._t = t
        self._foot = int(round(FOOT_CM / STEP_CM))
        self._shade = int(round(SHADE_CM / STEP_CM))
        self._run = int(round(TABLE_CM / STEP_CM))
        sides: list[tuple[str, tuple[float, float]]] = []
        from_eye: list[float] = []
        maps: list[np.ndarray] = []
        footprints: list[tuple[np.ndarray, float]] = []
        for c in classes:
            half = bin_half_outer_m(c) / M_PER_CM
            centre_cm = np.array(c.bin_cm[:2], dtype=float)
            footprints.append((centre_cm, half))
        for c, (centre_cm, half) in zip(classes, footprints, strict=True):
            for n in ((1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)):
                normal = np.array(n)
                mid = centre_cm + half * normal
                if float((eye - mid) @ normal) <= 0:
                    continue  # its outer face looks away: the wall's top hides the foot
                along = np.array([-normal[1], normal[0]])
                u = np.linspace(-0.8, 0.8, PROFILES) * half
                pts = mid + u[:, None, None] * along + t[None, :, None] * normal  # (P, T, 2)
                px = np.asarray(geometry.table_to_pixel(pts.reshape(-1, 2)), dtype=float)
                px = px.reshape(PROFILES, len(t), 2)
                inside = (
                    np.isfinite(px).all(axis=2)
                    & (px[..., 0] >= 0)
                    & (px[..., 0] <= w - 1)
                    & (px[..., 1] >= 0)
                    & (px[..., 1] <= h - 1)
                )
                # off the frame or on another bin: black, and no foot is seen there
                others = [b for b in footprints if b[0] is not centre_cm]
                px[~inside | _on_a_bin(pts, others)] = -1.0
                sides.append((c.name, n))
                from_eye.append(float((mid - eye) @ normal))
                maps.append(px)
        self.sides = sides
        self._from_eye = from_eye
        if maps:
            px = np.concatenate(maps).astype(np.float32)  # (sides·P, T, 2)
        else:
            px = np.full((0, len(t), 2), -1.0, np.float32)
        self._map_x, self._map_y = px[..., 0].copy(), px[..., 1].copy()
        self._in_frame = px[..., 0] >= 0  # (sides·P, T)
        self._rows = np.clip(np.round(px[..., 1]).astype(int), 0, h - 1)
        self._cols = np.clip(np.round(px[..., 0]).astype(int), 0, w - 1)

    def measure(self, frame: np.ndarray, hidden: np.ndarray | None = None) -> list[BinSide]:
        """Each side's foot where this frame shows it.

        Args:
            frame: A BGR frame, (H, W, 3) uint8, of the calibrated size.
            hidden: The arm's body in it (non-zero), (H, W), or ``None``: a line that
                crosses it says nothing.

        Returns:
            The sides measured (at least :data:`MIN_PROFILES` lines each).
        """
        if not self.sides:
            return []
        samples = cv2.remap(frame, self._map_x, self._map_y, cv2.INTER_LINEAR)
        hsv = cv2.cvtColor(samples, cv2.COLOR_BGR2HSV)
        saturated = hsv[..., 1] >= TABLE_SATURATION_MIN  # the table, lit or in a shadow
        table = saturated & (hsv[..., 2] >= TABLE_VALUE_MIN)
        usable = np.ones(len(samples), dtype=bool)
        if hidden is not None:
            usable &= ~((hidden[self._rows, self._cols] != 0) & self._in_frame).any(axis=1)
        # walking in: the table (past a neighbouring bin the line may start in), then the
        # first sample that is not table, and the bin from there on
        lines, n = table.shape
        rows = np.arange(lines)[:, None]
        start = np.argmax(table, axis=1)
        first = np.argmin(table | (np.arange(n)[None, :] < start[:, None]), axis=1)
        wall = np.minimum(np.arange(self._foot)[None, :] + first[:, None], n - 1)
        # ... and, past at most a narrow shadow, the bin's unsaturated wall
        past = np.minimum(wall + self._shade, n - 1)
        clean = (
            usable
            & table[np.arange(lines), start]
            & (first - start >= self._run)
            & (first + self._foot <= n)
            & ~table[rows, wall].any(axis=1)
            & ~saturated[rows, past].any(axis=1)  # not the table in a shadow
            & self._in_frame[rows, wall].all(axis=1)  # the foot seen, not the frame's edge
        )
        found: list[BinSide] = []
        for k, (name, normal) in enumerate(self.sides):
            side = slice(k * PROFILES, (k + 1) * PROFILES)
            ok = clean[side]
            if int(ok.sum()) < MIN_PROFILES:
                continue
            # what the side's lines saw before its foot is mostly table (not a grey table
            # with an object on it)
            foot = int(np.median(first[side][ok]))
            seen = self._in_frame[side, :foot] & usable[side, None]
            if np.count_nonzero(table[side, :foot] & seen) < TABLE_SHARE * np.count_nonzero(seen):
                continue
            offsets = self._t[first[side][ok]]
            found.append(
                BinSide(name, normal, float(np.median(offsets)), int(ok.sum()), self._from_eye[k])
            )
        return found
