"""One object from the table to its bin: plan the pick and the place in full, then move.

The pick is planned with the route above the object (``task.approach_height_cm``) before
either moves; with the object held, the lift and then the place route are planned in
full, and nothing unplanned is sent (an object whose place cannot be planned is put back
and skipped). Whether the grip held is read from the camera once the arm is over the
bin; whether the place counts, from the bus's report of the release.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Protocol

import numpy as np

from mearm.config.classes import ColorClass
from mearm.config.shape_catalogue import SHAPES
from mearm.hardware.bus import (
    ReportsHold,
    ReportsRelease,
    ReportsWhere,
    ServoBus,
    SettlesObjects,
)
from mearm.ik import IKTarget
from mearm.kinematics import ArmModel
from mearm.kinematics.bodies import M_PER_CM, object_of
from mearm.kinematics.collision import TOUCH_M, CollisionModel
from mearm.kinematics.errors import JointLimitError, TargetError
from mearm.task.claw_loop import TABLE_ROOM_CM, ClawEye, shifted
from mearm.task.execute import Executor
from mearm.task.looking_picks import (
    aim_aside,
    aim_by_eye,
    aim_low,
    aim_over,
    beside_wall,
    lower_by_looks,
)
from mearm.task.plan import Planner
from mearm.task.route import Route
from mearm.task.table_tracking import TableTracking, TrackedObject

#: Why a pick failed: the camera, looking from over the bin, still sees the object.
PICK_MISSED = "the camera still sees it where the jaws closed: they did not take it"
#: Why a pick failed: the camera sees it on the table near where it lay (``_pushed_to``).
PICK_PUSHED = (
    "the camera sees it {moved_cm:.1f} cm from where it lay: the closing jaws pushed it aside"
)
#: Why a pick failed: the camera over the bin no longer sees it where it lay, but the
#: simulator's jaws had closed on nothing (:func:`took_nothing`): they pushed it, or it
#: lies where the camera does not see it.
PICK_EMPTY = (
    "the jaws closed on nothing: the camera no longer sees it where it lay, but they did not "
    "take it"
)
#: The turns of the jaws' opening line tried over a round object whose way down is
#: refused [deg]: a pad beside a wall or a neighbour swings off it (90°: along it).
ROUND_TURNS_DEG = (30.0, -30.0, 60.0, -60.0, 90.0)
#: A pick that a bin's wall refuses is tried again moved off the wall by this share of the
#: open jaws' room beside the object (``open_cm`` / 2 less the object's footprint radius):
#: the rest is left for the camera's and the arm's errors, so the jaws still come down
#: around it, and closing bring it to their middle (:meth:`PickAndPlace._off_the_wall`) ...
WALL_SHIFT_SHARE = 0.5
#: ... or, where that does not plan, by as much less in steps of this [cm].
WALL_STEP_CM = 0.1


class EpisodeRecorder(Protocol):
    """Records the run as episodes (:class:`mearm.dataset.DatasetRecorder`).

    The sorter opens an episode as a pick-and-place of an object of ``class_name``
    starts, ends it when the pick-and-place ends, ends the run after the last one, and
    abandons the episode a fault or Ctrl-C cuts short.
    """

    def begin(self, class_name: str) -> None: ...  # noqa: D102
    def end(self) -> None: ...  # noqa: D102
    def end_run(self) -> None: ...  # noqa: D102
    def abandon(self) -> None: ...  # noqa: D102


class PickAndPlace(TableTracking):
    """The sorter's pick-and-place of one object (a part of the sorter).

    Attributes:
        bus: The servo bus.
        model: The arm's kinematic model.
        collision: What the routes are checked against.
        planner: Plans each route in full.
        executor: Sends planned routes to the bus.
        eye: The camera watching the claw (picks that look), or ``None``.
        recorder: Records each pick-and-place as an episode, or ``None``.
    """

    bus: ServoBus
    model: ArmModel
    collision: CollisionModel
    planner: Planner
    executor: Executor
    eye: ClawEye | None
    recorder: EpisodeRecorder | None
    #: How far below the planned grip the last pick's jaws closed [cm], the marker's
    #: height errors its looks saw [cm] and how far down the object's side the open jaws
    #: reached in its plan [cm] (:class:`~mearm.task.claw_loop.GripDrops`).
    _drop_cm: float = 0.0
    _seen_z_cm: Sequence[float] = ()
    _overlap_cm: float = 0.0
    #: The objects the jaws closed on at the last grip, where the bus knows (the twin's ids).
    _gripped: frozenset[str] = frozenset()
    #: The TCP's way over the bin before the place, in the table plane [cm], (k, 2)
    #: (:meth:`_plan_carry`; none where the place went directly).
    _carried_over_cm: np.ndarray = np.zeros((0, 2))

    def _recorded_pick(self, obj: TrackedObject) -> None:
        """:meth:`_pick_and_place` as an episode of the recording, if there is one."""
        recorder = self.recorder
        if recorder is None:
            self._pick_and_place(obj)
            return
        recorder.begin(obj.class_name)
        try:
            self._pick_and_place(obj)
        except BaseException:
            recorder.abandon()
            raise
        recorder.end()

    def _approach(self, obj: TrackedObject, pick: Route) -> Route | None:
        """The route to above the object (``task.approach_height_cm``), planned.

        ``None`` when the config asks for the paper's direct routes.
        """
        h = self.config.task.approach_height_cm
        if h is None:
            return None
        q = self.executor.q_now()
        z = float(pick.target.position_cm[2])
        # Where it is higher, the travel height: the jaws, and the object they lift back
        # to here, pass every bin wall and object top by the clearance and a margin for
        # the arm's lag in the transits to and from here (Planner.travel_heights_cm);
        # where that is out of reach, lower down to the approach height.
        heights = [max(h, t - z) for t in self.planner.travel_heights_cm(q)] + [h]
        above = None
        for height in dict.fromkeys(heights):
            target = self.planner.above_target(pick.target, height)
            above = Route(obj.id, obj.class_name, "approach", pick.attempt, target)
            if self.planner.plan(above, q).planned:
                break
        return above

    def _pick_routes(
        self, obj: TrackedObject, goal: IKTarget, aim: np.ndarray, below_cm: float = 0.0
    ) -> tuple[Route | None, Route]:
        """The route above the object, planned, and the pick to ``goal`` shifted by ``aim``.

        A pick lowered by a miss (``aim``'s z < 0, :class:`~mearm.task.claw_loop.GripDrops`)
        goes no lower than the collision check lets the jaws come to the table at the
        planned pose, the table checked ``below_cm`` lower where a miss measured the claw
        that much higher than commanded (:attr:`GripDrops.below_cm`), nor below the arm's
        target box (``arm.target_box.z_cm.min``, where the solver refuses a target): where
        the drop is more, the pick rises to the higher bound; where the pick lowered even
        that far cannot be planned, it goes at the planned height.
        """
        pick = Route(obj.id, obj.class_name, "pick", obj.failed_picks + 1, shifted(goal, aim))
        above = self._approach(obj, pick)  # planned in full with the pick, before either
        if aim[2] >= 0 or above is None or above.plan is None or not above.planned:
            return above, pick
        # the tool hangs the same below the TCP over the object as at the pick (the
        # way down is straight): the room under its lowest point at the planned pick
        tcp_z = float(self.model.fk_cm(above.plan.q)[2])
        goal_z = float(goal.position_cm[2])
        lowest = self.collision.tool_lowest_cm(above.plan.q)[0] - (tcp_z - goal_z)
        floor_z = max(
            goal_z - max(0.0, lowest + below_cm - TABLE_ROOM_CM),
            min(self.config.arm.target_box.z_cm.min, goal_z),
        )
        if goal_z + aim[2] < floor_z:  # lower than the bounds allow: at the higher one
            x, y, _ = (float(v) for v in pick.target.position_cm)
            risen = dataclasses.replace(goal, position_cm=(x, y, floor_z))
            pick = Route(obj.id, obj.class_name, "pick", obj.failed_picks + 1, risen)
            above = self._approach(obj, pick)
        if (
            above is not None
            and above.planned
            and above.plan is not None
            and self.planner.plan(pick, above.plan.q, target=obj.id).planned
        ):
            return above, pick
        # the lowered pick not planned: as planned
        level = shifted(goal, np.array([aim[0], aim[1], 0.0]))
        pick = Route(obj.id, obj.class_name, "pick", obj.failed_picks + 1, level)
        return self._approach(obj, pick), pick

    def _world(
        self,
        held: TrackedObject | None = None,
        opening_cm: float | None = None,
        table_below_cm: float = 0.0,
    ) -> None:
        """What the collision checks see: the objects on the table, the jaws, the held one.

        ``table_below_cm``: how much lower the table is checked (the claw measured that
        much higher than commanded: :attr:`~mearm.task.claw_loop.GripDrops.below_cm`).
        """
        g = self.config.arm.tool.gripper
        on_table = [
            (o.id, o.class_name, o.x_cm, o.y_cm)
            for o in self._objects
            if not o.sorted and o is not held
        ]
        pair = None if held is None else (held.id, held.class_name)
        self.collision.set_world(
            on_table, opening_cm=opening_cm or g.open_cm, held=pair, table_below_cm=table_below_cm
        )

    def _lift_and_plan_place(
        self, obj: TrackedObject, cls: ColorClass, above: Route | None, pick: Route
    ) -> tuple[Route, float] | None:
        """With ``obj`` held: lift it, then plan the place route in full.

        The lift (when the pick came down from ``above``) comes before anything else
        moves. Where the pick ended within the clearance of something (the object held
        beside a bin's wall), a route out may leave as long as it comes no closer
        (:mod:`mearm.kinematics.collision`). Returns the place route and when its planning
        began (``time.perf_counter``), or ``None`` when no place can be planned: nothing
        unplanned is sent, so the object is put back where it was and skipped, for the
        bin when the bin is out of reach, for the pick when no route leaves where it ended
        without coming closer to what it ended beside. The place is planned from where
        the lift will end before the lift, so such an object is let go where the jaws
        closed; the pick is then logged unconfirmed (its grip never checked), not failed.
        """
        ex = self.executor
        up = None
        if above is not None:
            # straight up from where the jaws closed, to the height it came down from (the
            # point above the target is off the pose by as much as the solver left: that
            # way may bring an object held beside a wall closer to it)
            z = float(above.target.position_cm[2])
            straight_up = self.planner.up_from(ex.q_now(), z, above.target.approach)
            up = Route(obj.id, obj.class_name, "lift", 1, straight_up)
            self.planner.plan(up, ex.q_now())
        t1 = time.perf_counter()
        # planned from where the lift ends before the lift: an object whose place cannot
        # be planned is let go where the jaws closed, not dropped from the lift's height
        lifted = up.plan.q if up is not None and up.planned and up.plan is not None else None
        over, place = self._plan_carry(obj, cls, ex.q_now() if lifted is None else lifted)
        if place.planned and up is not None and lifted is not None:
            ex.stream(up, "travel", closed=True)
            if not np.array_equal(ex.q_now(), lifted):  # (the bus rounds: plan from there)
                t1 = time.perf_counter()
                over, place = self._plan_carry(obj, cls, ex.q_now())
        self._carried_over_cm = np.zeros((0, 2))
        if place.planned and over is not None and over.plan is not None:
            try:
                ex.stream(over, "travel", closed=True)
            except BaseException:  # a fault on the way: the pick is logged unconfirmed
                pick.confirmed = False
                self.reporter.route(pick)
                raise
            self._carried_over_cm = over.plan.ee_path_cm[:, :2]
            if not np.array_equal(ex.q_now(), over.plan.q):  # (the bus rounds)
                place = Route(obj.id, obj.class_name, "place", 1, place.target)
                self.planner.plan_place(place, ex.q_now())
        if not place.planned:
            pick.confirmed = False  # its grip is not checked: the object is let go
            self.reporter.route(pick)
            beside = self.collision.gap(ex.q_now())
            if place.failure_kind == "collision" and beside[0] < TOUCH_M:
                why = stuck_reason(beside, self.config.task.clearance_cm, place.failure)
                self._skip(obj, why, pick, kind="collision")
            else:
                why = f"bin unreachable: {place.failure}"
                self._skip(obj, why, place, kind="bin_unreachable")
            ex.set_tool("grip", closed=True)
            ex.set_tool("grip", closed=False)
            return None
        return place, t1

    def _plan_carry(
        self, obj: TrackedObject, cls: ColorClass, q: np.ndarray
    ) -> tuple[Route | None, Route]:
        """The carry from pose ``q`` to ``cls``'s bin: over it, then the place; planned.

        A place releases as low as the jaws clear the bin's walls by the clearance
        (:meth:`Planner.plan_place`). Planned from where the lift ends as one transit, it
        comes down into the bin as it swings over: streamed at the servos' speed limits a
        transit strays from its planned path, by centimetres where the servos lag
        (:data:`~mearm.task.plan.TRAVEL_MARGIN_CM`), and a pad came down on the blue
        bin's wall and the elbow stalled (the paper's arm with a kit of servos,
        ``sim_mujoco_kits_paper --random 21 --seed 48633``). Where picks go via a point
        above (``task.approach_height_cm``), the carry goes as a pick comes: a transit
        to over the bin at the travel height an approach keeps over every wall
        (:meth:`Planner.travel_heights_cm`, else the safe height), then straight down to
        the release. Returns the route over the bin (``None``: the place goes directly,
        as where picks go directly, or where no way over the bin is planned with its
        place) and the place route, planned or with its failure.
        """
        target = self.planner.place_target(cls)
        if self.config.task.approach_height_cm is not None:
            z = float(target.position_cm[2])
            for height in self.planner.travel_heights_cm(q):
                if height <= z:
                    break
                above = self.planner.above_target(target, height - z)
                over = Route(obj.id, obj.class_name, "lift", 1, above)
                if not self.planner.plan(over, q).planned or over.plan is None:
                    continue
                place = Route(obj.id, obj.class_name, "place", 1, target)
                if self.planner.plan_place(place, over.plan.q).planned:
                    return over, place
        place = Route(obj.id, obj.class_name, "place", 1, target)
        self.planner.plan_place(place, q)
        return None, place

    def _pick_and_place(self, obj: TrackedObject) -> None:
        """Pick ``obj`` and place it in its bin: plan in full, go down, grip, carry, release."""
        self._active, self._active_from_cm = obj, (obj.x_cm, obj.y_cm)
        cls = self.config.task.class_named(obj.class_name)
        ex = self.executor
        t0 = time.perf_counter()
        self._seen_z_cm = ()
        xy = np.array([obj.x_cm, obj.y_cm])
        goal = self.planner.pick_target(cls, obj.x_cm, obj.y_cm)
        # picks that look start from the aim the picks nearby needed (claw_loop)
        aim, below = np.zeros(3), 0.0
        if self.eye is not None:
            aim[:2] = self.eye.corrections.guess(xy)
            aim[2] = -self.eye.drops.drop_cm(obj.id, xy)  # the height misses taught
            below = self.eye.drops.below_cm.get(obj.id, 0.0)
        # (the table as checked stays lowered for the lift: the jaws leave from where
        # they were planned to close)
        self._world(table_below_cm=below)
        above, pick = self._pick_routes(obj, goal, aim, below)
        aim[2] = float(pick.target.position_cm[2] - goal.position_cm[2])
        failed = self._plan_way_down(obj, above, pick, aim)
        if not failed.planned:
            moved = self._off_the_wall(obj, cls, failed, aim, below)
            if moved is not None:
                above, pick = moved
                failed = pick
        if not self._planned_or_set_aside(obj, failed):
            return
        low = None  # beside a bin's wall, where the way down stops to look again
        if above is not None:
            ex.stream(above, "travel", closed=False)
            if self.eye is not None:
                pick, aim, seen = aim_over(self.eye, self.planner, ex, obj, pick, aim)
                wall = beside_wall(self.planner, self.collision, pick)
                if wall is not None:  # (the low point clears the walls whatever the error)
                    low, pick, aim, seen_low = aim_low(self.eye, self.planner, ex, obj, pick, aim)
                    if low is not None and not (seen or seen_low):
                        low, pick, aim, seen_low = aim_aside(
                            self.eye, self.planner, ex, obj, low, pick, aim
                        )
                    if not (seen or seen_low):  # its error unknown: it may land on the wall
                        self._skip(obj, blind_reason(wall), pick, kind="collision")
                        return
        ex.stream(pick, "travel", closed=False, color=hex_rgb(cls.draw_rgb))
        if self.eye is not None:  # (corrections go back up to where it last looked)
            pick, aim, self._seen_z_cm = aim_by_eye(
                self.eye, self.planner, ex, obj, low or above, pick, aim
            )
            pick, aim = lower_by_looks(
                self.planner, self.collision, ex, obj, low or above, pick, aim, self._seen_z_cm
            )
            self.eye.corrections.add(xy, aim[:2])
            self.eye.drops.looked(xy, self._seen_z_cm)
            self._drop_cm = -float(aim[2])
            if pick.plan is not None:  # how far down the object's side the open jaws reach
                low_cm = self.collision.tool_lowest_cm(pick.plan.q)[0]
                self._overlap_cm = cls.height_cm - low_cm
            pick.target = goal  # the pick is judged, and logged, against the object
        ex.finish(pick, t0)  # where the TCP arrived (Table 8's)
        ex.set_tool("grip", closed=False)
        pick.grip_ee_cm = ex.ee_now_cm()  # settled: where the jaws close
        ex.set_tool("grip", closed=True)
        self._gripped = objects_gripped(self.bus)
        ex.show_held((obj.id, obj.class_name))
        ex.set_tool("travel", closed=True)
        self._world(held=obj, opening_cm=cls.diameter_cm, table_below_cm=below)
        planned = self._lift_and_plan_place(obj, cls, above, pick)
        if planned is not None:
            self._place(obj, cls, above, pick, *planned)

    def _plan_way_down(
        self, obj: TrackedObject, above: Route | None, pick: Route, aim: np.ndarray
    ) -> Route:
        """Plan the pick down from ``above`` (or from where the arm is), the jaws turned.

        A pick aimed off the object by ``aim`` [cm], (3,) (the error the picks nearby
        saw: the looks then correct the claw onto the object) is checked where the claw
        will go, too (:meth:`_claw_way_down`). Returns the route that decides: planned
        when both are, else the one refused (nothing else is changed).
        """
        if above is not None and obj.yaw_deg is not None:  # jaws across a cube's faces
            # (the yaw is a square outline's, whatever shape the class names)
            self.planner.turn_jaws(above, obj.yaw_deg, SHAPES["cube"].symmetry_deg)
        if above is None:
            self.planner.plan(pick, self.executor.q_now(), target=obj.id)
        elif above.planned and above.plan is not None:
            self.planner.plan(pick, above.plan.q, target=obj.id)
        failed = pick if above is None or above.planned else above
        if failed.planned and above is not None:
            blocked = self._claw_way_down(obj, above, pick, aim)
            if blocked is not None:
                pick.failure, pick.failure_kind = blocked, "collision"
        if failed.planned:
            blocked = self._lands_on_wall(pick)
            if blocked is not None:
                pick.failure, pick.failure_kind = blocked, "collision"
        if failed is pick and pick.failure_kind == "collision" and above is not None:
            self._turn_round_grip(obj, above, pick, aim)
        return failed

    def _planned_or_set_aside(self, obj: TrackedObject, failed: Route) -> bool:
        """Whether the pick's routes are planned (``failed``: the one that decides).

        Otherwise ``obj`` waits, blocked, when a collision refused it (another object may
        clear its way), or is skipped.
        """
        if failed.planned:
            return True
        if failed.failure_kind == "collision" and obj.blocked is None:
            obj.blocked = failed.failure  # another object may clear its way
            return False
        self._skip(obj, failed.failure or "no plan", failed, kind=failure_kind(failed))
        return False

    def _off_the_wall(
        self, obj: TrackedObject, cls: ColorClass, failed: Route, aim: np.ndarray, below: float
    ) -> tuple[Route | None, Route] | None:
        """The pick's routes moved off the bin's wall that refused them, planned; or ``None``.

        The camera locates an object off where it stands: the twin's overhead camera,
        calibrated on the table, sees a 1 cm object's top face up to 0.35 cm outwards
        beside the bins (parallax), and a pick planned where it is seen may pass a bin's
        wall within the clearance though the object stands clear of it. Open jaws wider
        than the object grip it off their middle too (closing, they bring it there), so
        the pick is tried again moved off the wall by :data:`WALL_SHIFT_SHARE` of the open
        jaws' room beside the object (the rest is left for the camera's and the arm's
        errors), then by :data:`WALL_STEP_CM` less at a time: the farthest first, as the
        twin's arm strays up to 0.44 cm from a pick's pose and a pad planned at the
        clearance came within 0.12 cm of the wall. Each try is planned in full with
        every collision check, so the jaws keep the clearance from the wall wherever
        they go. ``None`` when no bin's wall came within the clearance of the refused
        route's path, or no try plans.
        """
        if failed.failure_kind != "collision" or failed.plan is None:
            return None
        color = self._wall_beside(failed)
        if color is None:
            return None
        bin_cls = self.config.task.class_named(color)
        half = bin_cls.bin_inner_width_cm / 2
        centre = np.asarray(bin_cls.bin_cm[:2], dtype=float)
        xy = np.array([obj.x_cm, obj.y_cm])
        away = xy - np.clip(xy, centre - half, centre + half)  # from the bin's nearest point
        if not np.any(away):  # (over the bin: no way off its walls)
            return None
        away /= np.linalg.norm(away)
        room_cm = self.config.arm.tool.gripper.open_cm / 2 - cls.footprint_radius_cm
        steps = int(WALL_SHIFT_SHARE * room_cm / WALL_STEP_CM + 1e-9)
        for k in range(steps, 0, -1):  # farthest first: the arm's own error eats the gap
            x, y = xy + k * WALL_STEP_CM * away
            goal = self.planner.pick_target(cls, float(x), float(y))
            above, pick = self._pick_routes(obj, goal, aim, below)
            if self._plan_way_down(obj, above, pick, aim).planned:
                return above, pick
        return None

    def _wall_beside(self, failed: Route) -> str | None:
        """The class whose bin's wall refused ``failed`` (a collision), or ``None``.

        The bin the jaws come down beside within the arm's position error at the route's
        end (:meth:`_lands_on_wall`), else the one its path came within the clearance of.
        """
        assert failed.plan is not None
        task = self.config.task
        if task.position_error_cm > 0:
            gap_cm, color, _ = self._nearest_wall(failed.plan.q)
            if gap_cm < task.clearance_cm + task.position_error_cm:
                return color
        near = [(d, c) for q in failed.plan.q_path for c, _, d in self.collision.bins_at(q)]
        gap_cm, color = min(near, default=(np.inf, ""))
        return None if gap_cm >= task.clearance_cm else color

    def _turn_round_grip(
        self, obj: TrackedObject, above: Route, pick: Route, aim: np.ndarray
    ) -> bool:
        """Turn the jaws over a round object whose way down a collision refused.

        A disc is gripped across any diameter, so where a pad would pass a bin's wall or
        a neighbour within the clearance, jaws turned to close along it may clear it (the
        5-DOF arm's wrist roll; an arm without one keeps its jaws). The opening lines
        :data:`ROUND_TURNS_DEG` off the planned one are tried, least turn first: each turn
        is appended to the route above and checked with it, and the way down is planned
        again from there, in full (:meth:`Planner.turn_jaws`, :meth:`_claw_way_down`).
        Returns whether a turn planned; otherwise both routes are as they were.
        """
        cls = self.config.task.class_named(obj.class_name)
        if obj.yaw_deg is not None or cls.object_shape.symmetry_deg != 0.0:
            return False
        if above.plan is None or self.planner.roll_joint(above.plan.q) is None:
            return False
        kept_above = above.plan
        kept_pick = (pick.plan, pick.failure, pick.failure_kind, pick.detour_cm)
        phi = self.planner.opening_deg(above.plan.q)
        for turn in sorted(ROUND_TURNS_DEG, key=abs):
            above.plan = kept_above
            if not self.planner.turn_jaws(above, phi + turn, 180.0, target=obj.id):
                continue
            pick.plan, pick.failure, pick.failure_kind, pick.detour_cm = None, None, None, None
            self.planner.plan(pick, above.plan.q, target=obj.id)
            if (
                pick.planned
                and self._claw_way_down(obj, above, pick, aim) is None
                and self._lands_on_wall(pick) is None
            ):
                return True
        above.plan = kept_above
        pick.plan, pick.failure, pick.failure_kind, pick.detour_cm = kept_pick
        return False

    def _claw_way_down(
        self, obj: TrackedObject, above: Route, pick: Route, aim: np.ndarray
    ) -> str | None:
        """Why the way down where the claw will really go is not clear of the bins, or ``None``.

        The collision check sees the commanded poses; the looks bring the claw onto the
        object, ``aim`` in the table plane off them: a jaw beside a bin's wall comes that
        much nearer to it than checked (simulated: 0.74 cm, onto the wall's top, and the
        shoulder stalled pushing the arm on it). The same way down less the aim's
        table-plane part is solved and must keep the clearance from every bin. (Only the
        bins: a jaw that grazes a neighbouring object nudges it, and the neighbour is
        what the commanded check keeps the clearance from.) Where it cannot be solved,
        the commanded way down stands.
        """
        if above.plan is None or not np.any(aim[:2]):
            return None
        back = np.array([-aim[0], -aim[1], 0.0])
        try:
            over = self.planner.solver.solve(shifted(above.target, back), above.plan.q)
            real = self.planner.solver.solve(shifted(pick.target, back), over.q)
        except (TargetError, JointLimitError):
            return None
        if not (over.converged and real.converged):
            return None
        near = [(d, c, p) for q in real.q_path for c, p, d in self.collision.bins_at(q)]
        gap_cm, color, part = min(near, default=(np.inf, "", ""))
        if gap_cm >= self.config.task.clearance_cm:
            return None
        how = f"within {gap_cm:.2f} cm of" if gap_cm > 0 else f"{-gap_cm:.2f} cm into"
        return (
            f"where the claw goes ({np.hypot(*aim[:2]):.2f} cm off its aim) the {part} comes "
            f"{how} the {color} bin's wall (task.clearance_cm)"
        )

    def _nearest_wall(self, q: np.ndarray) -> tuple[float, str, str]:
        """The gap to the nearest bin's wall at pose ``q`` [cm], its class and the arm's part."""
        near = [(d, c, p) for c, p, d in self.collision.bins_at(q)]
        return min(near, default=(np.inf, "", ""))

    def _lands_on_wall(self, pick: Route) -> str | None:
        """Why the jaws at ``pick``'s end come too near a wall for the arm's error, or ``None``.

        The collision check keeps ``task.clearance_cm`` from the walls at the planned
        pose, but the arm lands off it by as much as ``task.position_error_cm``: where the
        jaws come down beside a bin, they keep both from its wall. (A kit of uncalibrated
        servos lands 0.46–1.05 cm off its picks: a pad planned 0.41 cm from the blue
        bin's wall pressed on it and the shoulder stalled, ``sim_mujoco_kits_paper
        --random 21 --seed 50031``, simulated.) ``None`` too where the config gives no
        position error, or the pick has no plan.
        """
        task = self.config.task
        if task.position_error_cm <= 0 or pick.plan is None:
            return None
        gap_cm, color, part = self._nearest_wall(pick.plan.q)
        need_cm = task.clearance_cm + task.position_error_cm
        if gap_cm >= need_cm:
            return None
        return (
            f"the {part} comes down {gap_cm:.2f} cm from the {color} bin's wall, less than "
            f"task.clearance_cm and task.position_error_cm ({task.clearance_cm:g} + "
            f"{task.position_error_cm:g} cm): an arm that lands that far off presses on it"
        )

    def _place(
        self,
        obj: TrackedObject,
        cls: ColorClass,
        above: Route | None,
        pick: Route,
        place: Route,
        t1: float,
    ) -> None:
        """Carry the held object along the planned ``place`` route, check the grip, release.

        ``t1``: when the place's planning began (``time.perf_counter``). A grip that did
        not hold takes whatever the jaws hold back over the spot and lets it go there;
        one whose object a second look, the jaws opened over the bin, still sees pushed
        aside has let go there already (:meth:`_let_go_and_look`).
        """
        ex = self.executor
        # Whether the grip held is read once the arm is over the bin: there the camera sees
        # the table unobstructed, and an object held over its own spot (in view of a camera
        # above it) is not taken for one left there. (The paper re-reads the table after
        # each object.) A fault on the way leaves the pick in the log, unconfirmed.
        pick.confirmed = False
        held: bool | None = None  # what the jaws held over the bin, once they opened there
        try:
            ex.stream(place, "travel", closed=True, color=hex_rgb(cls.draw_rgb))
            seen = self._look(track_new=False)
            left = self._on_table(obj, seen)
            pushed = None if left else self._pushed_to(obj, seen)
            if pushed is not None:
                held, pushed = self._let_go_and_look(obj, pushed)
            empty = not left and pushed is None and took_nothing(self.bus, self._gripped)
            pick.success = not left and pushed is None and not empty
            pick.why_failed = None if pick.success else PICK_EMPTY if empty else PICK_MISSED
            if pushed is not None:  # followed there: the next attempt goes for it there
                x0, y0 = self._active_from_cm
                moved_cm = float(np.hypot(pushed[0] - x0, pushed[1] - y0))
                pick.why_failed = PICK_PUSHED.format(moved_cm=moved_cm)
            pick.confirmed = True
        finally:
            self.reporter.route(pick)
        if self.eye is not None:  # what the grip's height did (claw_loop.GripDrops)
            xy = np.array(self._active_from_cm)
            if pick.success:
                self.eye.drops.held(obj.id, xy, self._drop_cm, self._seen_z_cm, self._overlap_cm)
            else:
                moved = float(np.hypot(obj.x_cm - xy[0], obj.y_cm - xy[1]))
                drops = self.eye.drops
                drops.missed(obj.id, self._drop_cm, moved, self._seen_z_cm, self._overlap_cm)
        if not pick.success:
            # the jaws hold nothing, or a neighbour: take it back over the spot (not into
            # this bin) and let it go there (unless they opened over the bin to look again)
            if held is None:
                self._out_of_the_bin(closed=True)
                back = above.target if above is not None else self.planner.lift_target(pick.target)
                back_route = Route(obj.id, obj.class_name, "lift", 1, back)
                if self.planner.plan(back_route, ex.q_now()).planned:
                    ex.stream(back_route, "travel", closed=True)
                ex.set_tool("travel", closed=False)
            else:  # the jaws opened over the bin
                self._out_of_the_bin(closed=False)
            self._failed_try(obj, pick, "pick failed {n} times")
            return
        if held is None:
            held = holds_its_class(self.bus, obj.class_name)
            ex.set_tool("travel", closed=False)
        place.why_failed = place_failure(self.bus, obj.class_name, held=held, gripped=self._gripped)
        if not held and self._gripped:  # a grip of nothing keeps the ids an earlier one lost
            obj.lost_ids = self._gripped
        place.success = place.why_failed is None
        obj.place_failed = place.why_failed
        place.note = place_note(held=held, success=place.success)
        obj.sorted = place.success
        if place.success:
            obj.places += 1
        if not place_confirmed(self.bus, success=place.success) and place.plan is not None:
            # unconfirmed: it may have slipped on the way (an object of its class seen new
            # near the way is it, TableTracking._dropped)
            obj.carried_cm = np.vstack(
                [[obj.x_cm, obj.y_cm], self._carried_over_cm, place.plan.ee_path_cm[:, :2]]
            )
        for o in self._objects:  # the table changed: a blocked pick may be clear now
            o.blocked = None
        self.reporter.route(ex.finish(place, t1))
        self._out_of_the_bin(closed=False)
        if not place.success:
            # a grip that let go on the way failed as one that missed does, and counts with
            # them: the look over the bin may not see the spot it left (the MeArm v1's twin,
            # its blue bin 5 cm behind a 0.8 cm blue the jaws kept losing on the lift, took
            # the empty look for a pick and went for it again until max_rounds: 312 picks)
            self._failed_try(obj, pick, "{n} picks failed to bring it to its bin")

    def _out_of_the_bin(self, *, closed: bool) -> None:
        """Rise straight up from over the bin, before any route on from there.

        A place comes down as low as the jaws, held closed or opened to let go, clear the
        bin's walls by the clearance (:meth:`Planner.plan_place`, which checks this way up
        exists); a route on from there planned as one transit (to the next pick, or back
        over the spot of a pick that did not take its object) rises and turns away at
        once. Streamed at the servos' speed limits, a transit strays from its planned
        path (a lagging shoulder leaves the jaws low while the elbow swings them in:
        :data:`~mearm.task.plan.TRAVEL_MARGIN_CM`), and a real servo's calibration error
        leaves them nearer the wall than planned before it starts: the paper's arm with a
        kit of servos pushed a pad onto the blue bin's wall, and the shoulder stalled
        (``sim_mujoco_kits_paper --random 21 --seed 48633``: planned 0.53 cm from the
        wall, measured 0.16 cm at the release). So the jaws rise straight up first (a
        vertical move strays least) to the travel height an approach keeps over every
        wall (:meth:`Planner.travel_heights_cm`), else to the safe height; where neither
        is planned, the route on leaves from here. ``closed``: the jaws are closed (they
        took nothing, and go back over its spot); otherwise they let go here. Only where
        picks go via a point above (``task.approach_height_cm``): the paper's direct
        routes are left as the paper has them.
        """
        if self.config.task.approach_height_cm is None:
            return
        if not closed:
            self._world()  # the jaws open, what they held let go
        ex = self.executor
        q = ex.q_now()
        z = float(self.model.fk_cm(q)[2])
        for height in self.planner.travel_heights_cm(q):
            if height <= z:
                return  # (as high already)
            up = self.planner.way_up(q, safe_cm=height)
            if up.planned:
                ex.stream(up, "travel", closed=closed)
                return

    def _failed_try(self, obj: TrackedObject, pick: Route, why: str) -> None:
        """Count a failed try at ``obj``; past ``task.pick_retries`` retries, leave it.

        It is left as ``pick_failed``, ``why`` saying so with the tries' count (``{n}``).
        """
        obj.failed_picks += 1
        if obj.failed_picks > self.config.task.pick_retries:
            self._skip(obj, why.format(n=obj.failed_picks), pick, kind="pick_failed")

    def _let_go_and_look(
        self, obj: TrackedObject, pushed: tuple[float, float]
    ) -> tuple[bool, tuple[float, float] | None]:
        """Open the jaws over the bin and look again where ``obj`` was seen pushed.

        The detection taken for it pushed (:meth:`_pushed_to`) may be the held object
        itself: a camera places an object in the air where its ray meets the table, past
        the bin's walls when the camera is low or to one side. Let go over the bin, a held
        object falls in and its image goes; one pushed aside is still on the table.
        Returns whether the jaws held an object of its class before they opened
        (:func:`holds_its_class`) and where it lies pushed, where ``obj`` is now followed
        (``None``: it was held, and ``obj`` is left where it was).
        Opening here is no worse than the place it replaces: the jaws open over the bin
        whatever they hold.
        Where the bus knows the jaws held an object of its class (:class:`ReportsHold`)
        and the detection is still there once they opened, it was another object, one
        the arm hid from every look before, and the held one fell into the bin: that
        counts as a place of ``obj`` (:attr:`TrackedObject.places`), which the world's
        count of the bin confirms at the end (``sim_5dof_mujoco --random 18 --seed
        48598``: a red the arm at home hid, 4 cm from the red the jaws took, was taken
        for that one pushed aside; both reds ended in their bin, and the sort said ``17
        of 18 (1 never seen by the camera)`` and exited 1).
        """
        held = holds_its_class(self.bus, obj.class_name)
        self.executor.set_tool("travel", closed=False)
        kept = obj.x_cm, obj.y_cm
        obj.x_cm, obj.y_cm = pushed
        if self._on_table(obj, self._look(track_new=False)):
            if held and isinstance(self.bus, ReportsHold):
                obj.places += 1
            return held, (obj.x_cm, obj.y_cm)
        obj.x_cm, obj.y_cm = kept
        return held, None


def place_failure(
    bus: ServoBus, class_name: str, *, held: bool, gripped: frozenset[str] = frozenset()
) -> str | None:
    """Why a place did not put its object in its class's bin, once the jaws opened.

    ``None``: it did, as far as the bus knows (a real rig's always). ``held``:
    :func:`holds_its_class`, read over the bin before the jaws opened. A simulator that
    reports where a released object went (:class:`ReportsRelease`) says where it landed;
    one that knows its objects (:class:`ReportsWhere`) says where the objects the jaws
    closed on (``gripped``, :func:`objects_gripped`) went when they were lost on the way,
    or that the jaws closed on nothing (the object was not between them: a disc still
    rolling where the camera had seen it, a prism the closing jaws pushed aside). One of
    them of ``class_name`` that fell into its own bin on the way is sorted all the same
    (``None``; the place says so, :data:`LOST_INTO_ITS_BIN`): the world has the object in
    its class's bin. One that fell into another class's bin, or anywhere else, is not.
    Held over the bin, the objects the jaws closed on are looked for in the same way once
    they opened: a held one may miss the bin (a 1 cm disc swinging in the jaws as the arm
    stopped landed beside the blue bin, and the place had said ``ok``).
    Jaws that closed on nothing carried nothing, whatever ``held`` says: the twin counts
    an object of the class still settling in its bin as just let fall there, and one
    placed before had not come to rest when empty jaws arrived over it (``sim_mujoco_lamp
    --random 9 --seed 28050 --set twin.camera.height_cm=60``: a pick pushed its green
    8 cm aside, and the place said ``ok``).
    Where none of them is in its bin yet, they are first let come to rest
    (:func:`in_its_bin_at_rest`): read as it bounced on the bin's floor, one let fall
    there moved too fast to count as held, and the place had said ``FAILED`` of an object
    the sort's end found in its bin.
    """
    why = "over the bin the jaws held nothing of its class: "
    if isinstance(bus, ReportsWhere) and not gripped:
        return why + "they had closed on nothing at the pick"
    if not held:
        if not isinstance(bus, ReportsWhere):
            return why + "it was lost on the way"
        if in_its_bin_at_rest(bus, class_name, gripped):
            return None
        return why + "it was lost on the way and " + where_they_are(bus, gripped)
    if isinstance(bus, ReportsWhere) and gripped:
        if in_its_bin_at_rest(bus, class_name, gripped):
            return None
        return "released, it " + where_they_are(bus, gripped)
    release = bus.last_release if isinstance(bus, ReportsRelease) else None
    if release is None or release.bin == class_name:
        return None
    if release.bin is None:
        return f"released, it landed on the table at ({release.x_cm:.1f}, {release.y_cm:.1f}) cm"
    return f"released, it fell into the {release.bin} bin"


def took_nothing(bus: ServoBus, gripped: frozenset[str]) -> bool:
    """Whether the jaws closed on nothing at the pick, where the bus knows (else ``False``).

    ``gripped``: :func:`objects_gripped` as the jaws closed. The camera over the bin sees
    only that an object is gone from its spot; one the closing jaws pushed where it does
    not see it is gone from it too, and the pick had said ``ok``, its place ``FAILED``
    (they had closed on nothing: ``sim_mujoco_kits_paper --random 21 --seed 49921``,
    blue5). A simulator that knows its objects (:class:`ReportsWhere`) says whether the
    jaws took anything; a real rig's camera is all there is.
    """
    return isinstance(bus, ReportsWhere) and not gripped


def place_confirmed(bus: ServoBus, *, success: bool) -> bool:
    """Whether a simulator confirmed where the place just made put its object.

    One that reports its releases (:class:`ReportsRelease`, the kinematic world) says where
    the object landed; one that knows its objects (:class:`ReportsWhere`, the twin) counts
    a place only when an object its jaws closed on rests in its class's bin
    (:func:`place_failure`), so a place it counted is confirmed. Otherwise (a real rig, or
    a place the twin did not count) the object may have slipped on the way: it stays
    carried (:attr:`~mearm.task.table_tracking.TrackedObject.carried_cm`). A place the twin
    confirmed was taken as carried all the same, and an object of its class first seen
    later, one the arm at home had hidden, was taken for it, dropped on the way: picked
    and placed under the first one's name, the second never named (``sim_5dof_mujoco
    --random 13 --seed 49730``: ``red4`` twice, no ``red5``; 12.8 cm from the first one's
    way, the bins out of the camera's view).
    """
    if isinstance(bus, ReportsRelease) and bus.last_release is not None:
        return True
    return success and isinstance(bus, ReportsWhere)


#: What a place whose object slipped out of the jaws on the way, into its own class's
#: bin, says after ``ok`` (:func:`place_failure`: it is sorted; the jaws came empty).
LOST_INTO_ITS_BIN = "lost on the way, it fell into its own bin: counted sorted"


def place_note(*, held: bool, success: bool) -> str | None:
    """What a place that did its job says after ``ok``, if anything.

    :data:`LOST_INTO_ITS_BIN` when the jaws held nothing of its class over the bin
    (:func:`place_failure` found the object in its bin all the same); else ``None``.
    """
    return LOST_INTO_ITS_BIN if success and not held else None


def in_its_bin_at_rest(bus: ReportsWhere, class_name: str, object_ids: frozenset[str]) -> bool:
    """Whether one of ``object_ids`` of ``class_name`` is in its own bin, once they rest.

    Read at once, and where none is and the bus can run its physics on
    (:class:`SettlesObjects`), again once they have come to rest (or the bus gave up on
    them): a bin holds only an object too slow to rise over its walls, and one just let
    fall is, for a moment, not (``sim_mearm_v1_mujoco --random 4 --seed 32091 --set
    task.classes.red.diameter_cm=1.8``: red1 read at 1 cm up in its bin, still moving,
    its place ``FAILED``, and the sort's end found it there).
    """
    if any(bus.in_own_bin(i) == class_name for i in object_ids):
        return True
    if not isinstance(bus, SettlesObjects):
        return False
    bus.settle_objects(object_ids=object_ids)
    return any(bus.in_own_bin(i) == class_name for i in object_ids)


def where_they_are(bus: ReportsWhere, object_ids: frozenset[str]) -> str:
    """Where the bus has each of ``object_ids`` now, in id order, joined by "and"."""
    return " and ".join(map(bus.where, sorted(object_ids)))


def objects_gripped(bus: ServoBus) -> frozenset[str]:
    """The objects the jaws hold now, where the bus knows (:class:`ReportsWhere`); else none."""
    return bus.held_ids() if isinstance(bus, ReportsWhere) else frozenset()


def holds_its_class(bus: ServoBus, class_name: str) -> bool:
    """Whether the jaws hold an object of ``class_name`` over its bin, where the bus knows.

    A simulator knows what its jaws hold (:class:`ReportsHold`): an object a pick knocked
    away, or one that slipped out on the way, leaves them empty, and the place fails
    rather than print ``ok``. A bus that does not know (a real rig) says ``True``: the
    camera saw the object leave its spot, and the place counts.
    """
    return not isinstance(bus, ReportsHold) or class_name in bus.held_classes()


def blind_reason(wall: str) -> str:
    """Why a pick beside ``wall``'s bin is not made: the camera saw the claw nowhere near it."""
    return (
        f"the way down passes the {wall} bin's wall within the claw's unmeasured error "
        "(the camera saw the claw neither over the object nor just above the walls): not "
        "picked blind"
    )


def failure_kind(route: Route) -> str:
    """The typed reason a route's plan failed (``unreachable`` when it gives none)."""
    kind = getattr(route, "failure_kind", None)
    return str(kind) if kind else "unreachable"


def hex_rgb(rgb: tuple[int, int, int]) -> str:
    """A colour as the view draws it: ``#rrggbb``."""
    return "#{:02x}{:02x}{:02x}".format(*rgb)


def stuck_reason(beside: tuple[float, str, str], clearance_cm: float, failure: str | None) -> str:
    """Why a held object stays where the pick ended, for the skip.

    Args:
        beside: :meth:`CollisionModel.gap` where the pick ended (within the clearance).
        clearance_cm: ``task.clearance_cm``.
        failure: Why the place was refused.
    """
    gap_m, part, obstacle = beside
    name = object_of(obstacle) or obstacle
    if obstacle == "table":  # (the table keeps no clearance: its gap is the height)
        where = f"{part} {gap_m / M_PER_CM:.2f} cm above it"
    else:
        where = f"{part} {gap_m / M_PER_CM + clearance_cm:.2f} cm from it"
    return (
        f"the pick ended beside {name} ({where}, within task.clearance_cm) and no route "
        f"leaves without coming closer: {failure}"
    )
