r"""Objects followed across timestamped frames: a Kalman filter per object.

Each object the camera sees is a :class:`Track`: OpenCV's :class:`cv2.KalmanFilter` of
its state :math:`s = (x, y, \dot x, \dot y)` on the table [cm, cm/s] under a
constant-velocity model. Between two frames :math:`\Delta t` apart,

.. math::

    s_{k+1} = F s_k + w,\qquad F = \begin{pmatrix} I & \Delta t\,I \\ 0 & I \end{pmatrix},
    \qquad Q = \sigma_a^2 \begin{pmatrix} \tfrac{\Delta t^4}{4} I & \tfrac{\Delta t^3}{2} I \\
    \tfrac{\Delta t^3}{2} I & \Delta t^2 I \end{pmatrix}

(white acceleration of standard deviation :math:`\sigma_a`, ``accel_std_cm_s2``), and a
detection measures :math:`z = (x, y)` with noise :math:`\sigma_z` (``measurement_std_cm``).

**Time.** A frame shows the scene as it was ``camera.latency_s`` before it was read, so
:meth:`Tracker.update` is given the time the frame was *taken*: the read time minus the
latency.

**What is taken.** Only whole objects (:func:`whole_sightings`): a region cut by the arm
over it has its centre off the object's, and would pull the velocity with it; such a
region (smaller than ``min_area_share`` of the class's footprint) is left out and the
track coasts.

**Association.** A detection can only be of a track of its class, within ``gate_cm``
and three standard deviations of the track's predicted position (:meth:`Track.gate_cm`:
wider while a track's velocity is little known: an object seen once is taken to ride at
the belt's velocity, give or take the belt's speed). An object slower than the belt
(one that landed at rest and is still being brought up to its speed: at 100 cm/s in the
twin that takes some 0.17 s, two frames) may be anywhere from its prediction to where
the belt's velocity would have carried it since it was last seen: the distance is to
that stretch (:meth:`Track.reach_cm`), and a detection only the belt's pull explains
makes the track learn its velocity afresh (:meth:`Track.pulled`) rather than start a
second track of the same object;
the pairs are taken nearest first (greedily: on a belt objects of a class lie
centimetres apart, far more than the gate, so nearest-first and an optimal assignment
agree). A detection left over starts a track; a track left
over *coasts* on its prediction, unseen (the arm over it), and is dropped once it has
been unseen for ``coast_s``. A track keeps its id from the first frame to the last, so
an object hidden by the arm and seen again is the same object.

**A still table** (:func:`explain`): with no belt nothing brings objects to the table, so
a detection not where a known object was is a known object that is no longer where it
was (pushed by the jaws, dropped on the way to its bin, tipped and rolled, knocked out of
its bin), if one of its class is missing; only when none is, is it a new object. Objects
missing from the table before those carried to their bins (most likely there), and the
ones the arm went near before the others; within each, the nearest pairs first. No
distance is too far: in the physical twin the jaws pushed an upright object 12 cm from
where it stood and tipped cylinders rolled off the table, so a reach short of the table
would count a pushed object twice.

norfair, the tracking library that would do this, pins ``numpy<2`` and cannot be
installed with this package; the filter is OpenCV's.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from mearm.config import ColorClass
from mearm.config.belt_config import MAX_BELT_SPEED_CM_S, TrackingConfig
from mearm.vision.calibration import Calibration
from mearm.vision.detector import Detection
from mearm.vision.errors import TrackingError
from mearm.vision.pinhole import PerspectiveCamera


@dataclass(frozen=True)
class Seen:
    """One detection given to the tracker.

    Attributes:
        color: Its class's name.
        x_cm: Its centre on the table, base frame [cm].
        y_cm: Its centre on the table, base frame [cm].
    """

    color: str
    x_cm: float
    y_cm: float


def whole_sightings(
    detections: Iterable[Detection],
    calibration: Calibration | PerspectiveCamera,
    classes: Sequence[ColorClass],
    min_area_share: float,
) -> list[Seen]:
    """The detections of whole objects, as sightings for the tracker.

    Left out: merged regions (no centre of one object), regions with no place on the
    table (a detector without a calibration), and regions smaller than
    ``min_area_share`` of the class's footprint (``object_shape.area_cm2``) at the
    calibration's scale where they lie (an object partly hidden).
    """
    by_name = {c.name: c for c in classes}
    out = []
    for d in detections:
        c = by_name.get(d.color)
        if d.merged or c is None or d.table_cm is None:
            continue
        cm2_per_px = calibration.pixel_area_cm2(d.centroid_px).item()
        footprint_px = c.object_shape.area_cm2(c.diameter_cm) / cm2_per_px
        if d.area_px >= min_area_share * footprint_px:
            out.append(Seen(d.color, float(d.table_cm[0]), float(d.table_cm[1])))
    return out


@dataclass(frozen=True)
class TrackState:
    """A track's estimate at one time.

    Attributes:
        id: The track's number, kept for its object's whole life.
        color: Its class's name.
        t_s: The time of the estimate [s].
        position_cm: (x, y) on the table [cm], (2,).
        velocity_cm_s: (vx, vy) [cm/s], (2,).
        seen: Whether a detection was taken at this time (else it coasts).
        unseen_s: How long it has gone unseen [s].
    """

    id: int
    color: str
    t_s: float
    position_cm: np.ndarray
    velocity_cm_s: np.ndarray
    seen: bool
    unseen_s: float


class Track:
    """One object followed by a Kalman filter (the module docstring).

    Args:
        track_id: Its number.
        seen: The detection that starts it.
        t_s: When that detection was taken [s].
        tracking: The filter's noise.
        belt_cm_s: The belt's velocity (vx, vy) [cm/s]: the velocity it starts with, and
            its speed the standard deviation of that until more sightings (``None``: at
            rest, give or take the fastest belt a config may give).
    """

    def __init__(
        self,
        track_id: int,
        seen: Seen,
        t_s: float,
        tracking: TrackingConfig,
        belt_cm_s: tuple[float, float] | None = None,
    ):
        self.id = track_id
        self.color = seen.color
        self._accel_var = tracking.accel_std_cm_s2**2
        self._measurement_var = tracking.measurement_std_cm**2
        self._belt = None if belt_cm_s is None else np.array(belt_cm_s, dtype=float)
        kf = cv2.KalmanFilter(4, 2, 0, cv2.CV_64F)
        kf.measurementMatrix = np.hstack([np.eye(2), np.zeros((2, 2))])
        kf.measurementNoiseCov = np.eye(2) * self._measurement_var
        self._kf = kf
        self._start(seen)
        #: How many times its object was seen.
        self.sightings = 1
        #: The sightings its velocity is learned from (:meth:`correct`).
        self.learned_from = 1
        self.t_s = t_s
        self.last_seen_s = t_s
        #: Where it was last seen (x, y) [cm].
        self.last_seen_cm = np.array([seen.x_cm, seen.y_cm], dtype=float)
        self.seen = True

    def _start(self, seen: Seen) -> None:
        """Put the filter at ``seen``, at the belt's velocity give or take its speed."""
        vx, vy = (0.0, 0.0) if self._belt is None else self._belt
        speed = MAX_BELT_SPEED_CM_S if self._belt is None else math.hypot(vx, vy)
        self._kf.statePost = np.array([[seen.x_cm], [seen.y_cm], [vx], [vy]], dtype=float)
        # the velocity is the belt's, give or take its speed, until the sightings say more
        self._kf.errorCovPost = np.diag([self._measurement_var] * 2 + [speed**2] * 2)

    def _transition(self, dt: float) -> None:
        kf = self._kf
        F = np.eye(4)
        F[0, 2] = F[1, 3] = dt
        kf.transitionMatrix = F
        q = self._accel_var
        a, b, c = dt**4 / 4 * q, dt**3 / 2 * q, dt**2 * q
        kf.processNoiseCov = np.array(
            [[a, 0, b, 0], [0, a, 0, b], [b, 0, c, 0], [0, b, 0, c]], dtype=float
        )

    def predict(self, t_s: float) -> np.ndarray:
        """Move the estimate on to ``t_s`` (no later than now: never back); returns (x, y)."""
        dt = t_s - self.t_s
        if dt > 0:
            self._transition(dt)
            self._kf.predict()
            # predict() leaves statePost as it was; the prediction is the estimate now
            self._kf.statePost = self._kf.statePre.copy()
            self._kf.errorCovPost = self._kf.errorCovPre.copy()
            self.t_s = t_s
        self.seen = False
        return self.position_cm

    def correct(self, seen: Seen) -> None:
        """Take a detection at the track's current time.

        Corrected from the estimate now: OpenCV's ``correct()`` starts from the last
        ``predict()``'s state, and a track seen again in a frame dated as the last one
        (:meth:`predict` moves nothing) was not predicted since. One just started was
        never: its state there is zeros, and it went to (0, 0), at rest and certain of
        it, a phantom at the arm's base the belt's picks were then refused beside
        (``sim_conveyor --set belt.arrivals.seed=46313``, 6 cm/s, 1-2 s apart: 3 of 8
        sorted, simulated).

        On a moving belt the velocity is learned from the second sighting on: the
        first may show the object as it landed, at rest, before the belt brought it
        to its speed, and the constant-velocity model took the start-up for a slower
        object (the filter starts again there, :attr:`learned_from` counting from it).
        """
        kf = self._kf
        self.sightings += 1
        if self.sightings == 2 and self._belt is not None and np.any(self._belt):
            self._start(seen)
            self.learned_from = 0
        kf.statePre = kf.statePost.copy()
        kf.errorCovPre = kf.errorCovPost.copy()
        kf.correct(np.array([[seen.x_cm], [seen.y_cm]], dtype=float))
        self.learned_from += 1
        self.last_seen_s = self.t_s
        self.last_seen_cm = np.array([seen.x_cm, seen.y_cm], dtype=float)
        self.seen = True

    def gate_cm(self, gate_cm: float) -> float:
        """How far from its prediction a detection may be its object's [cm].

        ``gate_cm`` plus three standard deviations of the predicted position: wide for a
        track seen once (its velocity still unknown), ``gate_cm`` and a little more once
        its velocity is known.
        """
        cov = self._kf.errorCovPost[:2, :2]
        return gate_cm + 3.0 * math.sqrt(float(np.max(np.linalg.eigvalsh(cov))))

    def _pull(self) -> tuple[np.ndarray, float]:
        """The belt's velocity less the estimate's (2,) [cm/s], and the time unseen [s]."""
        if self._belt is None:
            return np.zeros(2), 0.0
        return self._belt - self.velocity_cm_s, self.t_s - self.last_seen_s

    def reach_cm(self) -> np.ndarray:
        """Where the object may be now: the stretch's two ends, (2, 2) [cm].

        From the prediction to where the object would be had it ridden at the belt's
        velocity since it was last seen: one slower than the belt is being brought up to
        its speed (it landed at rest), so it has gone at least as far as its estimate
        says and at most as far as the belt carries. Without a belt, or at the belt's
        velocity, both ends are the prediction.
        """
        dv, dt = self._pull()
        p = self.position_cm
        return np.array([p, p + dv * dt])

    def pulled(self) -> None:
        """The belt's pull sped the object up: take its next detection to learn from.

        The detection is farther down the belt than the estimate put it. The velocity
        since the object was last seen is uncertain by its difference from the belt's, so
        the correction learns it afresh.
        """
        dv, dt = self._pull()
        var = float(dv @ dv)
        block = np.array([[dt * dt, dt], [dt, 1.0]]) * var
        self._kf.errorCovPost = self._kf.errorCovPost + np.kron(block, np.eye(2))

    @property
    def position_cm(self) -> np.ndarray:
        """The estimated (x, y) [cm], (2,)."""
        return self._kf.statePost[:2, 0].copy()

    @property
    def velocity_cm_s(self) -> np.ndarray:
        """The estimated (vx, vy) [cm/s], (2,)."""
        return self._kf.statePost[2:, 0].copy()

    def position_at(self, t_s: float) -> np.ndarray:
        """Where the constant-velocity model puts the object at ``t_s`` [cm], (2,)."""
        return self.position_cm + self.velocity_cm_s * (t_s - self.t_s)

    def state(self) -> TrackState:
        """The estimate now, as a record."""
        return TrackState(
            self.id,
            self.color,
            self.t_s,
            self.position_cm,
            self.velocity_cm_s,
            self.seen,
            self.t_s - self.last_seen_s,
        )


class Tracker:
    """Tracks of the objects in a stream of timestamped detections (the module docstring).

    Args:
        tracking: The filter's noise, the gate and the coasting time.
        belt_cm_s: The belt's velocity (vx, vy) [cm/s], which an object seen once is
            taken to ride at, give or take its speed (``None``: at rest, give or take the
            fastest belt a config may give).

    Attributes:
        tracks: The live tracks, by id.
        lost: Ids of tracks dropped after coasting ``coast_s`` unseen, in order.
    """

    def __init__(self, tracking: TrackingConfig, belt_cm_s: tuple[float, float] | None = None):
        self.tracking = tracking
        self.belt_cm_s = belt_cm_s
        self.tracks: dict[int, Track] = {}
        self.lost: list[int] = []
        self._next_id = 1
        self._t_s: float | None = None

    def update(self, t_s: float, detections: Sequence[Seen]) -> list[TrackState]:
        """Take the detections of one frame taken at ``t_s``; returns every live track.

        Raises:
            TrackingError: ``t_s`` is not finite or earlier than the last frame's.
        """
        if not math.isfinite(t_s) or (self._t_s is not None and t_s < self._t_s):
            raise TrackingError(t_s, self._t_s)
        self._t_s = t_s
        ids = list(self.tracks)
        predicted = [self.tracks[tid].predict(t_s) for tid in ids]
        reach = [self.tracks[tid].reach_cm() for tid in ids]
        distance = np.full((len(ids), len(detections)), math.inf)
        for i, tid in enumerate(ids):
            for k, d in enumerate(detections):
                if d.color == self.tracks[tid].color and not self._upstream(tid, d):
                    distance[i, k] = distance_to_path(reach[i], (d.x_cm, d.y_cm))
        gates = [self.tracks[tid].gate_cm(self.tracking.gate_cm) for tid in ids]
        taken_detections: set[int] = set()
        for i, k in nearest_pairs(distance, gates):
            track, d = self.tracks[ids[i]], detections[k]
            if float(np.hypot(*(predicted[i] - (d.x_cm, d.y_cm)))) > gates[i]:
                track.pulled()  # only the belt's pull explains it
            track.correct(d)
            taken_detections.add(k)
        for tid in list(self.tracks):
            if t_s - self.tracks[tid].last_seen_s > self.tracking.coast_s:
                del self.tracks[tid]
                self.lost.append(tid)
        for k, d in enumerate(detections):
            if k not in taken_detections:
                self.tracks[self._next_id] = Track(
                    self._next_id, d, t_s, self.tracking, self.belt_cm_s
                )
                self._next_id += 1
        return [track.state() for track in self.tracks.values()]

    def _upstream(self, track_id: int, d: Seen) -> bool:
        """Whether ``d`` lies up the belt from where the track's object was last seen.

        More than ``gate_cm`` up: a belt carries its objects down, never up, so it is
        another object. A track unseen for long is given a wide gate (its velocity
        little known: its position's spread grows as the belt's speed times the time
        unseen), and took an object of its class just landed 63 cm up the belt from its
        prediction for the one it followed, left on the belt by a failed pick: the new
        one was never sorted, and said "never seen by the camera" (``sim_conveyor`` at
        10 cm/s, ``belt.arrivals.seed=46375``, simulated). Without a moving belt: never.
        """
        if self.belt_cm_s is None:
            return False
        belt = np.asarray(self.belt_cm_s, dtype=float)
        speed = float(np.hypot(*belt))
        if speed == 0.0:
            return False
        back = self.tracks[track_id].last_seen_cm - (d.x_cm, d.y_cm)
        return float(back @ belt) / speed > self.tracking.gate_cm

    def drop(self, track_id: int) -> None:
        """Forget a track (its object was picked up)."""
        self.tracks.pop(track_id, None)


def nearest_pairs(
    distance_cm: np.ndarray, reach_cm: float | Sequence[float] = math.inf
) -> list[tuple[int, int]]:
    """Rows paired with columns, the nearest pair first, each row and column at most once.

    Greedy: the closest pair left is taken, then the next closest of those whose row and
    column are both still free (ties: the lower row, then the lower column).

    Args:
        distance_cm: (rows, columns) distances [cm]; ``inf`` where a pair may not be made.
        reach_cm: How far apart a pair may be: one for every row, or one per row.

    Returns:
        The ``(row, column)`` pairs in the order taken.
    """
    d = np.asarray(distance_cm, dtype=float)
    if d.size == 0:
        return []
    reach = np.broadcast_to(np.asarray(reach_cm, dtype=float), (d.shape[0],))
    rows: set[int] = set()
    cols: set[int] = set()
    pairs = []
    for flat in np.argsort(d, axis=None, kind="stable").tolist():
        i, j = divmod(flat, d.shape[1])
        if not (math.isfinite(d[i, j]) and d[i, j] <= reach[i]):
            continue
        if i in rows or j in cols:
            continue
        pairs.append((i, j))
        rows.add(i)
        cols.add(j)
    return pairs


def distance_to_path(path_cm: np.ndarray, point_cm: Sequence[float] | np.ndarray) -> float:
    """The distance of a point (2,) from a polyline (k ≥ 1, 2) [cm] (k = 1: a point)."""
    path = np.atleast_2d(np.asarray(path_cm, dtype=float))
    p = np.asarray(point_cm, dtype=float)
    if len(path) == 1:
        return float(np.linalg.norm(path[0] - p))
    a, ab = path[:-1], np.diff(path, axis=0)
    t = np.einsum("kd,kd->k", p - a, ab) / np.maximum(np.einsum("kd,kd->k", ab, ab), 1e-12)
    nearest = a + np.clip(t, 0.0, 1.0)[:, None] * ab
    return float(np.min(np.linalg.norm(nearest - p, axis=1)))


@dataclass(frozen=True)
class Missing:
    """A known object not seen where it was, on a still table (:func:`explain`).

    Attributes:
        color: Its class's name.
        from_cm: Where it may have gone from, (k, 2) [cm]: where it was last seen, and
            for an object carried away the path it was carried along.
        touched: Whether the arm went near it since it was last seen.
        carried: Whether it was carried to its bin (its release unconfirmed): it is most
            likely there, and explains a sighting only when no object missing from the
            table can.
    """

    color: str
    from_cm: np.ndarray
    touched: bool
    carried: bool = False


def explain(missing: Sequence[Missing], appeared: Sequence[Seen]) -> list[tuple[int, int]]:
    """Which missing object each detection not where a known object was is.

    A still table (the module docstring): by class; the objects missing from the table
    before those carried to their bins, and within each those the arm touched before the
    others; the nearest pairs first (the distance from where a missing object may have
    gone from, :attr:`Missing.from_cm`), whatever the distance. A detection left over is
    a new object.

    Returns:
        ``(missing, appeared)`` index pairs.
    """
    distance = np.full((len(missing), len(appeared)), math.inf)
    for i, m in enumerate(missing):
        for j, s in enumerate(appeared):
            if s.color == m.color:
                distance[i, j] = distance_to_path(m.from_cm, (s.x_cm, s.y_cm))
    pairs: list[tuple[int, int]] = []
    for carried, touched in ((False, True), (False, False), (True, True), (True, False)):
        rows = [i for i, m in enumerate(missing) if (m.carried, m.touched) == (carried, touched)]
        taken = {j for _, j in pairs}
        cols = [j for j in range(len(appeared)) if j not in taken]
        for a, b in nearest_pairs(distance[np.ix_(rows, cols)]):
            pairs.append((rows[a], cols[b]))
    return pairs
