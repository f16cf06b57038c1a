r"""Picks that look: the camera sees where the claw is before the jaws close; the pick is corrected.

Real hobby servos do not go where they are told: each unit's zero and scale differ from
the datasheet's, and its gears' play (backlash, 0.5–2° at the shaft) and dead band
(up to 10 µs) leave it short of its command by an amount that depends on the way it
last turned. Over the paper's arm that is 0.5–1 cm at the claw, as much as the jaws' room
around a 2 cm object. The calibrated camera sees the claw's marker
(:mod:`mearm.vision.claw_marker`) to a few hundredths of a centimetre, so the sort asks it.

At a pose the arm was sent to, the marker's seen centre :math:`m_s` and the centre the
plan put it at :math:`m_p` (the forward kinematics of the commanded joints) differ by the
arm's error :math:`e = m_s - m_p`. The arm was aimed at the goal :math:`g` shifted by
:math:`a` (zero at first), so the claw is :math:`r = a + e` off the goal, and the aim
becomes :math:`a - r`: an integrator on what the camera sees, which cancels an error that
stays put (a servo's zero) at once and one that follows the command (the gears' play
after a move) too; the camera then looks again, a few times at most (:data:`MAX_LOOKS`),
until :math:`|r|` < :data:`GOOD_ENOUGH_CM`. Each corrected
route is planned in full and checked against collisions like any other before it is
sent. Only the table plane is corrected (x, y): the marker's height is the least well
measured of its coordinates, and the jaws close at half the object's height with room to
spare. The height is corrected from what misses, slips in the carry and the looks of
several picks show (:class:`GripDrops`).

What the arm learns is kept for the rest of the run: each corrected pick leaves the
correction it needed at its place (:class:`CorrectionMap`), and the next pick starts from
the nearest ones' (the servos' errors vary smoothly over the table), so that it needs
fewer looks; so does each drop of the grip with which a pick held.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from mearm.config import Config
from mearm.config.servo_models import servo_named
from mearm.ik import IKTarget
from mearm.kinematics import ArmModel
from mearm.kinematics.bodies import marker_in_tcp
from mearm.vision.pinhole import PerspectiveCamera

if TYPE_CHECKING:  # the marker's finder loads at the first look: a claw camera's sort only
    from mearm.vision.claw_marker import MarkerSighting

#: Looks at one pose at most (the first, and two corrections of it).
MAX_LOOKS = 3
#: An error this small in the table plane is left as it is [cm]: a few tenths of a
#: millimetre is below what the servos' smallest step moves the claw by.
GOOD_ENOUGH_CM = 0.05
#: The largest correction believed [cm]; a larger error means the marker was seen where
#: the claw is not (another print of it in view) or the arm is not where its state says.
MAX_CORRECTION_CM = 4.0
#: How long the arm is held still before a look [s]: a hobby servo's step response has
#: settled to a few hundredths of a degree by then (the twin's: mearm servo-steps).
SETTLE_S = 0.25
#: The corrections kept from earlier picks weigh in within this distance [cm].
NEIGHBOURHOOD_CM = 12.0
#: An object seen within this of where it was before a pick that missed is still on its
#: spot [cm]: pads that close over its top brush its edge and nudge it by a few
#: millimetres (up to 0.9 cm, simulated: docs/twin.md); farther, it was pushed or dropped.
UNMOVED_CM = 1.0
#: How much of an object's side the jaws need to hold it [cm]: a pick that missed with
#: the object unmoved had its claw at least the planned overlap less this high, and a
#: miss lowers the next attempt by at least this.
GRIP_HOLD_CM = 0.1
#: A lowered grip keeps the tool's lowest point this far above the table at the planned
#: pose [cm]: the collision check's own bound is the table itself (0).
TABLE_ROOM_CM = 0.05
#: How much of an object's side the jaws need to carry it to the bin [cm]: grips of the
#: top 0.15-0.25 cm held at the lift and slipped out on the way (simulated, kits 21, 52,
#: 53: docs/twin.md), grips of 0.35 cm and more did not.
GRIP_CARRY_CM = 0.3
#: Picks whose looks weigh in before the claw's height they saw lowers a first attempt.
LEVEL_PICKS = 3
#: The picks' mean height must exceed this, less two of its standard errors, to count as
#: high [cm]: a pick's looks see the marker's height to a few millimetres, and on average
#: between 0.5 cm lower and 0.15 cm higher than the claw is (kits 3, 11, 21, 52, 53,
#: simulated: docs/twin.md); a low claw (kit 3, 0.2 cm low) was seen up to 0.46 cm high in
#: one pick, never on average. Such picks start lower by the height seen (less, for
#: the claws seen high, than they were).
LEVEL_HIGH_CM = 0.05
#: A miss with the claw seen this high on average measures it high [cm]: a low claw
#: (kit 3) was seen at most 0.26 cm high in a pick, kit 21's far out 0.2-0.9 cm.
MISS_HIGH_CM = 0.3
#: How much the claw's height at one place varies between attempts [cm]: kit 21's far
#: out 0.88-1.16 cm high over three (simulated, seed 901).
CLAW_REPEAT_CM = 0.3
#: How many looks the forward kinematics' height weighs as, beside the heights the looks
#: nearby saw, in the height a look's ray is met at (:meth:`ClawEye.look`).
KINEMATIC_LOOKS = 1.0


@dataclass
class CorrectionMap:
    """The corrections earlier picks needed, by where they were needed (x, y).

    Attributes:
        dims: How many values a correction has (2: the table plane; 1: the grip's drop).
    """

    dims: int = 2
    places_cm: list[np.ndarray] = field(default_factory=list)
    corrections_cm: list[np.ndarray] = field(default_factory=list)

    def add(self, place_cm: np.ndarray, correction_cm: npt.ArrayLike) -> None:
        """Keep the correction a pick at ``place_cm`` (x, y) needed (its first ``dims``)."""
        self.places_cm.append(np.asarray(place_cm, dtype=float)[:2].copy())
        correction = np.atleast_1d(np.asarray(correction_cm, dtype=float))[: self.dims]
        self.corrections_cm.append(correction.copy())

    def guess(self, place_cm: np.ndarray) -> np.ndarray:
        """The correction to start a pick at ``place_cm`` from: the nearest ones', weighted."""
        if not self.places_cm:
            return np.zeros(self.dims)
        d = np.linalg.norm(np.array(self.places_cm) - np.asarray(place_cm)[:2], axis=1)
        w = np.where(d < NEIGHBOURHOOD_CM, 1.0 / (1.0 + d), 0.0)
        if w.sum() <= 0:
            return np.zeros(self.dims)
        return (w[:, None] * np.array(self.corrections_cm)).sum(axis=0) / w.sum()


@dataclass
class GripDrops:
    r"""How far below the planned grip the jaws close: learned from misses, kept for the run.

    A kit whose shoulder turns more than nominal leaves the claw a few millimetres high,
    and the jaws close above a 1 cm object, or on its top millimetres, which slip out on
    the way to the bin. The camera tells such a miss from others: the
    object is seen still on its spot (:data:`UNMOVED_CM`; jaws that closed on its side
    push it away), and the looks at the grip pose saw the marker high (their mean :math:`\bar e_z
    > 0`; a marker's height is measured to a few millimetres a look, but its sign over the
    looks tells a high claw from a low one). The jaws then closed above the object's side,
    so the claw was at least as high as the plan had them reach down it, :math:`o`, less
    the :data:`GRIP_HOLD_CM` they need of it; the next attempt goes lower by
    :math:`\max(\bar e_z,\ o - h,\ h) + c` (:data:`GRIP_CARRY_CM`: the claw may be
    higher still), down to what the collision check allows (the caller's bound; with
    the claw seen high by more than :data:`MISS_HIGH_CM`, the check's table lies lower by
    what the miss measured, less :data:`CLAW_REPEAT_CM`). An object that held and slipped
    out on the way (seen on the table again after it was carried off, with the claw seen
    high) is as good evidence: the claw
    was at least :math:`o - c` high (:data:`GRIP_CARRY_CM`). A drop with which a pick held,
    or that a slip called for, is kept at its place, and later picks start from their
    neighbours' (:class:`CorrectionMap`). And where the looks of several picks nearby saw
    the claw high by more than their noise (:data:`LEVEL_HIGH_CM`), a first attempt starts
    lower by that height. A claw seen low lowers no first attempt; but a miss with the
    object unmoved and the claw not seen high is not repeated at its height: the claw
    may be as low (the open jaws' tips stalled on the table round the object) as high,
    so the next attempt tries the other height (:meth:`missed`).
    """

    kept: CorrectionMap = field(default_factory=lambda: CorrectionMap(dims=1))
    #: The drop the next attempt at an object starts from, after a miss [cm], by id.
    retry_cm: dict[str, float] = field(default_factory=dict)
    #: The mean height error each pick's looks at the grip pose saw, by place [cm].
    levels: CorrectionMap = field(default_factory=lambda: CorrectionMap(dims=1))
    #: The picks that held, by id: (place (x, y) [cm], drop [cm], the looks' height errors
    #: [cm], the plan's overlap [cm]); one picked again slipped out on the way.
    carried: dict[str, tuple[np.ndarray, float, tuple[float, ...], float]] = field(
        default_factory=dict
    )
    #: How far below the real table the collision check may put the table for the next
    #: attempt at an object [cm], by id: what its miss measured the claw high by, less
    #: :data:`CLAW_REPEAT_CM` (:meth:`missed`).
    below_cm: dict[str, float] = field(default_factory=dict)

    def drop_cm(self, obj_id: str, place_cm: np.ndarray) -> float:
        """The drop to start a pick of ``obj_id`` at ``place_cm`` from [cm], ≥ 0.

        An object that held before and is picked again slipped out on the way to its bin
        (:meth:`slipped`).
        """
        if obj_id in self.carried:
            self.slipped(obj_id)
        if obj_id in self.retry_cm:
            return self.retry_cm[obj_id]
        return max(0.0, float(self.kept.guess(place_cm)[0]), self.level_cm(place_cm))

    def looked(self, place_cm: np.ndarray, seen_z_cm: Sequence[float]) -> None:
        """Keep the mean height error the looks at a pick's grip pose saw [cm]."""
        if len(seen_z_cm):
            self.levels.add(place_cm, [float(np.mean(seen_z_cm))])

    def level_cm(self, place_cm: np.ndarray) -> float:
        """How much lower than planned a first attempt at ``place_cm`` starts [cm], ≥ 0.

        The height the looks of the picks nearby saw (their mean, the nearer weighing more),
        where at least :data:`LEVEL_PICKS` of them saw it high by more than
        :data:`LEVEL_HIGH_CM` plus two standard errors of their mean; 0 otherwise.
        """
        if not self.levels.places_cm:
            return 0.0
        d = np.linalg.norm(np.array(self.levels.places_cm) - np.asarray(place_cm)[:2], axis=1)
        v = np.array(self.levels.corrections_cm)[d < NEIGHBOURHOOD_CM, 0]
        if len(v) < LEVEL_PICKS:
            return 0.0
        if v.mean() - 2.0 * v.std(ddof=1) / np.sqrt(len(v)) <= LEVEL_HIGH_CM:
            return 0.0
        return max(0.0, float(self.levels.guess(place_cm)[0]))

    def held(
        self,
        obj_id: str,
        place_cm: np.ndarray,
        drop_cm: float,
        seen_z_cm: Sequence[float] = (),
        overlap_cm: float = 0.0,
    ) -> None:
        """The pick of ``obj_id`` at ``place_cm`` held with the jaws ``drop_cm`` lower.

        Only a drop is kept: a pick that held at the planned height says the claw was not
        too high there for the jaws to hold on to the top of the object, not that it was
        level. What the pick saw (``seen_z_cm``, ``overlap_cm``: :meth:`missed`) is kept
        until the object is picked again, if it is: it slipped (:meth:`slipped`).
        """
        if drop_cm > 0:
            self.kept.add(place_cm, [drop_cm])
        self.retry_cm.pop(obj_id, None)
        place = np.asarray(place_cm, dtype=float)[:2].copy()
        self.carried[obj_id] = (place, drop_cm, tuple(seen_z_cm), overlap_cm)

    def slipped(self, obj_id: str) -> float:
        """``obj_id``, which held, slipped out of the jaws: the drop its next attempt starts from.

        With the claw seen high at its grip, the jaws held less of its side than they need
        to carry it (:data:`GRIP_CARRY_CM`): the claw was at least the plan's overlap less
        that high. The lower drop is kept at where it was picked, for the picks nearby.
        """
        place, drop_cm, seen_z_cm, overlap_cm = self.carried.pop(obj_id)
        high = float(np.mean(seen_z_cm)) if seen_z_cm else 0.0
        if high <= 0:
            return self.retry_cm.get(obj_id, drop_cm)
        drop = drop_cm + max(high, overlap_cm - GRIP_CARRY_CM, GRIP_HOLD_CM)
        self.kept.add(place, [drop])
        self.retry_cm[obj_id] = drop
        return drop

    def missed(
        self,
        obj_id: str,
        drop_cm: float,
        moved_cm: float,
        seen_z_cm: Sequence[float],
        overlap_cm: float,
    ) -> float:
        """The pick of ``obj_id`` missed: the drop its next attempt starts from [cm].

        Args:
            obj_id: The object.
            drop_cm: How far below the planned grip the jaws closed [cm].
            moved_cm: How far the object is seen from where it was before the pick [cm].
            seen_z_cm: The marker's height errors the looks at the grip pose saw [cm].
            overlap_cm: How far down the object's side the open jaws reached in the plan
                (its top less their lowest point) [cm].
        """
        high = float(np.mean(seen_z_cm)) if len(seen_z_cm) else 0.0
        drop = drop_cm
        if moved_cm <= UNMOVED_CM and len(seen_z_cm) and high <= 0:
            # not seen high: the claw may be as low, the open jaws' tips stalled on the
            # table round the object (the looks' mean has the wrong sign either way, kit
            # 82: docs/twin.md); the next attempt tries the other height: the planned one
            # after a lowered attempt, lower after one at or above it
            lower = drop_cm + max(overlap_cm - GRIP_HOLD_CM, GRIP_HOLD_CM) + GRIP_CARRY_CM
            drop = 0.0 if drop_cm > 0 else lower
        if moved_cm <= UNMOVED_CM and high > 0:
            # at least that high: lower by it and by what carrying the object needs, so
            # that a claw higher than that still holds it to the bin (the caller's bound
            # keeps the tips over the table)
            drop += max(high, overlap_cm - GRIP_HOLD_CM, GRIP_HOLD_CM) + GRIP_CARRY_CM
        if moved_cm <= UNMOVED_CM and high > MISS_HIGH_CM:
            # the tips stayed above the object's side less what holds it: the claw was
            # that high; the next attempt's may be planned that much lower, less how much
            # the claw's height varies (the real tips then stay over the table)
            measured = overlap_cm - GRIP_HOLD_CM - CLAW_REPEAT_CM
            self.below_cm[obj_id] = max(self.below_cm.get(obj_id, 0.0), measured)
        self.retry_cm[obj_id] = drop
        return drop


@dataclass(frozen=True)
class Look:
    """One look at the claw.

    Attributes:
        error_cm: Where the marker is seen less where the plan put it (x, y, z) [cm].
        sighting: What the camera saw.
    """

    error_cm: np.ndarray
    sighting: MarkerSighting


class ClawEye:
    """The calibrated camera watching the claw's marker.

    Args:
        config: The whole config (its tool's marker; a perspective calibration).
        model: The arm's kinematic model.
        camera: The calibrated camera.
        read: Reads a frame (BGR) of the camera, with the arm where it is now, checked as
            the table's looks' frames are, by the same check (the sort's:
            :meth:`~mearm.vision.frame_check.FrameCheck.read`): a black frame shows no
            marker, and a frozen stream's shows the claw where it was; either raises
            :class:`~mearm.vision.errors.CameraError`, which stops the sort.
        hold: Holds the arm still for a time [s] (:meth:`~mearm.hardware.bus.ServoBus.hold`).
    """

    def __init__(
        self,
        config: Config,
        model: ArmModel,
        camera: PerspectiveCamera,
        read: Callable[[], np.ndarray],
        hold: Callable[[float], None],
    ):
        marker = config.arm.tool.marker
        assert marker is not None
        self.marker = marker
        self.model = model
        self.camera = camera
        self.read = read
        self.hold = hold
        face = marker_in_tcp(config.arm, servo_named(config.twin.gripper_servo))
        assert face is not None
        self._centre_in_tcp_cm = face[:3, 3] * 100.0
        self.corrections = CorrectionMap()
        self.drops = GripDrops()
        #: The height errors the looks saw (seen less planned), by the claw's place.
        self.heights = CorrectionMap(dims=1)

    def planned_cm(self, q: np.ndarray) -> np.ndarray:
        """Where the marker's centre is at joints ``q`` by the forward kinematics [cm], (3,)."""
        p, R = self.model.tcp_pose(q)
        return p + R @ self._centre_in_tcp_cm

    def look(self, q_commanded: np.ndarray) -> Look | None:
        """Look at the claw, held at ``q_commanded``.

        The arm is held still for :data:`SETTLE_S` first. The marker's centre is where
        the ray through its image's centre (the diagonals' intersection, exact under
        perspective) meets the level plane at the claw's height: the planned height plus
        the height error the looks within :data:`NEIGHBOURHOOD_CM` saw, this one included,
        on average, the forward kinematics weighing as :data:`KINEMATIC_LOOKS` look with
        none. A servo kit's errors move the claw up and down by up to a centimetre, and
        a ray met at the planned height is then off sideways; but one look's height,
        from the marker's apparent size, is off by 0.28 cm on average and by up to 4.7 cm
        (658 looks, simulated kits), and a ray met there is off sideways too: three looks
        0.4-1.5 cm low moved a claw 0.5 cm along the jaws' pads, and the object slipped
        out on the way. The servos' errors vary smoothly over the
        table, the marker's size error from look to look: the heights of several looks
        nearby average it out (docs/twin.md, "Picks that look").

        Returns:
            The look, or ``None`` when the marker is not in view or is seen implausibly
            far (:data:`MAX_CORRECTION_CM`) from where it should be.

        Raises:
            CameraError: the frame is black or the stream froze (``read``'s check).
        """
        from mearm.vision.aruco import diagonal_center  # noqa: PLC0415  (a claw camera's only)
        from mearm.vision.claw_marker import find_claw_marker  # noqa: PLC0415

        self.hold(SETTLE_S)
        sighting = find_claw_marker(self.read(), self.marker, self.camera)
        if sighting is None:
            return None
        planned = self.planned_cm(q_commanded)
        z = float(sighting.centre_cm[2])
        height = planned[2] + self._height_error_cm(planned, z - planned[2])
        xy = self.camera.pixel_to_plane(diagonal_center(sighting.corners_px), height)
        error = np.array([xy[0], xy[1], z]) - planned
        if np.linalg.norm(error[:2]) > MAX_CORRECTION_CM:
            return None
        self.heights.add(planned, [z - planned[2]])
        return Look(error, sighting)

    def _height_error_cm(self, planned_cm: np.ndarray, seen_cm: float) -> float:
        """The claw's height error at ``planned_cm`` [cm]: this look's and those nearby's.

        Their mean, with the forward kinematics (no error) counted as
        :data:`KINEMATIC_LOOKS` looks.
        """
        seen = [seen_cm]
        if self.heights.places_cm:
            d = np.linalg.norm(np.array(self.heights.places_cm) - planned_cm[:2], axis=1)
            errors = np.array(self.heights.corrections_cm)[:, 0]
            seen += errors[d < NEIGHBOURHOOD_CM].tolist()
        return float(np.sum(seen) / (len(seen) + KINEMATIC_LOOKS))


def shifted(target: IKTarget, shift_xy_cm: np.ndarray) -> IKTarget:
    """``target`` moved by ``shift_xy_cm`` in the table plane (and up, given a third value)."""
    x, y, z = (float(v) for v in target.position_cm)
    dx, dy = (float(v) for v in shift_xy_cm[:2])
    dz = float(shift_xy_cm[2]) if len(shift_xy_cm) > 2 else 0.0
    return dataclasses.replace(target, position_cm=(x + dx, y + dy, z + dz))


def claw_eye(
    config: Config,
    model: ArmModel,
    geometry: object,
    read: Callable[[], np.ndarray],
    hold: Callable[[float], None],
) -> ClawEye | None:
    """The :class:`ClawEye` of a sort, or ``None`` where its picks cannot look.

    They look where ``task.look_at_claw`` asks for it, the tool carries a marker, the
    camera's calibration is a perspective one (``geometry``) and picks go via a point above
    the object (``task.approach_height_cm``).
    """
    task = config.task
    if not task.look_at_claw or task.approach_height_cm is None:
        return None
    if config.arm.tool.marker is None or not isinstance(geometry, PerspectiveCamera):
        return None
    return ClawEye(config, model, geometry, read, hold)
