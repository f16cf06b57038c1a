r"""Sorting what a conveyor belt brings: track each object, pick it where it will be.

:class:`ConveyorSorter` runs the sort of ``config.belt`` (:mod:`mearm.config.belt_config`):

1. **Look** every :data:`LOOK_PERIOD_S` while the arm waits, and after every move: each
   frame is dated when it was taken (the bus's clock minus ``camera.latency_s``), its
   whole objects on the belt feed the tracker (:class:`~mearm.vision.tracking.Tracker`),
   and a track the arm hides coasts on its prediction. Each frame is checked as the still
   table's looks are: black, frozen, or the bins seen moved (the camera was knocked; the
   belt's objects move, so only the bins, which stand still, can show it).
2. **Choose** the object farthest down the belt whose track has a velocity (learned
   from :data:`MIN_SIGHTINGS` sightings; on a moving belt not from the first, which may
   show the object as it landed, at rest: :meth:`~mearm.vision.tracking.Track.correct`).
3. **Intercept**: the pick is planned for where the object will be when the jaws close
   on it. With :math:`p(t)` the track's constant-velocity prediction, the grip time
   solves

   .. math:: t_g = t_0 + T_{approach}(p(t_g)) + T_{pick}(p(t_g)) + T_{tool}

   by fixed-point iteration: each round plans the approach (above the object) and the
   pick to :math:`p(t_g)` in full, with their collision checks, and times them with the
   servo time law (Ruckig, :func:`~mearm.task.timing.time_path`), plus the tool's
   travel to its grip setting; the jaws start closing then, around the object. The
   other objects are checked where they will be at :math:`t_g`.
4. **Close following**: the jaws take the gripper's travel and settling to close
   (:func:`~mearm.task.timing.tool_move_s`), and the object rides on meanwhile; the arm
   follows it there, one command a bus period to where its track puts it then, each
   pose planned and the whole checked (collisions, the servos' time law) before the
   catch sends anything (:meth:`ConveyorSorter._follow`). Closed where it stood, the
   twin's jaws met a 10 cm/s belt's object 1.2 cm downstream of their middle, off their
   1.48 cm wide pads, and every catch failed from 6 cm/s on.
5. An object whose intercept lies off the belt's end, or out of the arm's reach before
   it gets there, is left **missed on the belt** (``missed_belt``), as is one whose
   track is lost; one whose pick is refused for a collision is left for that
   (``collision``, "no route clear of collisions"), its reason still saying it was
   missed on the belt.

Lift, place, release and the outcome are the still table's
(:class:`~mearm.task.sorter.Sorter`): in simulation an object counts as sorted only when
the world or the twin's physics holds it in its bin, and an object the belt brought that
the camera never saw counts too, left ``unseen``. With a recorder (``--record``) each
catch is an episode, as the still table's pick-and-place is
(:meth:`~mearm.task.pick_place.PickAndPlace._recorded_pick`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from mearm import interrupts
from mearm.config import ColorClass, Config
from mearm.errors import MearmError
from mearm.hardware.bus import ServoBus
from mearm.ik import IKTarget
from mearm.kinematics.collision import TOUCH_M
from mearm.sim.belt import Belt, belt_arrivals
from mearm.task.pick_place import (
    failure_kind,
    holds_its_class,
    objects_gripped,
    place_failure,
    place_note,
)
from mearm.task.report import Outcome, SortReport
from mearm.task.route import Route
from mearm.task.sorter import Sorter, TrackedObject, _hex
from mearm.task.table_tracking import check_bins
from mearm.task.timing import TimedPath, tool_move_s
from mearm.vision import Camera
from mearm.vision.tracking import (
    Track,
    Tracker,
    TrackState,
    distance_to_path,
    whole_sightings,
)

#: Why a pick on the belt failed: over the bin, the camera still tracks the object on.
BELT_PICK_MISSED = "the camera still sees it on the belt, where it rode on from the grip"
#: How often the camera is read while the arm waits for an object [s].
LOOK_PERIOD_S = 0.1
#: Sightings a track's velocity is learned from before it is trusted for an intercept.
MIN_SIGHTINGS = 3
#: The intercept's rounds: each plans the routes to the last round's grip point.
INTERCEPT_ROUNDS = 8
#: The intercept has converged when the grip point moves less than this [cm].
INTERCEPT_TOL_CM = 0.02


@runtime_checkable
class KeepsTime(Protocol):
    """A bus that simulates time (the kinematic arm's world, the twin's physics)."""

    @property
    def time_s(self) -> float: ...  # noqa: D102


@dataclass(frozen=True)
class GripAim:
    """Where the jaws were sent to close on a moving object.

    Attributes:
        object_id: The object.
        t_s: When the jaws close on it, on the bus's clock [s].
        aim_cm: Where its track put it then (x, y) [cm], (2,).
    """

    object_id: str
    t_s: float
    aim_cm: np.ndarray


@dataclass(frozen=True)
class Intercept:
    """The routes that catch a moving object, as :meth:`ConveyorSorter._intercept` planned.

    Attributes:
        above: The approach to above the object, or ``None`` where the pick goes there
            directly.
        pick: The descent to where the object will be.
        t_grip_s: When the jaws close on it, on the bus's clock [s].
        timed: The routes' commands as the servos will follow them, in order
            (:meth:`~mearm.task.execute.Executor.followed`: the stream sends these); empty
            where a plan failed.
        wait_s: How long the open jaws wait there for the object [s].
    """

    above: Route | None
    pick: Route
    t_grip_s: float
    timed: list[TimedPath] = field(default_factory=list)
    wait_s: float = 0.0


@dataclass(frozen=True)
class Riding:
    """An object the jaws closed on and carried off: where it may have fallen back.

    Attributes:
        obj: The object.
        aim_cm: Where the jaws closed on it (x, y) [cm], (2,).
        t_s: When, on the bus's clock [s].
        carried_cm: Where the jaws carried it on to its bin: the place's commands' TCP
            (x, y) [cm], (k, 2).
        carried_t_s: When each was sent [s], (k,).
    """

    obj: TrackedObject
    aim_cm: np.ndarray
    t_s: float
    carried_cm: np.ndarray
    carried_t_s: np.ndarray


class ConveyorSorter(Sorter):
    """Sorts the objects a belt brings (the module docstring).

    Takes :class:`~mearm.task.sorter.Sorter`'s arguments, and:

    Args:
        on_grip: Called with each :class:`GripAim` as the jaws close (a simulation
            measures there how far the track was from the object).

    Raises:
        ValueError: ``config.belt`` is not set.
    """

    def __init__(
        self,
        config: Config,
        camera: Camera,
        bus: ServoBus,
        *,
        on_grip: Callable[[GripAim], None] | None = None,
        **kwargs: Any,
    ):
        super().__init__(config, camera, bus, **kwargs)
        if self.config.belt is None:
            raise ValueError("ConveyorSorter needs config.belt")
        self.belt = Belt(self.config.belt)
        belt_cm_s = tuple(float(v) for v in self.belt.velocity_cm_s)
        self.tracker = Tracker(self.config.belt.tracking, (belt_cm_s[0], belt_cm_s[1]))
        self.on_grip = on_grip
        self._by_track: dict[int, TrackedObject] = {}
        #: Where each track's object was last seen (x, y) [cm]: a lost track's is said.
        self._seen_cm: dict[int, tuple[float, float]] = {}
        #: Objects the jaws closed on and carried off, until the look over the bin said
        #: whether they still lie on the belt: a new track where one may lie is it.
        self._riding_on: list[Riding] = []
        self._t0 = time.monotonic()
        self._last_frame_s = -np.inf
        self._last_seen_s = 0.0
        self._planning_s = 0.0

    # ----------------------------------------------------------------- time and sight

    def now_s(self) -> float:
        """The bus's simulated time, or the wall clock since the start on a real rig [s]."""
        if isinstance(self.bus, KeepsTime):
            return float(self.bus.time_s)
        return time.monotonic() - self._t0

    def _observe(self) -> list[TrackState]:
        """Read a frame, feed its whole objects on the belt to the tracker.

        Raises:
            CameraError: the frame is black, or the stream froze (:class:`FrameCheck`, as
                the still table's looks check): the sort stops on it and parks, where a
                belt watched by a dead camera ran on, every later object "never seen";
                or the bins appear moved (:func:`check_bins`, as the still table's looks
                check): the view moved.
        """
        frame = self.camera.read()
        self.frame_check.check(frame, self.camera.frame_time_s, self.camera.clock_s)
        hidden = None if self.arm_in_view is None else self.arm_in_view(frame.shape)
        if self._bin_feet_cm is None:
            self._bin_feet_cm = {}
        check_bins(self._bin_feet.measure(frame, hidden), self._bin_feet_cm, self.camera.source)
        taken = max(self.now_s() - self.config.camera.latency_s, self._last_frame_s)
        self._last_frame_s = taken
        tracking = self.tracker.tracking
        seen = [
            s
            for s in whole_sightings(
                self.detector.detect(frame),
                self.calibration,
                self.config.task.classes,
                tracking.min_area_share,
            )
            if self.belt.carries(s.x_cm, s.y_cm)
        ]
        before = set(self.tracker.lost)
        states = self.tracker.update(taken, seen)
        for s in states:
            if s.seen:
                self._seen_cm[s.id] = (float(s.position_cm[0]), float(s.position_cm[1]))
            obj = self._by_track.get(s.id)
            if obj is None:
                obj = self._ridden_on(s, taken)
                if obj is not None:
                    self._by_track[s.id] = obj
            if obj is None:
                n = sum(1 for o in self._objects if o.class_name == s.color) + 1
                x, y = (float(v) for v in s.position_cm)
                obj = TrackedObject(f"{s.color}{n}", s.color, x, y)
                self._objects.append(obj)
                self._by_track[s.id] = obj
            obj.x_cm, obj.y_cm = (float(v) for v in s.position_cm)
            if s.seen and not obj.sorted and obj.skipped is None:
                # the belt still brings something to sort; an object left (a failed pick,
                # out of reach) that stays in view, a still belt's, kept the run waiting
                # for ever
                self._last_seen_s = taken
        for tid in set(self.tracker.lost) - before:
            obj = self._by_track.get(tid)
            if obj is not None and not obj.sorted and obj.skipped is None:
                # where it was last seen, not where its prediction coasted to since
                obj.x_cm, obj.y_cm = self._seen_cm.get(tid, (obj.x_cm, obj.y_cm))
                self._skip(
                    obj,
                    f"missed on the belt: its track was lost (last seen at ({obj.x_cm:.1f}, "
                    f"{obj.y_cm:.1f}) cm)",
                    kind="missed_belt",
                )
        return states

    def _ridden_on(self, s: TrackState, taken_s: float) -> TrackedObject | None:
        """The object a failed pick left on the belt that a new track ``s`` is, if any.

        Of its class, within the tracking gate of where it may be (:meth:`_rode_on`):
        counted once, and left as its pick failed (its track was dropped at the grip, so
        the camera's next sighting of it began a new one, a new object).
        """
        gate = self.tracker.tracking.gate_cm
        for k, riding in enumerate(self._riding_on):
            if riding.obj.class_name != s.color:
                continue
            if (
                min(distance_to_path(w, s.position_cm) for w in self._rode_on(riding, taken_s))
                <= gate
            ):
                del self._riding_on[k]
                return riding.obj
        return None

    def _rode_on(self, riding: Riding, t_s: float) -> list[np.ndarray]:
        """Where an object the jaws closed on may lie on the belt at ``t_s``: polylines [cm].

        The stretch from where the jaws closed to where riding on since would have carried
        it, (2, 2). Left by jaws that never held it, it rode on all the time; lifted and
        dropped back, it rode only from when it fell: in the twin at 10 cm/s
        (``belt.arrivals.seed=48808``) the jaws lifted red8 at x = 8.4 cm and lost it,
        and 1.5 s later it lay at x = -1.5 cm, not -6.2 cm; looked for at the far end
        alone, it was taken for a new object, and the sort named it twice.

        And, where the jaws carried it on towards its bin (:attr:`Riding.carried_cm`),
        each point they passed with the ride on from there, (k, 2): lost on the swing
        over the belt, it lands downstream of anywhere riding would have taken it (the
        kinematic belt at 10 cm/s, the jaws losing blue1 at their place's first command,
        at (0.3, 49.3) cm: the look over the bin saw it 3.0 cm from the stretch, took it
        for a new object, blue2, and called the pick good; the world counted it once, a
        real rig would have counted two).
        """
        v = self.belt.velocity_cm_s
        aim = np.asarray(riding.aim_cm, dtype=float)
        where = [np.array([aim, aim + v * (t_s - riding.t_s)])]
        passed = riding.carried_t_s <= t_s
        if np.any(passed):
            ridden = (t_s - riding.carried_t_s[passed])[:, None] * v
            where.append(riding.carried_cm[passed] + ridden)
        return where

    def _wait(self) -> None:
        """Let one look period pass with the arm still (the belt runs on)."""
        self.bus.hold(LOOK_PERIOD_S)

    # ----------------------------------------------------------------- choice

    def _choose_track(self, states: list[TrackState]) -> tuple[TrackedObject, int] | None:
        """The object farthest down the belt with a trusted velocity, and its track id."""
        ready = []
        for s in states:
            obj = self._by_track[s.id]
            if obj.sorted or obj.skipped is not None:
                continue
            if self.tracker.tracks[s.id].learned_from < MIN_SIGHTINGS:
                continue
            along, _ = self.belt.along_across_cm(*s.position_cm)
            ready.append((along, s.id))
        if not ready:
            return None
        _, tid = max(ready)
        return self._by_track[tid], tid

    # ----------------------------------------------------------------- intercept

    def _tool_s(self, phase: str, before: tuple[str, bool], *, closed: bool) -> float:
        ex = self.executor
        return tool_move_s(
            self.config.arm.tool,
            ex.tool_settings(before[0]),  # type: ignore[arg-type]
            ex.tool_settings(phase),  # type: ignore[arg-type]
            before_closed=before[1],
            after_closed=closed,
        )

    def _intercept(self, obj: TrackedObject, tid: int) -> Intercept:
        """The approach and pick routes to where the object will be, and when [s].

        Returns the last round's routes, and no commands, when a plan fails (the caller
        reports why). Where the rounds do not converge, a route that is timed as it will
        be sent can jump between two timings (its chords clear at the servos' full speed
        or not): aimed a little farther down the belt it arrives early, aimed at that
        time it arrives late. The last round that arrives no later than its object is
        taken, its jaws held open until the object comes (:attr:`Intercept.wait_s`);
        a round that arrived late was aimed at where the object had been.

        Raises:
            CollisionError: a planned route's commands come too close to something even at
                the slowest of the servos' speeds (nothing was sent; a stream would refuse
                them as well).
        """
        ex, track = self.executor, self.tracker.tracks[tid]
        cls = self.config.task.class_named(obj.class_name)
        # from the travel setting with open jaws: the tool's move to its grip setting;
        # the jaws close from there, around where the object is then
        # (the setting is one command, which takes a servo period before the hold)
        tool_s = self._tool_s("grip", ("travel", False), closed=False) + self.bus.period_s
        # on a real rig the belt runs on while the routes are planned: the arm sets off
        # that much later (the last intercept's planning time; a simulator's clock waits)
        t0 = self.now_s() + self._planning_s
        t_grip = t0 + tool_s
        p = track.position_at(t_grip)
        pick = Route(obj.id, obj.class_name, "pick", obj.failed_picks + 1,
                     self._on_belt(cls, p))  # fmt: skip
        last = Intercept(None, pick, t_grip)
        early: Intercept | None = None
        for _ in range(INTERCEPT_ROUNDS):
            self._objects_at(t_grip)  # every object where it will be as the jaws close
            pick = Route(obj.id, obj.class_name, "pick", obj.failed_picks + 1,
                         self._on_belt(cls, p))  # fmt: skip
            self._world()
            above = self._approach(obj, pick)
            last = Intercept(above, pick, t_grip)
            if above is None:
                self.planner.plan(pick, ex.q_now(), target=obj.id)
            elif above.planned and above.plan is not None:
                self.planner.plan(pick, above.plan.q, target=obj.id)
            if not (pick.planned and (above is None or above.planned)):
                return last
            # timed as they will be sent, in this round's world: a route whose commands'
            # chords pass too near something is sent at a fraction of the servos' speeds.
            # Timed at their full speed, the first pick from home of a 20-object belt,
            # beside the red bin's walls (sent at half speed), brought the jaws 0.18 s
            # after the object: 1.8 cm behind it at 10 cm/s, past the grip's tolerance,
            # and every catch failed from 7 cm/s on
            timed = [ex.followed(r, carrying=False) for r in (above, pick) if r is not None]
            t_next = t0 + sum(t.duration_s for t in timed) + tool_s
            p_next = track.position_at(t_next)
            if t_next <= t_grip:  # there no later than the object, which it waits for
                early = Intercept(above, pick, t_grip, timed, wait_s=t_grip - t_next)
            last = Intercept(above, pick, t_next, timed)
            converged = float(np.hypot(*(p_next - p))) < INTERCEPT_TOL_CM
            t_grip, p = t_next, p_next
            if converged:
                return last
        if early is None:
            return last
        self._objects_at(early.t_grip_s)
        return early

    def _close_s(self) -> float:
        """How long the open jaws take to close at the grip setting: travel and settling [s]."""
        return self._tool_s("grip", ("grip", False), closed=True)

    def _closing(
        self, obj: TrackedObject, tid: int, caught: Intercept
    ) -> tuple[np.ndarray, np.ndarray, float] | None:
        """The close's follow (:meth:`_follow`), where the object is then and when [s].

        ``None``: the object is left, for why (past the belt's end by then, a follow that
        cannot be planned or sent).
        """
        closed_cm, t_closed = self._closed_at(tid, caught)
        if self._left_past_end(obj, tid, caught):
            return None
        follow = self._follow(obj, tid, caught)
        if isinstance(follow, Route):
            kind = "collision" if failure_kind(follow) == "collision" else "missed_belt"
            self._skip(obj, f"missed on the belt: {follow.failure}", follow, kind=kind)
            return None
        return follow, np.asarray(closed_cm, dtype=float), t_closed

    def _closed_at(self, tid: int, caught: Intercept) -> tuple[np.ndarray, float]:
        """Where the track puts the object when the jaws have closed on it [cm], and when [s]."""
        period = self.bus.period_s
        t_closed = caught.t_grip_s + math.ceil(self._close_s() / period - 1e-9) * period
        return self.tracker.tracks[tid].position_at(t_closed), t_closed

    def _left_past_end(self, obj: TrackedObject, tid: int, caught: Intercept) -> bool:
        """Whether the object would be past the belt's end when the jaws closed: left so.

        Checked before a refused intercept's own reason too: one aimed past the end was
        refused for what lies beyond it (in the twin at 8 cm/s, ``belt.arrivals.seed=49886``
        1.5-2.5 s apart, blue3 aimed 4 cm past the end, beside the green bin, was left
        "no route clear of collisions").
        """
        closed_cm, _ = self._closed_at(tid, caught)
        along, _ = self.belt.along_across_cm(*closed_cm)
        if along <= self.belt.config.length_cm:
            return False
        self._skip(
            obj,
            f"missed on the belt: it would be {along - self.belt.config.length_cm:.1f} cm "
            "past the belt's end when the jaws closed on it",
            caught.pick,
            kind="missed_belt",
        )
        return True

    def _follow(self, obj: TrackedObject, tid: int, caught: Intercept) -> np.ndarray | Route:
        """The poses that keep the jaws on the object while they close, (k + 1, n).

        From the pick's end, one pose a bus period to where the track puts the object
        then, for the close's whole travel and settling. Each pose is planned from the
        last; the commands are checked against the world at the grip (every object on
        the belt rides along with the jaws, so none comes closer than at the pick's end,
        which its plan checked; the bins and what lies on the table stand still) and
        timed by the servos' time law, which must keep up with them. The step that
        fails is returned instead, unplanned, its failure saying that it was following
        the object while the jaws closed, then why (its plan's own reason, which alone
        read as the pick's: ``needs base = 88.41 deg, outside its limits``).
        """
        ex, track = self.executor, self.tracker.tracks[tid]
        cls = self.config.task.class_named(obj.class_name)
        close_s, period = self._close_s(), self.bus.period_s
        pick = caught.pick
        assert pick.plan is not None
        poses = [pick.plan.q]
        self._objects_at(caught.t_grip_s)
        self._world()
        step = pick
        for k in range(1, math.ceil(close_s / period - 1e-9) + 1):
            p = track.position_at(caught.t_grip_s + k * period)
            step = Route(obj.id, obj.class_name, "pick", obj.failed_picks + 1,
                         self._on_belt(cls, p))  # fmt: skip
            self.planner.plan(step, poses[-1], target=obj.id)
            if not step.planned or step.plan is None:
                step.failure = _while_closing(step)
                return step
            poses.append(step.plan.q)
        q = np.array(poses)
        contact = self.collision.first_contact(q, target=obj.id, allowance_m=TOUCH_M)
        if contact is not None:
            step.failure_kind = "collision"
            chain = ex.chain
            step.failure = "collision: following it while the jaws close, " + contact.describe(
                chain.names, chain.scale
            )
            return step
        need_s = ex.timed(q).duration_s
        if need_s > (len(q) - 1) * period + 1e-9:
            step.failure_kind = "limit"
            step.failure = (
                f"the servos take {need_s:.2f} s to follow it {len(q) - 1} bus periods "
                f"({(len(q) - 1) * period:.2f} s) while the jaws close"
            )
            return step
        return q

    def _objects_at(self, t_s: float) -> None:
        """Put every tracked object where its track predicts it at ``t_s``."""
        for o in self._objects:
            state = self._track_of(o)
            if state is not None:
                o.x_cm, o.y_cm = (float(v) for v in state.position_at(t_s))

    def _on_belt(self, cls: ColorClass, xy_cm: np.ndarray) -> IKTarget:
        """The pick target of an object lying on the belt: its surface lifts it."""
        target = self.planner.pick_target(cls, float(xy_cm[0]), float(xy_cm[1]))
        return self.planner.above_target(target, self.belt.config.surface_cm)

    def _track_of(self, obj: TrackedObject) -> Track | None:
        for tid, o in self._by_track.items():
            if o is obj:
                return self.tracker.tracks.get(tid)
        return None

    # ----------------------------------------------------------------- one object

    def _recorded_catch(self, obj: TrackedObject, tid: int) -> None:
        """:meth:`_catch` as an episode of the recording, if there is one.

        The still table's convention (:meth:`~mearm.task.pick_place.PickAndPlace._recorded_pick`):
        the episode opens as the catch starts and ends once it has placed (or left) the
        object; a fault or Ctrl-C abandons it. Per scene the first catch opens the one
        episode, which the run's end writes.
        """
        recorder = self.recorder
        if recorder is None:
            self._catch(obj, tid)
            return
        recorder.begin(obj.class_name)
        try:
            self._catch(obj, tid)
        except BaseException:
            recorder.abandon()
            raise
        recorder.end()

    def _reach(self, caught: Intercept, cls: ColorClass, t_start: float) -> None:
        """Send the intercept's routes as it timed them and open the jaws there.

        Where the routes arrive before the object (:attr:`Intercept.wait_s`), the open
        jaws wait for it.
        """
        ex = self.executor
        if caught.above is not None:
            ex.stream(caught.above, "travel", closed=False, timed=caught.timed[0])
        color = _hex(cls.draw_rgb)
        ex.stream(caught.pick, "travel", closed=False, color=color, timed=caught.timed[-1])
        ex.finish(caught.pick, t_start)
        ex.set_tool("grip", closed=False)
        if caught.wait_s > 0:
            self.bus.hold(caught.wait_s)

    def _catch(self, obj: TrackedObject, tid: int) -> None:
        cls = self.config.task.class_named(obj.class_name)
        ex = self.executor
        t_start = time.perf_counter()
        planning = time.monotonic()
        caught = self._intercept(obj, tid)
        above, pick, t_grip = caught.above, caught.pick, caught.t_grip_s
        if not isinstance(self.bus, KeepsTime):
            self._planning_s = time.monotonic() - planning
        failed = pick if above is None or above.planned else above
        if not failed.planned:
            if self._left_past_end(obj, tid, caught):
                return
            reason = f"missed on the belt: {failed.failure or 'no plan'}"
            # a route refused for a collision is counted as one (``no route clear of
            # collisions``): 45 objects whose every pick met the red bin's grown walls
            # were counted "45 missed on the belt", which names no cause
            kind = "collision" if failure_kind(failed) == "collision" else "missed_belt"
            self._skip(obj, reason, failed, kind=kind)
            return
        closing = self._closing(obj, tid, caught)
        if closing is None:
            return
        follow, aim, t_closed = closing
        self._reach(caught, cls, t_start)
        if self.on_grip is not None:
            aimed = np.array(pick.target.position_cm[:2], dtype=float)
            self.on_grip(GripAim(obj.id, self.now_s(), aimed))
        ex.close_following(follow, "grip", self._close_s())
        t_grip = t_closed  # (where the jaws closed on it, following it, and when)
        closed_on = objects_gripped(self.bus)
        ex.show_held((obj.id, obj.class_name))
        ex.set_tool("travel", closed=True)
        self.tracker.drop(tid)
        obj.x_cm, obj.y_cm = float(aim[0]), float(aim[1])
        self._world(held=obj, opening_cm=cls.diameter_cm)
        planned = self._lift_and_plan_place(obj, cls, above, pick)
        if planned is None:
            return
        place, t1 = planned
        pick.confirmed = False
        try:
            # the place's commands, and when each is sent: where the jaws carry it over the
            # belt, it may fall from them (:meth:`_rode_on`)
            timed = ex.followed(place, carrying=True)
            t_place = self.now_s()
            self._riding_on.append(
                Riding(
                    obj,
                    np.array(aim, dtype=float),
                    t_grip,
                    np.array([self.model.fk_cm(q)[:2] for q in timed.q]),
                    t_place + timed.period_s * np.arange(len(timed.q)),
                )
            )
            ex.stream(place, "travel", closed=True, color=_hex(cls.draw_rgb), timed=timed)
            # over the bin the camera sees the belt whole: a grip that held left nothing
            # of the class where the object would be now (and what it sees there is this
            # object riding on, not a new one)
            states = self._observe()
            where = np.array(aim) + self.belt.velocity_cm_s * (self.now_s() - t_grip)
            pick.success = not any(
                s.seen
                and (
                    # the sighting taken for it, dropped back short of where it would
                    # have ridden to (:meth:`_rode_on`)
                    self._by_track.get(s.id) is obj
                    or s.color == obj.class_name
                    and float(np.hypot(*(s.position_cm - where))) <= self.tracker.tracking.gate_cm
                )
                for s in states
            )
            pick.why_failed = None if pick.success else BELT_PICK_MISSED
            pick.confirmed = True
            if pick.success:  # (not seen riding on: no later track is it)
                self._riding_on = [r for r in self._riding_on if r.obj is not obj]
        finally:
            self.reporter.route(pick)
        if not pick.success:
            ex.set_tool("travel", closed=False)
            self._skip(obj, "pick failed on the belt", pick, kind="pick_failed")
            return
        held = holds_its_class(self.bus, obj.class_name)
        ex.set_tool("travel", closed=False)
        place.why_failed = place_failure(self.bus, obj.class_name, held=held, gripped=closed_on)
        place.success = place.why_failed is None
        obj.place_failed = place.why_failed
        place.note = place_note(held=held, success=place.success)
        obj.sorted = place.success
        self.reporter.route(ex.finish(place, t1))

    # ----------------------------------------------------------------- run

    def _idle_limit_s(self) -> float:
        """How long the belt may bring nothing before the run ends [s]."""
        a = self.belt.config.arrivals
        return max(a.first_s, a.max_gap_s) + 1.0

    def run(self) -> SortReport:
        """Sort what the belt brings until it has brought nothing for a while, then go home.

        The belt is done when nothing has been on it for longer than the longest gap
        between arrivals (``belt.arrivals``), with no object still tracked.

        Raises:
            SortAborted: camera or servo failure, or Ctrl-C; the reason is logged first.
        """
        try:
            # before each motion the loop starts: a Ctrl-C C code swallowed stops it too
            interrupts.raise_swallowed_ctrl_c()
            if not self.bus.is_connected:
                self.bus.connect()
            self.executor.home_pose()
            self._last_seen_s = self.now_s()
            while True:
                states = self._observe()
                chosen = self._choose_track(states)
                if chosen is not None:
                    interrupts.raise_swallowed_ctrl_c()
                    self._recorded_catch(*chosen)
                    self._observe()
                    self._home()
                    continue
                pending = [o for o in self._by_track.values() if not o.sorted and o.skipped is None]
                idle_s = self.now_s() - self._last_seen_s
                if not pending and idle_s > self._idle_limit_s():
                    break
                if idle_s > self._idle_limit_s() + self.tracker.tracking.coast_s:
                    for o in pending:  # tracked, never seen again, never lost: say so
                        self._skip(o, "missed on the belt: no longer seen", kind="missed_belt")
                    break
                self._wait()
            self._home()
            if self.recorder is not None:
                self.recorder.end_run()
        except MearmError as exc:
            self._stop_on_fault(exc)
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM/SIGHUP taken as one
            interrupts.answered()
            self._abort(f"interrupted ({interrupts.named(exc)})", park=True, interrupted=True)
        self.reporter.summary(ok=True, outcome=self.outcome(), motion=self.executor.motion)
        return self.report

    def outcome(self, stopped: str | None = None) -> Outcome:
        """The still table's outcome, with the belt's objects the camera never saw.

        In simulation the belt's arrivals are known (:func:`~mearm.sim.belt.belt_arrivals`):
        each that has landed on the belt by now and was never seen (a belt out of the
        camera's view, an object gone before it was seen whole) is left ``unseen``, with
        the table's own (``placed``). A run that stopped (``stopped``: Ctrl-C, a fault)
        leaves them to that instead: the belt brings objects all the time, one has
        usually just landed, and the run ended before the camera could see it (still one
        of the M objects, so the last line names the stop). A real rig knows only what its
        camera saw.
        """
        out = super().outcome(stopped)
        if self.in_bins is None:
            return out
        expected = dict(self.placed)
        now = self.now_s()
        for a in belt_arrivals(self.config):
            if a.t_s <= now:
                expected[a.color] = expected.get(a.color, 0) + 1
        out.unseen = {}
        out.left.pop("unseen", None)
        for name, n in expected.items():
            surplus = out.seen.get(name, 0) - n
            if surplus > 0:
                self._count_once(out, name, surplus)
            missing = n - out.seen.get(name, 0)
            if missing > 0:
                out.unseen[name] = missing
                why = stopped or "unseen"
                out.left[why] = out.left.get(why, 0) + missing
        return out

    def _count_once(self, out: Outcome, name: str, surplus: int) -> None:
        """Count once the objects of class ``name`` the camera took for ``surplus`` more.

        In simulation the world knows how many the belt and the table held; more tracks
        of a class than that are objects seen again after their track was lost (a belt
        faster than the arm follows: at 15 cm/s, "sorted 1 of 23" of 20 brought). The
        surplus comes off the class's objects left as lost on the belt first (a lost
        track is one the object outlived), then off its others left, in the order seen.
        """
        out.seen[name] -= surplus
        left = [o.skip_kind for o in self._objects
                if o.class_name == name and not o.sorted and o.skip_kind is not None]  # fmt: skip
        left.sort(key=lambda kind: kind != "missed_belt")  # (stable)
        # one entry per object left: the class's (lost first), then any others (a stop's)
        units = left + [k for k, n in out.left.items() for _ in range(n)]
        for kind in units:
            if not surplus:
                break
            if out.left.get(kind, 0) > 0:
                out.left[kind] -= 1
                surplus -= 1
        for kind in [k for k, n in out.left.items() if n <= 0]:
            del out.left[kind]


def _while_closing(step: Route) -> str:
    """A follow step's failure, said to be the follow's: ``kind: following it …, why``.

    A reason that opens with its kind (``collision: …``) keeps it first, as the follow's
    own collision refusal reads; any other is put after the follow.
    """
    why = step.failure or "no plan"
    kind, sep, rest = why.partition(": ")
    if sep and kind == step.failure_kind:
        return f"{kind}: following it while the jaws close, {rest}"
    return f"following it while the jaws close: {why}"


__all__ = ["ConveyorSorter", "GripAim", "KeepsTime"]
