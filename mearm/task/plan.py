"""Plan: where each route goes and the whole IK solve to it, before anything moves.

A route is sent to the servos only when its plan converged and every pose of it passed
the checks here (:attr:`Route.planned`); otherwise it carries a typed reason
(:attr:`Route.failure_kind`: ``outside_box``, ``unreachable``, ``limit``, ``stalled``,
``singular``, ``collision``; :attr:`Route.failure`: the line for people) and nothing of
it moves.

**Turning the jaws.** An arm with a joint that turns the jaws about a vertical approach
axis without moving the TCP (a wrist roll) turns them, at the end of the route to above
a cube, to close on two of its faces (:meth:`Planner.turn_jaws`); over a disc, whose any
diameter grips it, where the way down passes a wall or a neighbour within the clearance
(``mearm.task.pick_place``). The turn is checked with the rest of the route, and an arm
without such a joint, or a turn past the joint's limits or into something, keeps the jaws
as they are. Otherwise a route keeps the jaws as it starts them, whatever its solve
(:meth:`Planner._jaws_kept`): the random layout checks each pick's jaws unturned.

**Collisions.** With a :class:`~mearm.kinematics.collision.CollisionModel` (the sorter
always gives one) the whole path is checked against the table, the bins and the objects
on it (:meth:`~mearm.kinematics.collision.CollisionModel.first_contact`: nothing is
stepped over). A path that comes within ``task.clearance_cm`` of something is planned
again as a detour: straight up from the start to the safe height (every bin wall and
object top, the clearance and the tool hanging below the TCP), over at that height to
above the target, and down; each leg is solved and the whole is checked again. Where the
arm cannot rise straight up that high (near its base, a joint at its limit), the way over
leaves from the start, rising as it goes. Where no such height works, the way over is
tried once more at the height that clears only what lies under it (the sector the arm
sweeps about its base between the start and the target:
:meth:`~mearm.kinematics.collision.CollisionModel.clear_height_between_cm`). A detour
that is not clear either refuses the route with ``collision``, naming the two bodies and
the pose, what stopped the way over the top and, where it was tried, the way over what
lies under it; nothing of it is sent. A direct solve that stopped short (``limit``,
``stalled``) is tried once more the same way, from over the target.

**A start within the clearance** (a pose that ended off its plan, an object held beside
a bin's wall) may be left by a path that brings nothing it starts within the clearance of
any closer (:mod:`mearm.kinematics.collision`); every other pair keeps the clearance. A
way up from there aims a little away from what it starts beside (:meth:`Planner.up_from`),
so that where the solve leaves the TCP it has not come closer.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from mearm.config import ColorClass, Config
from mearm.hardware.mapping import ServoMap
from mearm.ik import (
    APPROACH_TOLERANCE_DEG,
    IKFailure,
    IKResult,
    IKTarget,
    failure_of_error,
    make_solver,
)
from mearm.ik.batch import solve_batch
from mearm.kinematics import ArmModel
from mearm.kinematics.collision import CollisionModel, Contact
from mearm.kinematics.errors import JointLimitError, TargetError
from mearm.kinematics.urdf import jaw_frame
from mearm.task.route import Route

#: After a missed grip the TCP rises this much before the retry [cm].
RETRY_LIFT_CM = 5.0
#: A detour travels this much above the safe height, and tries these higher still [cm].
DETOUR_MARGIN_CM = 1.0
DETOUR_EXTRA_CM = (0.0, 3.0, 6.0)
#: An approach (and the lift back to it with the object) goes this much above the safe
#: height where it can [cm]: streamed at the servos' speed limits, the physical twin's
#: arm strays from a transit route's planned path by up to 2.7 cm (the paper's arm,
#: random scenes), from a vertical pick or lift by 0.4 cm.
TRAVEL_MARGIN_CM = 3.0
#: A way up from a pose within the clearance aims this many solver tolerances away from
#: what it is beside (:meth:`Planner.up_from`): the solve leaves the TCP up to one off its
#: target, in any direction, and straight up beside a bin's wall that ended closer to it
#: (0.01 cm, the paper's arm, an object held 0.1 cm from the green bin's wall).
AWAY_TOLERANCES = 2.0
#: Failures of a direct solve that a detour is tried for: a solve that stopped short
#: against the limits or stalled from this start may converge from over the target.
REROUTED = ("limit", "stalled")


#: A target is left unplanned when the batch solve misses it by this many times the
#: solver's tolerances (:meth:`Planner.reaches`): unreachable targets miss by centimetres,
#: while at the edge of reach the batch's least squares may stop just outside what PD-PIJ
#: accepts.
REACH_MARGIN = 10.0


class Planner:
    """Targets for picks, places, lifts and home, and the IK plan of each route.

    Args:
        config: The whole configuration (arm, tool, classes, controller).
        model: The arm model.
        collision: The arm's body and the table's contents, checked along every plan
            (the caller keeps its world up to date); ``None``: no collision checks.
    """

    def __init__(self, config: Config, model: ArmModel, collision: CollisionModel | None = None):
        self.config = config
        self.model = model
        # solved inside what the servos reach, so the check before sending never refuses
        # a plan for a servo's pulse range (ArmDescription.within_servos); checked on the
        # arm's own limits and the servos' ranges (_outside_limits)
        bounded = model.arm.within_servos()
        self._solve_model = model if bounded is model.arm else ArmModel(bounded)
        self.solver = make_solver(self._solve_model, config.controller)
        tool = config.arm.tool
        self._approach = tool.pick_approach
        self.collision = collision
        self._servos = ServoMap.from_arm(config.arm)
        self._combination = self._servos.combination
        self._jaw_across = jaw_frame(config.arm)[:, 1]  # the line the jaws open along

    # ----------------------------------------------------------------- targets

    def pick_target(self, cls: ColorClass, x_cm: float, y_cm: float) -> IKTarget:
        """Above an object so the jaws close at its class's grip height."""
        z = cls.grip_z_cm + self.config.arm.tool.tcp_above_grip_cm
        return IKTarget((x_cm, y_cm, z), self._approach)

    def place_target(self, cls: ColorClass) -> IKTarget:
        """The class's bin."""
        return IKTarget(cls.bin_cm, self._approach)

    def lift_target(self, target: IKTarget) -> IKTarget:
        """``target`` raised by :data:`RETRY_LIFT_CM`."""
        x, y, z = (float(v) for v in target.position_cm)
        return IKTarget((x, y, z + RETRY_LIFT_CM), target.approach)

    def above_target(self, target: IKTarget, height_cm: float) -> IKTarget:
        """``target`` raised by ``height_cm``, same approach."""
        x, y, z = (float(v) for v in target.position_cm)
        return IKTarget((x, y, z + height_cm), target.approach)

    def up_from(
        self, q: npt.ArrayLike, z_cm: float, approach: tuple[float, float, float] | None
    ) -> IKTarget:
        """Straight up from where the TCP is at pose ``q``, to height ``z_cm``.

        Where ``q`` is within the clearance of something (a pick that ended beside a bin's
        wall, an object held there), the target moves away from it in the table plane by
        :data:`AWAY_TOLERANCES` times the solver's tolerance: the solve leaves the TCP up
        to that far off its target, and a way straight up may end that much closer to
        what it started beside, which the check refuses
        (:mod:`mearm.kinematics.collision`).
        """
        x, y, _ = (float(v) for v in self.model.fk_cm(q))
        away = None if self.collision is None else self.collision.away_from(q)
        if away is not None:
            off = AWAY_TOLERANCES * math.sqrt(self.config.controller.tolerance_cm2)
            x, y = x + off * float(away[0]), y + off * float(away[1])
        return IKTarget((x, y, z_cm), approach)

    def home_target(self) -> IKTarget:
        """The TCP at the home pose (with its approach axis, for an arm that needs one)."""
        home = self.model.home
        x, y, z = (float(v) for v in self.model.fk_cm(home))
        if self._approach is None:
            return IKTarget((x, y, z))
        ax, ay, az = (float(v) for v in self.model.approach(home))
        return IKTarget((x, y, z), (ax, ay, az))

    def reaches(self, targets: Sequence[IKTarget]) -> np.ndarray:
        """Which of ``targets`` some joints reach, with a margin, (N,) bool: one batch solve.

        ``False``: no joints put the TCP within :data:`REACH_MARGIN` times the solver's
        tolerances of the target (the arm's closed form, else a batch of Gauss–Newton
        solves, :func:`~mearm.ik.batch.solve_batch`), so a plan of it would only fail,
        slowly: its solve runs the multi-start recovery to the end. ``True`` says only
        that a plan is worth trying. Targets with an approach are solved with it, unless
        one of them has none (then by position alone, which refuses fewer).
        """
        if not targets:
            return np.zeros(0, dtype=bool)
        approaches = [t.approach for t in targets]
        approach = None if any(a is None for a in approaches) else np.array(approaches)
        return solve_batch(
            self._solve_model,
            [t.position_cm for t in targets],
            approach,
            tolerance_cm=REACH_MARGIN * math.sqrt(self.config.controller.tolerance_cm2),
            tolerance_deg=REACH_MARGIN * APPROACH_TOLERANCE_DEG,
        ).reached

    # ----------------------------------------------------------------- plans

    def plan(self, route: Route, q_start: npt.ArrayLike, *, target: str | None = None) -> Route:
        """Solve ``route`` from ``q_start`` (full joints, model units); set its plan or failure.

        The whole solve runs first. A refused target or start (outside the box, out of
        reach, a joint limit), a solve that did not converge, or a plan with a pose
        outside the joint limits sets ``failure`` and ``failure_kind``, and the route is
        not :attr:`~Route.planned`: nothing of it may be sent. With a collision model the
        path is checked whole, and detoured or refused (the module docstring).

        Args:
            route: The route; its plan or failure is set.
            q_start: Where it starts.
            target: The object the jaws close on at its end (their pads may touch it).
        """
        result, failure = self._solve(route.target, q_start)
        if result is not None:
            route.plan = result
        if failure is not None:
            if self.collision is not None and failure.kind in REROUTED:
                # the solver stopped short from here; from over the target it may not
                detour = self._detour(route.target, q_start, target)
                if not isinstance(detour, str):
                    route.plan, route.detour_cm = detour
                    return route
            return _fail(route, failure)
        assert result is not None
        if self.collision is None:
            return route
        contact = self.collision.first_contact(result.q_path, target=target)
        if contact is None:
            return route
        detour = self._detour(route.target, q_start, target)
        if not isinstance(detour, str):
            route.plan, route.detour_cm = detour
            return route
        # both named: the straight way's contact, and what stops the way over the top (the
        # bins' walls raise it: a wall the claw cannot clear, a height out of reach)
        chain = self.model.chain
        why = f"collision: {contact.describe(chain.names, chain.scale)}; {detour}"
        return _fail(route, IKFailure("collision", why))

    def plan_place(self, route: Route, q_start: npt.ArrayLike) -> Route:
        """:meth:`plan` a place, and its release: the jaws open clear, and leave, where it ends.

        Where they would open within the clearance of something (a bin whose walls grew
        above the release height with its objects, the jaws opening between them), or
        where, opened, they have no way up out of the bin (:meth:`way_up`, the first leg
        of every way on from a release: its walls grown tall for many objects, the open
        jaws just clear of one at the release swing into it on the way up), the release
        is raised to where they open clear of every wall and object top, and the object
        drops the rest; where that is not planned either, the route is refused with
        ``collision``, naming what stops the jaws. Without a collision model, as
        :meth:`plan`.
        """
        self.plan(route, q_start)
        if self.collision is None or not route.planned:
            return route
        assert route.plan is not None
        open_cm = self.config.arm.tool.gripper.open_cm
        contact = self.collision.opening_contact(route.plan.q, open_cm)
        if contact is None:
            stuck = self._no_way_up(route.plan.q, open_cm)
            if stuck is None:
                return route
            why = f"collision: the jaws opened at the release have no way up: {stuck}"
        else:
            why = f"collision: the jaws open into it at the release: {self._describe(contact)}"
        x, y, z = (float(v) for v in route.target.position_cm)
        high_z = self.collision.open_clear_height_cm(route.plan.q, open_cm) + DETOUR_MARGIN_CM
        if high_z > z:
            own = route.target
            route.target, route.plan, route.detour_cm = (
                IKTarget((x, y, high_z), own.approach), None, None
            )  # fmt: skip
            self.plan(route, q_start)
            if route.planned and route.plan is not None:
                raised = self.collision.opening_contact(route.plan.q, open_cm)
                if raised is None:
                    stuck = self._no_way_up(route.plan.q, open_cm)
                    if stuck is None:
                        return route
                    why += f"; raised to {high_z:.1f} cm, no way up: {stuck}"
                else:
                    why += f"; raised to {high_z:.1f} cm: {self._describe(raised)}"
            else:
                why += f"; raised to {high_z:.1f} cm: {route.failure}"
            route.target, route.failure, route.failure_kind = own, None, None
        return _fail(route, IKFailure("collision", why))

    def way_up(
        self,
        q: npt.ArrayLike,
        from_cm: npt.ArrayLike | None = None,
        *,
        safe_cm: float | None = None,
    ) -> Route:
        """The TCP straight up from pose ``q`` to the safe height, planned and checked.

        ``from_cm``: where the TCP is [cm] (the simulated arm's truth; default: the FK of
        ``q``); ``safe_cm``: the height to rise to [cm] (default: :meth:`safe_height_cm`).
        The way home's first detour (:func:`~mearm.task.homing.go_home`), and
        from a release, in the world the jaws
        left there (:meth:`plan_place`). Not planned: its failure says why.
        """
        tcp = self.model.fk_cm(q) if from_cm is None else np.asarray(from_cm, dtype=float)
        x, y, z = (float(v) for v in tcp)
        safe = max(z, self.safe_height_cm(q) if safe_cm is None else safe_cm)
        return self.plan(Route("", "", "home", 1, IKTarget((x, y, safe))), q)

    def _no_way_up(self, q: np.ndarray, open_cm: float) -> str | None:
        """Why the jaws have no :meth:`way_up` from pose ``q``, opened there, or ``None``.

        Opened to ``open_cm``, what they held let go (a release); ``None``: they have one.
        """
        assert self.collision is not None
        with self.collision.released(open_cm):
            up = self.way_up(q)
            if up.planned:
                return None
            # up to where it clears what lies under it there, the least a detour on from
            # here rises to (:meth:`_detour`, over what lies under its way); then over
            # only what lies within the arm's reach there: a bin's walls farther out on
            # the same azimuth do not stand under a way straight up
            tried = float(up.target.position_cm[2])
            tcp = self.model.fk_cm(q)
            for near in (False, True):
                low = self.collision.clear_height_between_cm(q, tcp, within_reach=near)
                if low + DETOUR_MARGIN_CM < tried:
                    if self.way_up(q, safe_cm=low + DETOUR_MARGIN_CM).planned:
                        return None
                    tried = low + DETOUR_MARGIN_CM
        return up.failure

    def _solve(
        self, target: IKTarget, q_start: npt.ArrayLike
    ) -> tuple[IKResult | None, IKFailure | None]:
        """One solve and its checks: the result (if any) and why it cannot be sent.

        A converged solve whose updates swing a servo over a combination of joints past
        its pulse range on the way, though its start and end are within it, becomes a
        straight joint-space move to the same solution (:func:`_joint_move`): every
        servo's value is linear in the joints, so along the line it stays between its
        values at the two ends.
        """
        try:
            result = self._jaws_kept(self.solver.solve(target, q_start))
        except (TargetError, JointLimitError) as exc:
            return None, failure_of_error(exc)
        if not result.converged:
            stopped = result.failure or IKFailure("stalled", f"the solver {result.status}")
            return result, IKFailure(stopped.kind, f"no plan: {stopped.message}")
        failure = self._outside_limits(result.q_path)
        if failure is not None and self._combination is not None:
            if self._outside_limits(result.q_path[[0, -1]]) is None:
                moved = _joint_move(self.model, result, np.asarray(target.position_cm, float))
                return moved, self._outside_limits(moved.q_path)
        return result, failure

    def _jaws_kept(self, result: IKResult) -> IKResult:
        """``result`` with the jaws' joint (:meth:`roll_joint`) held where it starts.

        No target sets the line the jaws open along, and the solver's own updates leave
        that joint where it is; a multi-start's seed, drawn over the whole joint box, did
        not, and the turn stayed for every route after it. The 5-DOF arm's place of a
        red picked 27 cm out, over the top with a multi-start, turned its jaws by 50.7°,
        and two blues 3.55 cm apart, each clear of the other with the jaws as the random
        layout checks them (as planned from home), were then left ``no route clear of
        collisions``: each pick's way over the top came down with a pad within the
        clearance of the other (``sim_5dof --random 26 --seed 42011``, 2026-12-07,
        simulated). The joint moves neither the TCP nor the approach axis, so the path
        keeps every TCP point, and its checks are made on it as it is now (a turn the
        plan needs is :meth:`turn_jaws`', appended to it).
        """
        k = self._jaws_joint(result.q_path[0])
        if k is None:
            return result
        chain = self.model.chain
        actuated = chain.actuated_of(result.q_path)
        if np.all(actuated[:, k] == actuated[0, k]):
            return result
        actuated[:, k] = actuated[0, k]
        q_path = np.array([chain.full(a) for a in actuated])
        (p1, R1), (p2, R2) = self.model.tcp_pose(result.q), self.model.tcp_pose(q_path[-1])
        axis = self.model.approach_axis
        if np.linalg.norm(p1 - p2) > 1e-9 or np.linalg.norm(R1 @ axis - R2 @ axis) > 1e-9:
            return result  # (a joint that moves them elsewhere in its range: as solved)
        return dataclasses.replace(result, q=q_path[-1], q_path=q_path)

    def turn_jaws(
        self, route: Route, yaw_deg: float, symmetry_deg: float, *, target: str | None = None
    ) -> bool:
        """Turn the jaws, where ``route`` ends, to close across an object's faces.

        The object's faces are perpendicular to ``yaw_deg`` + k·``symmetry_deg`` in the
        table plane (a cube's: its yaw and every 90°). The jaws' joint (:meth:`roll_joint`)
        is turned in place, in steps of at most 2°, by the least turn within its limits
        that opens the jaws along one of those directions; the turn is appended to the
        route's plan and checked with it (limits, pulse ranges, collisions).

        Returns:
            Whether the plan now ends with the jaws so turned; ``False`` (the plan
            unchanged) for an unplanned route, an arm without such a joint, or a turn
            that is refused.
        """
        if not 0.0 < symmetry_deg <= 360.0:
            raise ValueError(f"symmetry_deg must be in (0, 360], got {symmetry_deg}")
        plan = route.plan
        if not route.planned or plan is None:
            return False
        found = self.roll_joint(plan.q)
        if found is None:
            return False
        k, rate = found
        chain = self.model.chain
        a_end = chain.actuated_of(plan.q)
        phi = self.opening_deg(plan.q)
        lo, hi = chain.actuated_lower[k], chain.actuated_upper[k]
        turns = []
        for i in range(max(1, round(360.0 / symmetry_deg))):
            delta = (yaw_deg + i * symmetry_deg - phi + 180.0) % 360.0 - 180.0
            dq = np.deg2rad(delta) / rate
            if lo <= a_end[k] + dq <= hi:
                turns.append(dq)
        if not turns:
            return False
        dq = min(turns, key=abs)
        steps = max(1, int(np.ceil(abs(dq) / JOINT_MOVE_STEP_RAD)))
        rows = []
        for t in np.linspace(0.0, 1.0, steps + 1)[1:]:
            a = a_end.copy()
            a[k] += dq * t
            rows.append(chain.full(a))
        q_path = np.vstack([plan.q_path, rows])
        if self._outside_limits(q_path) is not None:
            return False
        if self.collision is not None and self.collision.first_contact(q_path, target=target):
            return False
        ee = np.vstack([plan.ee_path_cm, [self.model.fk_cm(q) for q in rows]])
        route.plan = dataclasses.replace(
            plan,
            q=q_path[-1],
            q_path=q_path,
            ee_path_cm=ee,
            error_path_cm=np.linalg.norm(ee - plan.target_cm, axis=1),
            iterations=plan.iterations + steps,
        )
        return True

    def roll_joint(self, q: npt.ArrayLike) -> tuple[int, float] | None:
        """The actuated joint that turns the jaws about a vertical approach axis, at ``q``.

        One whose turn moves neither the TCP nor the approach axis but the line the jaws
        open along, checked by a small turn at ``q``; with the approach axis within 8° of
        vertical. Returns its index among the actuated joints and the turn of the opening
        line per unit of the joint [-] (±1), or ``None``.
        """
        q0 = np.asarray(q, dtype=float)
        _, R0 = self.model.tcp_pose(q0)
        if abs(float((R0 @ self.model.approach_axis)[2])) < math.cos(math.radians(8.0)):
            return None
        k = self._jaws_joint(q0)
        if k is None:
            return None
        eps = 1e-4
        a = self.model.chain.actuated_of(q0)
        a[k] += eps
        q1 = self.model.chain.full(a)
        dphi = (self.opening_deg(q1) - self.opening_deg(q0) + 180.0) % 360.0 - 180.0
        turn = dphi / np.rad2deg(eps)
        return (k, float(np.sign(turn))) if abs(abs(turn) - 1.0) < 1e-3 else None

    def _jaws_joint(self, q0: np.ndarray) -> int | None:
        """The actuated joint that turns the jaws about the approach axis, at ``q0``.

        Its index: one whose small turn moves neither the TCP nor the approach axis, but
        the jaws (the wrist's roll), wherever the approach axis points; or ``None``.
        """
        chain = self.model.chain
        p0, R0 = self.model.tcp_pose(q0)
        a0 = R0 @ self.model.approach_axis
        eps = 1e-4
        base = chain.actuated_of(q0)
        for k in range(chain.m):
            if chain.prismatic[chain.actuated_index[k]]:
                continue
            a = base.copy()
            a[k] += eps
            p1, R1 = self.model.tcp_pose(chain.full(a))
            moved = (
                np.linalg.norm(p1 - p0) > 1e-6
                or np.linalg.norm(R1 @ self.model.approach_axis - a0) > 1e-6
            )
            if not moved and np.linalg.norm((R1 - R0) @ self._jaw_across) > 1e-6:
                return k
        return None

    def opening_deg(self, q: npt.ArrayLike) -> float:
        """The direction the jaws open along, in the table plane, at ``q`` [deg]."""
        _, R = self.model.tcp_pose(q)
        o = R @ self._jaw_across
        return math.degrees(math.atan2(float(o[1]), float(o[0])))

    def _describe(self, contact: Contact) -> str:
        chain = self.model.chain
        return contact.describe(chain.names, chain.scale) + " (task.clearance_cm)"

    def safe_height_cm(self, q: npt.ArrayLike) -> float:
        """The TCP height a detour travels at, for the tool as it hangs at pose ``q`` [cm].

        Every bin wall and object top cleared by the clearance and
        :data:`DETOUR_MARGIN_CM`.
        """
        assert self.collision is not None
        return self.collision.clear_height_cm(q) + DETOUR_MARGIN_CM

    def travel_heights_cm(self, q: npt.ArrayLike) -> tuple[float, float]:
        """The TCP heights an approach tries, highest first, for the tool as at ``q`` [cm].

        The safe height with :data:`TRAVEL_MARGIN_CM` for the arm's lag in a transit,
        then the safe height alone.
        """
        safe = self.safe_height_cm(q)
        return safe + TRAVEL_MARGIN_CM, safe

    def _detour(
        self, target: IKTarget, q_start: npt.ArrayLike, obj: str | None
    ) -> tuple[IKResult, float] | str:
        """Up, over at a safe height and down to ``target``, checked whole.

        A leg up or over that the tool cannot make pointing along the approach (far out,
        a wrist at its limit) is solved for the TCP's position alone: the down leg turns
        the tool to the approach. Where the arm cannot rise straight up to that height at
        all (near its base: the paper arm's shoulder at its limit 32 cm out, 27 cm up),
        the way over leaves from the start, rising as it goes: a place from a pick by
        the table's near edge, the green bin's walls grown for 15 greens, was left ``bin
        unreachable`` (``sim --random 44 --seed 43011``, the count a refusal of 500
        named, 43 of 44), though that way to the bin is clear.

        Where no height over every wall and object top works, the way over is tried once
        more at the height over only what lies under it
        (:meth:`~mearm.kinematics.collision.CollisionModel.clear_height_between_cm`): the
        MeArm v1's blues were left ``bin unreachable`` with the red bin's walls raised to
        5 cm, the height over them out of the claw's reach over the blue bin, the red bin
        well off their way (``sim_mearm_v1 --set task.classes.0.bin_height_cm=5``,
        4 of 6). Tried last, so that every way the heights over everything find is kept.

        The plan and the height it travels at; or, where no height works, what stopped
        the lowest over every wall and object top (where the way up was not solved, what
        stopped it), and where the way over only what lies under it was tried, what
        stopped that too: with the MeArm v1's red bin's walls at 5 cm and the blue bin's
        at 4.8 cm the blues' places named only the height over the red bin's walls, 7.1
        cm, out of reach over the blue bin, though the blue bin's own walls alone ask for
        6.9 cm, out of reach too (``--set task.classes.0.bin_height_cm=5 --set
        task.classes.2.bin_height_cm=4.8``): lowering the red bin's walls would not help.
        """
        assert self.collision is not None
        q0 = np.asarray(q_start, dtype=float)
        base = self.safe_height_cm(q0)
        lowest = ""
        for extra in DETOUR_EXTRA_CM:
            z = base + extra
            way = self._over_at(z, target, q0, obj)
            if not isinstance(way, str):
                return way, z
            lowest = lowest or f"over the top at {z:.1f} cm: {way}"
        # lower still: over only what lies under the way there (the corridor's height);
        # the path is checked whole as at every other height
        z = self.collision.clear_height_between_cm(q0, target.position_cm) + DETOUR_MARGIN_CM
        if z < base:
            way = self._over_at(z, target, q0, obj)
            if not isinstance(way, str):
                return way, z
            # the closest it came, named too: the height over everything alone would send
            # a user to lower walls that do not lie under the way
            return f"{lowest}; over what lies under the way at {z:.1f} cm: {way}"
        return lowest

    def _over_at(
        self, z: float, target: IKTarget, q0: np.ndarray, obj: str | None
    ) -> IKResult | str:
        """:meth:`_detour`'s way over at TCP height ``z`` [cm], checked whole; or what stops it."""
        assert self.collision is not None
        z0 = float(self.model.fk_cm(q0)[2])
        x1, y1, z1 = (float(v) for v in target.position_cm)
        legs = [
            self.up_from(q0, max(z0, z), target.approach),
            IKTarget((x1, y1, max(z1, z)), target.approach),
            target,
        ]
        results: list[IKResult] = []
        q = q0
        rise = ""  # why the way straight up was not solved, if it was not
        for i, leg in enumerate(legs):
            result, failure = self._solve(leg, q)
            if failure is not None and i < len(legs) - 1 and leg.approach is not None:
                # far out, the tool may not point down that high (the 5-DOF arm's wrist
                # at its limit 27 cm out): it rises, or travels, tilted, and turns
                # down on the way to the target
                tilted, tilted_failure = self._solve(IKTarget(leg.position_cm), q)
                if tilted_failure is None:
                    result, failure = tilted, None
            if result is None or failure is not None:
                assert failure is not None
                if i == 0:  # no way straight up: over from here, rising as it goes
                    rise = failure.message
                    continue
                return rise or failure.message
            results.append(result)
            q = result.q
        joined = _join(results, np.asarray(target.position_cm, dtype=float))
        contact = self.collision.first_contact(joined.q_path, target=obj)
        if contact is None:
            return joined
        return rise or self._describe(contact)

    def _outside_limits(self, q: np.ndarray) -> IKFailure | None:
        """The first pose of ``plan`` outside the joint limits or the pulse ranges, if any.

        Outside a joint's limits (or not finite), or a servo that turns a combination of
        joints past its pulse range (:meth:`_outside_pulses`).

        Args:
            q: The plan's poses, full joints in model units, (k, n).
        """
        chain = self.model.chain
        tol = 1e-9
        inside = (q >= chain.lower - tol) & (q <= chain.upper + tol)  # NaN fails both
        if inside.all():
            return self._outside_pulses(q)
        k, i = (int(v) for v in np.argwhere(~inside)[0])
        s, unit = chain.scale[i], chain.unit(i)
        return IKFailure(
            "limit",
            f"plan rejected before sending: pose {k} of {len(q) - 1} puts {chain.names[i]} at "
            f"{q[k, i] / s:.4g} {unit}, outside its limits "
            f"[{chain.lower[i] / s:.4g}, {chain.upper[i] / s:.4g}] {unit}",
        )

    def pose_allowed(self, q: npt.ArrayLike) -> bool:
        """Whether a pose (full joints, model units) is within every limit and pulse range."""
        return self._outside_limits(np.atleast_2d(np.asarray(q, dtype=float))) is None

    def _outside_pulses(self, q: np.ndarray) -> IKFailure | None:
        """The first pose where a servo over a combination of joints leaves its pulse range.

        The MeArm's elbow servo turns shoulder + elbow. The check is the servo map's
        (:meth:`~mearm.hardware.mapping.ServoMap.outside_pulse_range`), the one ``mearm
        ik`` and ``mearm fk`` make too.
        """
        if self._combination is None:  # every servo turns its own joint: nothing to check
            return None
        chain = self.model.chain
        index = chain.actuated_index
        found = self._servos.outside_pulse_range(chain.actuated_of(q) / chain.scale[index])
        if found is None:
            return None
        servo = found.servo
        lo, hi = servo.pulse_limits
        return IKFailure(
            "limit",
            f"plan rejected before sending: pose {found.pose} of {len(q) - 1} turns "
            f"{servo.servo_text} to {found.value:.4g} {servo.unit}, outside what its "
            f"pulse range allows [{lo:.4g}, {hi:.4g}] {servo.unit}",
        )


#: A joint-space move's step: no actuated joint turns more than this between poses
#: [rad] (a prismatic one: :data:`JOINT_MOVE_STEP_M`).
JOINT_MOVE_STEP_RAD = np.deg2rad(2.0)
JOINT_MOVE_STEP_M = 0.005


def _joint_move(model: ArmModel, result: IKResult, target_cm: np.ndarray) -> IKResult:
    """``result``'s start and solution joined by a straight line of the actuated joints."""
    chain = model.chain
    a0, a1 = (chain.actuated_of(q) for q in (result.q_path[0], result.q))
    prismatic = chain.prismatic[chain.actuated_index]
    step = np.where(prismatic, JOINT_MOVE_STEP_M, JOINT_MOVE_STEP_RAD)
    k = max(1, int(np.ceil(np.max(np.abs(a1 - a0) / step))))
    q_path = np.array([chain.full(a0 + (a1 - a0) * t) for t in np.linspace(0.0, 1.0, k + 1)])
    ee = np.array([model.fk_cm(q) for q in q_path])
    return dataclasses.replace(
        result,
        iterations=k,
        q_path=q_path,
        ee_path_cm=ee,
        error_path_cm=np.linalg.norm(ee - target_cm, axis=1),
        method="joint_move",
        search_iterations=result.search_iterations + result.iterations,
    )


def _join(results: list[IKResult], target_cm: np.ndarray) -> IKResult:
    """Legs solved one after the other as one result toward ``target_cm``."""
    last = results[-1]
    ee = np.vstack([results[0].ee_path_cm, *(r.ee_path_cm[1:] for r in results[1:])])
    return dataclasses.replace(
        last,
        iterations=sum(r.iterations for r in results),
        initial_error_cm=float(np.linalg.norm(ee[0] - target_cm)),
        q_path=np.vstack([results[0].q_path, *(r.q_path[1:] for r in results[1:])]),
        ee_path_cm=ee,
        error_path_cm=np.linalg.norm(ee - target_cm, axis=1),
        search_iterations=sum(r.search_iterations for r in results),
    )


def _fail(route: Route, failure: IKFailure) -> Route:
    route.failure_kind = failure.kind
    route.failure = failure.message
    return route
