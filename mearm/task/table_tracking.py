"""The objects on the table, followed from look to look: which detection is which object.

Each known object takes the detection of its class nearest where it was; a detection left
over is a known object no longer where it was (pushed, dropped on the way to its bin) when
one can be, else a new object. Objects the arm did not go near that all moved by the same
shift mean the camera was knocked (:func:`check_view`), and so do the bins' feet seen away
from where the calibration puts them or an earlier look saw them (:func:`check_bins`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from collections.abc import Set as AbstractSet
from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np
import numpy.typing as npt

from mearm.config import Config
from mearm.kinematics.bodies import BIN_WALL_M, M_PER_CM
from mearm.task.execute import View
from mearm.task.report import Reporter, Skip
from mearm.task.route import Route
from mearm.vision import Camera, ColorDetector, Detection
from mearm.vision.bin_edges import BinFeet, BinSide
from mearm.vision.calibration import CameraGeometry
from mearm.vision.errors import CameraError
from mearm.vision.frame_check import FrameCheck
from mearm.vision.tracking import Missing, distance_to_path, explain, nearest_pairs
from mearm.vision.tracking import Seen as Sighting
from mearm.vision.work_area import table_corners_cm

#: A detection where no earlier look saw the table (the arm's body hid it) farther than
#: this from where every missing object of its class may have gone is an object not seen
#: before, not one of them pushed or dropped [cm]: twice :data:`SAME_OBJECT_CM`, more than
#: the jaws push one (0.9 cm at most, simulated) and than a drop lands off its path.
REVEALED_NEW_CM = 3.0
#: A detection within this distance of a known object is that object [cm].
SAME_OBJECT_CM = 1.5
#: Objects the arm did not go for that all move farther than this between two looks, the
#: same way, mean the view moved (the camera was knocked) [cm]: a detection's jitter is a
#: few tenths of a pixel (0.0625 cm a pixel at the paper's calibration).
VIEW_SHIFT_CM = 0.5
#: How closely their shifts must agree to be one move of the view [cm] (one object moved
#: alone may be the arm's doing: a jaw that caught it).
SAME_SHIFT_CM = 0.3
#: Bins whose feet a look sees farther than this from where the calibration puts them
#: mean the view moved [cm]: a bin stood by hand a little off its ``bin_cm`` (still under
#: the drop) is not a knocked camera (:func:`check_bins`; unbumped, the twin's lay within
#: 0.15 cm, simulated) ...
BIN_PLACED_CM = 1.0
#: ... and so do bins whose feet moved farther than this since an earlier look saw them
#: [cm]: a camera moved 2 cm up or down moves them 0.45–0.55 cm (simulated).
BIN_SHIFT_CM = 0.3
#: An object a look found away from where it was (dropped, pushed, rolled) is looked at
#: again this much later, until it stays put: a cylinder dropped on its side rolls on, and
#: a pick where it was seen closes on nothing [s] ...
REST_LOOK_S = 0.5
#: ... at most this many times (then it is picked where it was last seen) ...
REST_LOOKS = 6
#: ... and it is at rest when it moved less than this between two looks [cm]: more than
#: a detection's jitter (:data:`VIEW_SHIFT_CM`), less than :data:`SAME_OBJECT_CM`.
REST_CM = 0.3
#: An object whose region grew or shrank by more than this fraction since the last look
#: is partly hidden (by the arm) in one of them: its centroid moved for that [-].
SAME_AREA_RATIO = 0.15
#: How far past a bin's inner square the camera's place for an object still puts it in the
#: bin [cm]: the walls' thickness. No object on the table stands within a bin's walls (a
#: scene keeps each a radius outside, and the walls keep out one pushed against them),
#: while the camera may place one in the bin a little beyond the inner square (seen on the
#: others or by a wall; 0.1 cm outside, a sorted object was taken for a dropped one, then
#: lost: simulated).
IN_BIN_BEYOND_CM = BIN_WALL_M / M_PER_CM
#: How far round a region's box the arm's body counts as bordering it [px] (the ring the
#: detector's own test of a region the arm hides in part looks in, ``may_hold_two``).
BORDER_PX = 2


@dataclass
class TrackedObject:
    """An object seen on the table, followed from frame to frame by its position."""

    id: str
    class_name: str
    x_cm: float
    y_cm: float
    failed_picks: int = 0
    skipped: str | None = None
    skip_kind: str | None = None
    sorted: bool = False
    #: Why its pick was refused for a collision since the last object was sorted (others
    #: go first), or ``None``.
    blocked: str | None = None
    #: Whether the last look saw it as a region of touching objects (or one the arm hid
    #: in part, or one cut by the image border): not picked while so; left as ``merged``
    #: (or ``cut``) when nothing else is left.
    merged: bool = False
    #: A cube's yaw on the table at the last look [deg, 0–90), or ``None``: the jaws
    #: turn to its faces where the arm can turn them (:meth:`Planner.turn_jaws`).
    yaw_deg: float | None = None
    #: Its region's area at the last look [px].
    area_px: int = 0
    #: The path (x, y) [cm], (k, 2), its TCP carried it along to its bin, while no
    #: simulator has confirmed the release (a real rig; a place the twin did not count:
    #: :func:`~mearm.task.pick_place.place_confirmed`): an object of its class seen new
    #: near that path is it, dropped on the way (:meth:`TableTracking._dropped`).
    carried_cm: np.ndarray | None = None
    #: How many times it was placed in its bin: more than once when an object seen later
    #: near its way there was taken for it, dropped on the way
    #: (:meth:`TableTracking._dropped`), or when jaws the bus knew held one of its class
    #: let it go over its bin while a look took another, not seen before, for it pushed
    #: aside (:meth:`PickAndPlace._let_go_and_look
    #: <mearm.task.pick_place.PickAndPlace._let_go_and_look>`).
    places: int = 0
    #: The simulator's objects its jaws held when its last place lost them on the way,
    #: where the bus knows them (:class:`~mearm.hardware.bus.ReportsWhere`, the twin's
    #: ids): the twin can say where it went when the camera no longer sees it.
    lost_ids: frozenset[str] = frozenset()
    #: Why its last place failed (lost on the way, released off its bin), while it lies
    #: where that left it; ``None`` once a place put it in its bin, or none failed. A skip
    #: of it says so: the cause of its lying there is that place, not what the skip found.
    place_failed: str | None = None


Seen = list[tuple[Detection, np.ndarray]]


class TableTracking:
    """The objects on the table, as the sorter knows them (a part of its :class:`Sorter`).

    Attributes:
        config: The whole configuration.
        camera: Frame source.
        detector: Finds the objects in a frame.
        calibration: The camera's geometry (pixel ↔ table).
        frame_check: Refuses black and frozen frames.
        view: Meshcat view to update, or ``None``.
        reporter: Where skips are reported.
    """

    config: Config
    camera: Camera
    detector: ColorDetector
    calibration: CameraGeometry
    frame_check: FrameCheck
    view: View | None
    reporter: Reporter
    #: The arm's body in a frame of this shape at its last joints (0/255), where a
    #: calibrated camera sees it: no object is looked for there; ``None``: not known.
    arm_in_view: Callable[[tuple[int, ...]], np.ndarray] | None = None
    _objects: list[TrackedObject]
    #: The object the arm last went for (the only one it may have moved since).
    _active: TrackedObject | None
    _active_from_cm: tuple[float, float]
    #: The pixels some look saw the table in, not hidden by the arm; ``None``: no look yet.
    _seen_px: np.ndarray | None
    #: The objects the last look found away from where they were (:meth:`_dropped`).
    _moved: frozenset[str] = frozenset()
    #: Each bin side's foot as the first look that measured it saw it [cm] (:func:`check_bins`).
    _bin_feet_cm: dict[tuple[str, tuple[float, float]], float] | None = None

    def _look(self, *, track_new: bool = True) -> Seen:
        """Read a frame: what lies on the table, outside the bins.

        An object cut by the image border is in it, seen in part: followed, but not
        picked until seen whole (:meth:`_track`).

        Args:
            track_new: Start following objects not seen before (off while the gripper
                holds one: the camera sees the held object too, away from the table).
        """
        frame = self.camera.read()
        self.frame_check.check(frame, self.camera.frame_time_s, self.camera.clock_s)
        # an object seen in a bin is sorted, not on the table (a camera that sees the
        # bins sees what was put in them)
        hidden = None if self.arm_in_view is None else self.arm_in_view(frame.shape)
        if hidden is None:
            detections = self.detector.detect(frame)
        else:
            detections = self.detector.detect(frame, exclude=hidden)
        found = self._believed([(d, table_cm(d)) for d in detections], hidden)
        seen = [(d, p) for d, p in found if not self._in_a_bin(p)]
        if track_new:
            self._confirm_in_bins(found)
        revealed = self._revealed(seen, hidden) if track_new else set()
        self._track(seen, track_new=track_new, revealed=revealed)
        # the bins stand still: a view moved that the objects left alone cannot show
        if self._bin_feet_cm is None:
            self._bin_feet_cm = {}
        check_bins(self._bin_feet.measure(frame, hidden), self._bin_feet_cm, self.camera.source)
        if self.view is not None:
            self.view.set_camera_frame(frame, self.calibration.pixel_to_table)
            self.view.set_objects(
                [
                    (o.id, o.class_name, o.x_cm, o.y_cm)
                    for o in self._objects
                    if self._on_table(o, seen)
                ]
            )
        return seen

    def _look_at_rest(self, hold: Callable[[float], object]) -> Seen:
        """:meth:`_look`, and again while an object it found moved is still moving.

        An object found away from where it was (dropped on the way, pushed, tipped) may
        still be rolling: a cylinder dropped on its side rolled on, the pick went where
        the look had seen it and closed on nothing, and the object rolled off the table
        (simulated, docs/troubleshooting.md). Such an object is looked at again
        :data:`REST_LOOK_S` later (``hold``: the bus's, the time passing on the table),
        until it moved less than :data:`REST_CM` between two looks, or left the view, at
        most :data:`REST_LOOKS` times. A look that found nothing moved is the only one.
        """
        seen = self._look()
        watch = set(self._moved)
        for _ in range(REST_LOOKS):
            if not watch:
                break
            before = {o.id: (o, o.x_cm, o.y_cm) for o in self._objects if o.id in watch}
            hold(REST_LOOK_S)
            seen = self._look()
            watch = set(self._moved) | {
                oid
                for oid, (o, x, y) in before.items()
                if np.hypot(o.x_cm - x, o.y_cm - y) > REST_CM
            }
        return seen

    @cached_property
    def _bin_feet(self) -> BinFeet:
        """The bins' feet in the camera's frames (:class:`BinFeet`), laid out once."""
        camera = self.config.camera
        return BinFeet(
            self.calibration, list(self.config.task.classes), (camera.width_px, camera.height_px)
        )

    @cached_property
    def _work_surface_cm(self) -> np.ndarray:
        """:func:`work_surface_cm` of the run's config, once (the calibration is fixed)."""
        return work_surface_cm(self.config)

    def _believed(self, found: Seen, hidden: np.ndarray | None = None) -> Seen:
        """The detections placed on the work surface; the others judged by their centre's ray.

        A place off the calibrated field and its bins (:func:`work_surface_cm`, grown by an
        object's diameter) is not where an object is: the fit of its outline failed (a
        stack in a bin cut by the arm's body was placed 700 cm away, simulated). Such a
        detection whose centre's ray meets the table in a bin is in that bin, placed there;
        any other is not believed and left out, so no position off the table is kept.

        A detection the arm's body borders (``hidden``: seen in part, :func:`borders_hidden`)
        whose centre's ray meets the table within a bin's inner square is in that bin too,
        wherever its outline's fit placed it: that fit is of the part the arm leaves, and
        the arm over a bin leaves the side of a stack there, its top hidden. The fit placed
        the top of a stack of four 4.1 cm out from its bin's centre, beyond the walls
        (3.3 cm), the centre's ray 0.3 cm from it: the sort took it for the object it had
        just placed, dropped, and went for it by the wall (docs/twin.md, simulated).
        """
        surface = self._work_surface_cm
        out: Seen = []
        for d, p in found:
            r = self.config.task.class_named(d.color).diameter_cm
            placed = on_surface(surface, p, r)
            in_part = hidden is not None and borders_hidden(d, hidden)
            if placed and not in_part:
                out.append((d, p))
                continue
            ray = np.asarray(self.calibration.pixel_to_table(d.centroid_px), dtype=float)
            ray = ray.reshape(2)
            if self._in_a_bin(ray, beyond_cm=0.0 if placed else IN_BIN_BEYOND_CM):
                out.append((d, ray))
            elif placed:
                out.append((d, p))
        return out

    def _in_a_bin(self, xy_cm: np.ndarray, beyond_cm: float = IN_BIN_BEYOND_CM) -> bool:
        """Whether a table point lies within a class's bin, walls included.

        ``beyond_cm`` past its inner square (default :data:`IN_BIN_BEYOND_CM`: its walls).
        """
        x, y = float(xy_cm[0]), float(xy_cm[1])
        return any(c.in_bin(x, y, beyond_cm) for c in self.config.task.classes)

    def _confirm_in_bins(self, found: Seen) -> None:
        """Count a carried object in its bin where the camera sees its class there.

        An object carried to its bin stays "carried" (:attr:`TrackedObject.carried_cm`: it
        may have dropped on the way) until something confirms its release. Where the
        camera sees an object of a class in that class's bin and the class's only object
        counted sorted is one carried there, that one lies in it. With more, objects
        stacked in a bin show as one, and none is confirmed this way.
        """
        for cls in self.config.task.classes:
            if not any(
                d.color == cls.name and cls.in_bin(float(p[0]), float(p[1]), IN_BIN_BEYOND_CM)
                for d, p in found
            ):
                continue
            placed = [o for o in self._objects if o.class_name == cls.name and o.sorted]
            if len(placed) == 1 and placed[0].carried_cm is not None:
                placed[0].carried_cm = None

    def _revealed(self, seen: Seen, hidden: np.ndarray | None) -> set[int]:
        """The detections whose centre no earlier look saw (the arm's body hid it there).

        Also adds what this look sees of the table to :attr:`_seen_px` (only looks that
        may start new objects: one while the jaws hold an object would spend the news).
        """
        if hidden is None:
            return set()
        previous, self._seen_px = self._seen_px, hidden == 0
        if previous is None:
            return set()
        self._seen_px |= previous
        return {k for k, (det, _) in enumerate(seen) if centre_seen(previous, det) is False}

    def _track(
        self, seen: Seen, *, track_new: bool = True, revealed: AbstractSet[int] = frozenset()
    ) -> None:
        """Follow the objects seen: each detection is a known object, or a new one.

        Each known object takes the detection of its class nearest where it was, within
        :data:`SAME_OBJECT_CM` (:meth:`_match`). On a look that may start new objects, a
        detection left over is a known object no longer where it was, when one of its
        class is missing (:meth:`_dropped`); only one that none can be is a new object.
        A region cut by the image border, or of touching objects, is followed as
        ``merged``: not picked while so. An object the arm did not go for must not have
        moved.

        Raises:
            CameraError: two or more such objects, seen whole in both looks, all moved
                more than :data:`VIEW_SHIFT_CM` since the last look, by the same shift
                (within :data:`SAME_SHIFT_CM`): the camera was knocked. Or a move of the
                view too far for them to be matched (:meth:`_moved_far`).
        """
        taken = self._match(seen)
        check_view(self._moved_far(seen, taken, revealed), self.camera.source)
        shifts: list[tuple[TrackedObject, np.ndarray]] = []
        for k, known in taken.items():
            det, (x, y) = seen[k]
            if self._untouched(known, det):
                shifts.append((known, np.array([x - known.x_cm, y - known.y_cm])))
        if track_new:
            dropped = self._dropped(seen, taken, revealed)
            self._moved = frozenset(o.id for o in dropped.values())
            taken.update(dropped)
            for k, (det, _) in enumerate(seen):
                if k not in taken:
                    n = sum(1 for o in self._objects if o.class_name == det.color) + 1
                    taken[k] = TrackedObject(f"{det.color}{n}", det.color, 0.0, 0.0)
                    self._objects.append(taken[k])
        camera = self.config.camera
        for k, known in taken.items():
            det, (x, y) = seen[k]
            known.x_cm, known.y_cm = float(x), float(y)
            if track_new:  # (what the region looked like: the next look tells if it came apart)
                known.area_px = det.area_px
                # one look's merged region may be another's single object: the arm, now
                # elsewhere, hid part of it, or a neighbour picked meanwhile touched it;
                # an object cut by the image border has no centre seen either
                known.merged = det.merged or is_cut(det, camera.width_px, camera.height_px)
            if det.yaw_deg is not None:
                known.yaw_deg = det.yaw_deg
        check_view(shifts, self.camera.source)

    def _dropped(
        self, seen: Seen, taken: Mapping[int, TrackedObject], revealed: AbstractSet[int]
    ) -> dict[int, TrackedObject]:
        """The known objects that the detections :meth:`_match` left over are.

        On a still table nothing brings new objects (:func:`~mearm.vision.tracking.explain`):
        such a detection is a known object of its class that is missing, if one is: on the
        table but not seen where it was (pushed by the jaws, tipped and rolled), or counted
        sorted while no simulator confirmed its release (:attr:`TrackedObject.carried_cm`:
        dropped on the way, or out of its bin again), which is then no longer counted
        sorted and is picked again from where it lies. Those missing from the table come
        before those counted sorted, and the ones the arm went for or may have pushed since
        the last look before the others; the nearest pairs first.
        The other object of a region of touching objects come apart is a new one
        (:func:`come_apart`), and so is one where no earlier look saw the table
        (``revealed``: the arm's body hid it) farther than :data:`REVEALED_NEW_CM` from
        where each missing object of its class may have gone.

        Returns:
            The detection's index → the object it is.
        """
        present = {o.id for o in taken.values()}
        missing = [
            o
            for o in self._objects
            if o.id not in present and (not o.sorted or o.carried_cm is not None)
        ]
        apart = come_apart(seen, taken, self.config)
        left = [
            k
            for k in range(len(seen))
            if k not in taken
            and k not in apart
            and not (k in revealed and self._new_in_view(seen[k], missing))
        ]
        pairs = explain(
            [
                Missing(
                    o.class_name,
                    np.array([[o.x_cm, o.y_cm]]) if o.carried_cm is None else o.carried_cm,
                    touched=o is self._active or self._near_active(o),
                    carried=o.sorted,
                )
                for o in missing
            ],
            [Sighting(d.color, float(p[0]), float(p[1])) for d, p in (seen[k] for k in left)],
        )
        found = {}
        for i, j in pairs:
            obj = found[left[j]] = missing[i]
            obj.sorted, obj.carried_cm = False, None
        return found

    @staticmethod
    def _new_in_view(sighting: tuple[Detection, np.ndarray], missing: list[TrackedObject]) -> bool:
        """Whether a sighting is far from where each missing object of its class may be.

        Farther than :data:`REVEALED_NEW_CM` from every such object's last place or path.
        """
        det, p = sighting
        xy = (float(p[0]), float(p[1]))
        return all(
            distance_to_path(
                np.array([[o.x_cm, o.y_cm]]) if o.carried_cm is None else o.carried_cm, xy
            )
            > REVEALED_NEW_CM
            for o in missing
            if o.class_name == det.color
        )

    def _moved_far(
        self,
        seen: Seen,
        taken: Mapping[int, TrackedObject],
        revealed: AbstractSet[int] = frozenset(),
    ) -> list[tuple[TrackedObject, np.ndarray]]:
        """The objects the arm left alone that one move of the view took out of matching.

        A view moved farther than :data:`SAME_OBJECT_CM` leaves no object the arm did not
        go near within that of where it lay: :meth:`_match` pairs none of them, so
        :func:`check_view` has no shift to see, and :meth:`_dropped` takes their detections
        for them pushed (a camera moved 2 cm, and the sort went on picking where it saw
        them: 27 picks failed, simulated). So, once the matching lost one of them, each
        lost one's offset to each detection of its class is tried as the view's shift
        (refined to the mean of the shifts it explains). An object the arm left alone
        (:meth:`_untouched`'s, by where it lay) is explained by a shift when it is not
        seen where it lay (no detection of its class within :data:`VIEW_SHIFT_CM`) and a
        detection of its class, of its area (within :data:`SAME_AREA_RATIO`), lies within
        :data:`SAME_SHIFT_CM` of where the shift puts it, not where a known object lay nor
        where no earlier look saw the table (``revealed``: an object the arm hid): the
        shift says why the object is gone as well as where it went. (On a grid of one
        class a shift by the pitch maps objects onto their neighbours, but those lie where
        they lay.) A shift that explains two or more of them, more than half of the
        objects the arm left alone, one lost by the matching among them, is the view's.

        Args:
            seen: This look's detections and where they lie [cm].
            taken: :meth:`_match`'s pairs: detection index → object.
            revealed: The detections whose centre no earlier look saw (:meth:`_revealed`).

        Returns:
            Those objects and their shifts [cm] (for :func:`check_view`), or none.
        """
        alone = [
            o
            for o in self._objects
            if not o.sorted and not o.merged and o is not self._active and not self._near_active(o)
        ]
        lost = {id(o) for o in alone} - {id(o) for o in taken.values()}
        if len(alone) < 2 or not lost or not seen:
            return []  # (all matched: check_view sees their shifts)
        colors = np.array([d.color for d, _ in seen])
        xy = np.array([np.asarray(p, dtype=float).reshape(2) for _, p in seen])  # (m, 2)
        area = np.array([d.area_px for d, _ in seen], dtype=float)

        def at(o: TrackedObject) -> np.ndarray:
            """Each detection's distance from where ``o`` lay, inf if not of its class [cm]."""
            cm = np.hypot(xy[:, 0] - o.x_cm, xy[:, 1] - o.y_cm)
            return np.where(colors == o.class_name, cm, np.inf)

        # the detections no known object lies at: where a moved one may be seen
        free = np.array([not d.merged and k not in revealed for k, (d, _) in enumerate(seen)])
        for o in self._objects:
            if not o.sorted:
                free &= at(o) > VIEW_SHIFT_CM
        gone = [o for o in alone if not np.any(at(o) <= VIEW_SHIFT_CM)]
        if len(gone) < 2 or 2 * len(gone) <= len(alone):
            return []
        lay = np.array([[o.x_cm, o.y_cm] for o in gone])  # (n, 2)
        was = np.array([float(o.area_px) for o in gone])[:, None]
        # (n, m): detection j may be object i moved
        fits = (
            free[None, :]
            & (colors[None, :] == np.array([o.class_name for o in gone])[:, None])
            & (np.abs(area[None, :] - was) <= SAME_AREA_RATIO * was)
        )

        def explained(shift: np.ndarray) -> list[tuple[TrackedObject, np.ndarray]]:
            off = np.linalg.norm(xy[None, :, :] - (lay + shift)[:, None, :], axis=2)
            off = np.where(fits, off, np.inf)
            j = np.argmin(off, axis=1)
            return [
                (o, xy[j[i]] - lay[i]) for i, o in enumerate(gone) if off[i, j[i]] <= SAME_SHIFT_CM
            ]

        for i, o in enumerate(gone):
            if id(o) not in lost:
                continue
            for j in np.flatnonzero(fits[i]):
                moves = explained(xy[j] - lay[i])
                for _ in range(2):  # the shift their mean says, not one pair's
                    if len(moves) < 2:
                        break
                    moves = explained(np.mean([m for _, m in moves], axis=0))
                if (
                    len(moves) >= 2
                    and 2 * len(moves) > len(alone)
                    and any(id(m) in lost for m, _ in moves)
                ):
                    return moves
        return []

    def _untouched(self, obj: TrackedObject, det: Detection) -> bool:
        """Whether the arm left ``obj`` alone since the last look and both saw it whole."""
        if obj is self._active or obj.merged or det.merged or self._near_active(obj):
            return False
        # an area that changed: partly hidden (by the arm) in one look, its centroid moved
        return abs(det.area_px - obj.area_px) <= SAME_AREA_RATIO * obj.area_px

    def _near_active(self, obj: TrackedObject) -> bool:
        """Whether ``obj`` lay where the jaws coming down on the active object may push it."""
        if self._active is None:
            return False
        g = self.config.arm.tool.gripper
        r = self.config.task.class_named(obj.class_name).diameter_cm / 2
        x, y = self._active_from_cm
        return bool(np.hypot(obj.x_cm - x, obj.y_cm - y) < g.open_cm / 2 + g.jaw_thickness_cm + r)

    def _match(self, seen: Seen) -> dict[int, TrackedObject]:
        """The known objects seen where they were: detection index → object.

        Each object on the table (not counted sorted) and each detection of its class
        within :data:`SAME_OBJECT_CM` of where it was pair up, the nearest pairs first:
        of two detections near one object, the farther is another object.
        """
        known = [o for o in self._objects if not o.sorted]
        distance = np.full((len(known), len(seen)), np.inf)
        for i, o in enumerate(known):
            for k, (det, (x, y)) in enumerate(seen):
                if det.color == o.class_name:
                    distance[i, k] = float(np.hypot(x - o.x_cm, y - o.y_cm))
        return {k: known[i] for i, k in nearest_pairs(distance, SAME_OBJECT_CM)}

    def _pushed_to(self, obj: TrackedObject, seen: Seen) -> tuple[float, float] | None:
        """Where the jaws pushed ``obj`` when a look no longer sees it where it lay, or ``None``.

        The object the arm went for is not where it lay, while a detection of its class
        is nearby that is none of the objects known on the table: the one detection
        not of touching objects within the open jaws' reach of where it lay
        (:func:`come_apart`'s), in the table an earlier look saw (not one the arm hid
        before, which may be an object not seen yet), while every other object of its
        class on the table is seen where it lay (a neighbour the jaws pushed would be
        missing too, and which is which unknown: then ``None``, and a later look follows
        the moved objects, :meth:`_dropped`). Closing jaws tipped a prism aside 3.9 cm,
        and the place counted it (simulated, docs/troubleshooting.md). One pushed half
        out of the picture counts too, where its visible part is seen: it is not in the
        jaws all the same. (A prism the twin's jaws flung 13 cm to the border, beyond
        this reach, still counts as picked: seed 4600026 of ``sim_shapes_mujoco``.)
        """
        taken = self._match(seen)
        present = {o.id for o in taken.values()}
        if any(
            o.class_name == obj.class_name and o.id not in present
            for o in self._objects
            if not o.sorted and o is not obj
        ):
            return None
        g = self.config.arm.tool.gripper
        r = self.config.task.class_named(obj.class_name).footprint_radius_cm
        reach = g.open_cm / 2 + g.jaw_thickness_cm + 2 * r
        x0, y0 = self._active_from_cm
        near = [
            (float(x), float(y))
            for k, (d, (x, y)) in enumerate(seen)
            if k not in taken
            and d.color == obj.class_name
            and not d.merged
            and self._seen_before(d)
            and np.hypot(x - x0, y - y0) <= reach
        ]
        return near[0] if len(near) == 1 else None

    def _seen_before(self, det: Detection) -> bool:
        """Whether an earlier look saw the table at a detection's centre (or none is known)."""
        return self._seen_px is None or bool(centre_seen(self._seen_px, det))

    @staticmethod
    def _on_table(obj: TrackedObject, seen: Seen) -> bool:
        return any(
            d.color == obj.class_name and np.hypot(x - obj.x_cm, y - obj.y_cm) <= SAME_OBJECT_CM
            for d, (x, y) in seen
        )

    def _skip(
        self, obj: TrackedObject, reason: str, target: Route | None = None, *, kind: str
    ) -> None:
        if obj.place_failed is not None:
            reason = f"{reason} (after its place failed: {obj.place_failed})"
        obj.skipped = reason
        obj.skip_kind = kind
        where = None if target is None else tuple(float(v) for v in target.target.position_cm)
        self.reporter.skip(Skip(obj.id, obj.class_name, reason, where, kind))  # type: ignore[arg-type]


def check_view(shifts: list[tuple[TrackedObject, np.ndarray]], source: str) -> None:
    """Refuse one shift of every object the arm left alone: the view moved.

    :meth:`TableTracking._track` measures the shifts.
    """
    if len(shifts) < 2:
        return
    moves = np.array([d for _, d in shifts])  # (n, 2) [cm]
    mean = moves.mean(axis=0)
    if np.all(np.linalg.norm(moves, axis=1) > VIEW_SHIFT_CM) and np.all(
        np.linalg.norm(moves - mean, axis=1) <= SAME_SHIFT_CM
    ):
        names = ", ".join(o.id for o, _ in shifts)
        raise CameraError(
            source,
            f"the view moved: {names}, which the arm did not go near, all appear "
            f"{float(np.linalg.norm(mean)):.2f} cm from where they lay (by ({mean[0]:.2f}, "
            f"{mean[1]:.2f}) cm); was the camera knocked? Fix its mount and recalibrate "
            "(tools/calibrate_camera.py)",
        )


def check_bins(
    sides: list[BinSide], first_seen: dict[tuple[str, tuple[float, float]], float], source: str
) -> None:
    """Refuse bins whose feet all appear moved alike: the view moved.

    A bin moved when a side of it is seen farther than :data:`BIN_PLACED_CM` from where the
    calibration puts its foot, or farther than :data:`BIN_SHIFT_CM` from where the first
    look that measured it near its place saw it (``first_seen``, kept here: each side's
    first offset within :data:`BIN_PLACED_CM`; farther, the arm's body, where a homography
    cannot say it shows, may stand before it: the MeArm v1's at home, 3.1 cm, simulated).
    Two or more bins moved, more than half of those measured, whose sides facing one way
    all moved alike (within :data:`SAME_SHIFT_CM`), are a moved view: one bin alone may be
    hidden in part by what the look cannot name (an object lying against its wall), and
    the arm's body, where the camera's calibration cannot say where it shows (a
    homography), moves the feet it crosses each by its own amount (its forearm over one
    bin, 1.1 cm, while its jaws hung over another: ``sim_mujoco_kits_paper``, simulated).
    Each look's bins are measured by :class:`~mearm.vision.bin_edges.BinFeet`.

    Raises:
        CameraError: the view moved; the bins and the farthest foot are named.
    """
    placed = [(s, s.offset_cm) for s in sides]
    since = [
        (s, s.offset_cm - first_seen[(s.class_name, s.normal)])
        for s in sides
        if (s.class_name, s.normal) in first_seen
    ]
    for moves, limit, where in (
        # (off their places from the first look: the bins themselves may stand off)
        (placed, BIN_PLACED_CM, "where the calibration puts them (or do they stand off "
         "their task.classes[].bin_cm?)"),
        (since, BIN_SHIFT_CM, "where an earlier look saw them"),
    ):  # fmt: skip
        measured = {s.class_name for s, _ in moves}
        bins = list(dict.fromkeys(s.class_name for s, cm in moves if abs(cm) > limit))
        if len(bins) < 2 or 2 * len(bins) <= len(measured):
            continue
        facing: dict[tuple[float, float], list[float]] = {}
        for s, cm in moves:
            if s.class_name in bins:
                facing.setdefault(s.normal, []).append(cm)
        alike = all(max(cms) - min(cms) <= SAME_SHIFT_CM for cms in facing.values())
        if not alike and not _one_view_change(moves):
            continue
        far = max(abs(cm) for s, cm in moves if s.class_name in bins)
        raise CameraError(
            source,
            f"the view moved: the bins of {', '.join(bins)}, which stand still, appear "
            f"up to {far:.2f} cm from {where}; was the camera knocked? Fix its mount and "
            "recalibrate (tools/calibrate_camera.py)",
        )
    for side in sides:  # (a foot far off its place was not seen: something stood before it)
        if abs(side.offset_cm) <= BIN_PLACED_CM:
            first_seen.setdefault((side.class_name, side.normal), side.offset_cm)


def _one_view_change(moves: list[tuple[BinSide, float]]) -> bool:
    """Whether one change of the view moved every foot measured, each as far as it should.

    A camera moved up or down (or tilted, along its tilt) sees the table scaled about the
    point under it, and shifted: a foot moves by ``t · normal + k · from_eye_cm`` (t the
    shift, k the scale's change less one; :attr:`BinSide.from_eye_cm`), the farther from
    that point the more. Feet facing one way then move each by its own amount (a camera
    5.7 cm lower than calibrated moved the -y feet of the green and blue bins 0.2 and
    -0.95 cm, their +x feet alike by -2 cm: ``sim_mujoco_perspective --set
    twin.camera.height_cm=49.3``, simulated), which the feet alike miss. They are one
    change when the three numbers fit every foot measured within :data:`SAME_SHIFT_CM`,
    with at least two feet more than the numbers (the arm's body moves the feet it crosses
    each by its own amount, which a fit of as many numbers as feet would take for one).
    """
    if not moves:
        return False
    a = np.array([[s.normal[0], s.normal[1], s.from_eye_cm] for s, _ in moves], dtype=float)
    b = np.array([cm for _, cm in moves], dtype=float)
    fit, _, rank, _ = np.linalg.lstsq(a, b, rcond=None)
    if len(b) < rank + 2:
        return False
    return bool(np.max(np.abs(a @ fit - b)) <= SAME_SHIFT_CM)


def work_surface_cm(config: Config) -> np.ndarray:
    """The work surface's outline: the calibrated field and the bins' hull, (k, 1, 2) [cm].

    The field is the frame's corners on the table by the calibration's homography
    (:func:`~mearm.vision.work_area.table_corners_cm`); outside it the camera sees no table.
    """
    corners = table_corners_cm(config.calibration, config.camera, config.task.classes)
    return cv2.convexHull(np.asarray(corners, dtype=np.float32).reshape(-1, 1, 2))


def on_surface(surface_cm: np.ndarray, xy_cm: npt.ArrayLike, margin_cm: float) -> bool:
    """Whether a table point is finite and within ``margin_cm`` of the outline ``surface_cm``."""
    x, y = (float(v) for v in np.asarray(xy_cm, dtype=float).reshape(2))
    if not (math.isfinite(x) and math.isfinite(y)):
        return False
    return cv2.pointPolygonTest(surface_cm, (x, y), measureDist=True) >= -margin_cm


def centre_seen(seen_px: np.ndarray, det: Detection) -> bool | None:
    """Whether ``seen_px`` (bool, (H, W)) is set at a detection's centre; ``None``: outside it."""
    h, w = seen_px.shape
    u, v = (int(round(float(c))) for c in det.centroid_px)
    return bool(seen_px[v, u]) if 0 <= u < w and 0 <= v < h else None


def table_cm(d: Detection) -> np.ndarray:
    """Where the detector located a detection on the table [cm] (it has the calibration)."""
    assert d.table_cm is not None
    return d.table_cm


def borders_hidden(det: Detection, hidden: np.ndarray) -> bool:
    """Whether the arm's body (``hidden``, 0/255, (H, W)) borders a detection's region.

    A pixel of it within :data:`BORDER_PX` of the region's box: part of the object may be
    hidden there, and its outline's fit is of the part seen.
    """
    h, w = hidden.shape[:2]
    x, y, bw, bh = det.bbox_px
    x0, y0 = max(x - BORDER_PX, 0), max(y - BORDER_PX, 0)
    x1, y1 = min(x + bw + BORDER_PX, w), min(y + bh + BORDER_PX, h)
    return bool(hidden[y0:y1, x0:x1].any())


def is_cut(det: Detection, width_px: int, height_px: int) -> bool:
    """Whether a detection's region touches the image border (only part of it is seen)."""
    x, y, w, h = det.bbox_px
    return x <= 0 or y <= 0 or x + w >= width_px or y + h >= height_px


def seen_cut(obj: TrackedObject, seen: Seen, width_px: int, height_px: int) -> bool:
    """Whether the look saw ``obj`` (a detection of its class where it is) cut by the border."""
    return any(
        d.color == obj.class_name
        and np.hypot(x - obj.x_cm, y - obj.y_cm) <= SAME_OBJECT_CM
        and is_cut(d, width_px, height_px)
        for d, (x, y) in seen
    )


def come_apart(seen: Seen, taken: Mapping[int, TrackedObject], config: Config) -> set[int]:
    """The detections that are the other object of a region of touching objects come apart.

    A known object last seen as such a region (``merged``, and larger than it is seen
    now by more than :data:`SAME_AREA_RATIO`: not one the arm hid in part) and seen whole
    now: the detection of its class nearest where it was, not taken by a known object,
    within the open jaws' reach and an object across (the jaws parted them), is the
    other object the region stood for.
    """
    g, camera = config.arm.tool.gripper, config.camera
    apart: set[int] = set()
    for k, obj in taken.items():
        det = seen[k][0]
        if not obj.merged or det.merged or is_cut(det, camera.width_px, camera.height_px):
            continue
        if obj.area_px <= (1 + SAME_AREA_RATIO) * det.area_px:
            continue  # as large as one object now: part of it was hidden
        r = config.task.class_named(obj.class_name).footprint_radius_cm
        reach = g.open_cm / 2 + g.jaw_thickness_cm + 2 * r
        near = {
            float(np.hypot(x - obj.x_cm, y - obj.y_cm)): j
            for j, (d, (x, y)) in enumerate(seen)
            if j not in taken and j not in apart and d.color == obj.class_name
        }
        nearest = min(near, default=np.inf)
        if nearest <= reach:
            apart.add(near[nearest])
    return apart
