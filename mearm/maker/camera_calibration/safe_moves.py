"""The arm's moves, each planned in full and checked against the servos' doubt first.

No joint may come, within its doubt, nearer than :data:`JOINT_MARGIN` to its limits (nor
a servo to the end of its travel); the tool's lowest point stays :data:`TABLE_MARGIN_CM`
(or a higher floor, :attr:`SafeMoves.floor_cm`) above the table however far the doubt
could lower it; and the planner keeps ``task.clearance_cm`` plus how far the doubt could
move the tool wherever it could come below a bin wall's or an object's top. A move that
fails a check is not made.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from mearm.config import Config
from mearm.config.servo_file import replaced_calibration
from mearm.hardware import ServoMap
from mearm.ik import IKTarget
from mearm.kinematics.chain import Chain
from mearm.kinematics.collision import CollisionModel
from mearm.maker.camera_calibration.doubt import ServoDoubt
from mearm.maker.camera_calibration.errors import CameraCalibrationFailed
from mearm.maker.camera_calibration.points import (
    Point,
    Visit,
    joint_line,
    solved,
    thinned,
    tops_cm,
)
from mearm.maker.camera_calibration.settings import (
    APPROACH_FROM,
    CLEARANCE_STEP_CM,
    JOINT_MARGIN,
    TABLE_MARGIN_CM,
)
from mearm.sim.table_collision import collision_model
from mearm.task.claw_fit import ClawCamera
from mearm.task.execute import CollisionError, Executor
from mearm.task.plan import Planner
from mearm.task.rig import Rig
from mearm.task.route import Route
from mearm.task.timing import TimedPath


@dataclass(frozen=True)
class Slack:
    """How far a pose keeps inside the moves' checks within the doubt (below 0: outside).

    Attributes:
        joints: Each actuated joint's room to :data:`JOINT_MARGIN` inside its limits,
            model units, (m,).
        travel: Each joint servo's room to :data:`JOINT_MARGIN` inside its travel (the
            values the arm's own calibration puts at its ``min_us`` and ``max_us``: where
            its shaft stops) [deg or cm], (m,).
        table_cm: The tool's lowest point's room to :attr:`SafeMoves.floor_cm` [cm].
        reach_cm: How far the doubt may move a point of the tool, where that may bring
            it near a bin or an object; 0 where the tool, lowered by the doubt, stays
            above every bin wall and object by ``task.clearance_cm`` [cm].
        low_cm: The tool's lowest point above the table, as planned [cm].
        drop_cm: How far the doubt may lower it [cm].
        doubt: Each actuated joint's doubt, model units, (m,).
    """

    joints: np.ndarray
    travel: np.ndarray
    table_cm: float
    reach_cm: float
    low_cm: float
    drop_cm: float
    doubt: np.ndarray


#: How far past a check's bound a slack may come and pass, for rounding: the joints'
#: [model units] and the servos' travel [deg or cm]; the table's [cm].
_TOL = 1e-9
_TABLE_TOL_CM = 1e-6


def limits_of(chain: Chain, config: Config) -> tuple[np.ndarray, np.ndarray]:
    """The actuated joints' limits, model units, (m,) each: the chain's, or the config's.

    The config's where narrower: a calibration narrows a joint's limits where its servo
    reaches less of them (:func:`~mearm.config.servo_reach.narrowed`).
    """
    named = config.arm.joint_limits()
    scale = chain.scale[chain.actuated_index]
    lower = np.array([named[n].min for n in chain.actuated]) * scale
    upper = np.array([named[n].max for n in chain.actuated]) * scale
    return np.maximum(lower, chain.actuated_lower), np.minimum(upper, chain.actuated_upper)


class SafeMoves:
    """The arm's moves on an open rig, each planned in full and checked against the doubt.

    Args:
        config: The whole configuration (the present calibration; the scene as opened).
        rig: The rig, its bus connected.
        claw: The camera's view of the marker on the claw.

    Attributes:
        present: The configuration as given.
        config: The same with the fit the bus sends, once one is used.
        doubt: How far each servo may be from where it is sent.
        objects: What the camera saw on the table at home (id, class, x, y).
        raises: Each actuated joint's way (±1) that raises the tool at home.
        floor_cm: How high above the table the tool's lowest point stays, within the
            doubt: :data:`TABLE_MARGIN_CM`, or more (``floor_cm``; a sort's calibration
            keeps it above every object's top, seen or not) [cm].
    """

    def __init__(
        self, config: Config, rig: Rig, claw: ClawCamera, *, floor_cm: float = TABLE_MARGIN_CM
    ):
        self.present = config
        self.config = config  # with the fit the bus sends, once one is used
        self.floor_cm = max(TABLE_MARGIN_CM, floor_cm)
        #: Whether the floor keeps the tool above every object's top: the objects seen
        #: then keep ``task.clearance_cm`` from the arm's body as planned (the doubt lowers
        #: the tool to the floor at worst), the bins that plus the doubt's reach.
        self.over_objects = self.floor_cm > TABLE_MARGIN_CM
        own = replaced_calibration(config) or config  # the arm's calibration, before any file
        self.nominal_arm = own.arm
        self.shaft = ServoMap.from_arm(own.arm)  # where each servo's shaft stops: its pulse range
        self.rig, self.bus, self.model = rig, rig.bus, rig.model
        self.bus.servo_map = self.bus.servo_map.without_play()  # the play is measured
        self.chain = rig.model.chain
        self.claw = claw
        self.executor = Executor(config, rig.bus, rig.model, None)
        self.doubt = ServoDoubt()
        self.objects: list[tuple[str, str, float, float]] = []
        self._collision: dict[float, CollisionModel] = {}
        self._planner: dict[float, Planner] = {}
        self._kept_for: tuple[CollisionModel, float] | None = None  # what _kept holds for
        self._kept_poses: tuple[dict[bytes, float], dict[bytes, np.ndarray]] = ({}, {})
        self.raises = self._raising()
        self.tops_cm = tops_cm(config, [])

    # ----------------------------------------------------------------- planners

    def planner(self, clearance_cm: float) -> Planner:
        """A planner keeping ``clearance_cm`` from the bins and the objects seen (kept)."""
        key = round(clearance_cm, 3)
        if key not in self._collision:
            col = collision_model(self.present, self.model, clearance_cm=key)
            base = round(self.present.task.clearance_cm, 3)
            if not self.over_objects or key == base:  # else: objects_refusal
                col.set_world(self.objects, opening_cm=self.present.arm.tool.gripper.open_cm)
            self._collision[key] = col
        if key not in self._planner:  # with the calibration the bus sends
            self._planner[key] = Planner(self.config, self.model, self._collision[key])
        return self._planner[key]

    def collision(self, clearance_cm: float) -> CollisionModel:
        """:meth:`planner`'s collision model."""
        col = self.planner(clearance_cm).collision
        assert col is not None
        return col

    def clearance_cm(self, reach_cm: float) -> float:
        """``task.clearance_cm`` plus ``reach_cm``, rounded up to :data:`CLEARANCE_STEP_CM`."""
        steps = math.ceil(max(0.0, reach_cm) / CLEARANCE_STEP_CM - 1e-9)
        return self.present.task.clearance_cm + steps * CLEARANCE_STEP_CM

    # ----------------------------------------------------------------- the doubt

    def tool_points(self, q: np.ndarray) -> np.ndarray:
        """The TCP, the jaws' tips and the marker's centre at joints ``q`` [cm], (3, 3)."""
        p, R = self.model.tcp_pose(q)
        tool = self.present.arm.tool
        hang = tool.tcp_above_grip_cm + tool.gripper.jaw_length_cm / 2.0
        return np.array([p, p + (R @ self.model.approach_axis) * hang, self.claw.centre_cm(q)])

    def lowest_cm(self, q: np.ndarray) -> float:
        """The tool's lowest point above the table at ``q`` [cm] (the collision model's)."""
        col, kept = self._kept()[:2]
        key = np.ascontiguousarray(q, dtype=float).tobytes()
        if key not in kept:
            kept[key] = col.tool_lowest_cm(q)[0]
        return kept[key]

    def kept_tool_points(self, q: np.ndarray) -> np.ndarray:
        """:meth:`tool_points`, kept per pose as :meth:`lowest_cm` is (read-only)."""
        kept = self._kept()[2]
        key = np.ascontiguousarray(q, dtype=float).tobytes()
        if key not in kept:
            kept[key] = self.tool_points(q)
            kept[key].setflags(write=False)
        return kept[key]

    def _kept(self) -> tuple[CollisionModel, dict[bytes, float], dict[bytes, np.ndarray]]:
        """The collision model; the tool's lowest points and points kept, by the pose's bits.

        The checks look at the same poses again and again (a point's, turned by the same
        doubt, at each choice of the next point). Both are functions of the pose, the
        arm's shapes and the marker's apparent side alone: the stores are emptied when the
        collision model or the side changes.
        """
        col = self.collision(self.present.task.clearance_cm)
        held = self._kept_for
        if held is None or held[0] is not col or held[1] != self.claw.side:
            self._kept_for, self._kept_poses = (col, self.claw.side), ({}, {})
        return col, *self._kept_poses

    def doubt_turns(self, q: np.ndarray) -> tuple[np.ndarray, list[tuple[np.ndarray, ...]]]:
        """Each actuated joint's doubt at ``q``, and the poses with it turned by it.

        Returns:
            The doubts (model units, (m,)), and per joint the two poses with it turned by
            its doubt either way.
        """
        chain = self.chain
        doubt = self.doubt.joints(self.bus.servo_map, chain.named_actuated(q))
        doubt = doubt * chain.scale[chain.actuated_index]
        a = chain.actuated_of(q)
        eye = np.eye(len(a))
        return doubt, [
            tuple(chain.full(a + sign * d * eye[i]) for sign in (-1.0, 1.0))
            for i, d in enumerate(doubt)
        ]

    def slack(self, q: np.ndarray) -> Slack:
        """How far the pose ``q`` keeps inside the checks, within the doubt.

        Each joint's worst turn within its doubt, the table's and the tool's reach added
        up over the joints.
        """
        doubt, turns = self.doubt_turns(q)
        low = self.lowest_cm(q)
        drop = reach = 0.0
        for turned in turns:
            drop += self._drop_cm(low, turned)
        # above everything, the reach is 0 however far the tool strays sideways
        above = low - drop >= self.tops_cm + self.present.task.clearance_cm
        if not above:
            points = self.kept_tool_points(q)
            for turned in turns:
                reach += max(
                    float(np.linalg.norm(self.kept_tool_points(t) - points, axis=1).max())
                    for t in turned
                )
        return Slack(self._joint_room(q, doubt), self.travel(q), low - drop - self.floor_cm,
                     reach, low, drop, doubt)  # fmt: skip

    def allows(self, q: np.ndarray) -> bool:
        """Whether :meth:`refusal` passes ``q`` (no ``floor``), without the reach it returns.

        The same checks in the same order, each stopping at its first failure: the
        joints', the servos' travel, then the table's, joint by joint (the drop only grows).
        """
        doubt, turns = self.doubt_turns(q)
        if np.any(self._joint_room(q, doubt) < -_TOL) or np.any(self.travel(q) < -_TOL):
            return False
        low, drop = self.lowest_cm(q), 0.0
        for turned in turns:
            drop += self._drop_cm(low, turned)
            if low - drop - self.floor_cm < -_TABLE_TOL_CM:
                return False
        return True

    def _joint_room(self, q: np.ndarray, doubt: np.ndarray) -> np.ndarray:
        """Each actuated joint's room to its limits' margin within ``doubt`` (:class:`Slack`)."""
        chain = self.chain
        margin = JOINT_MARGIN * chain.scale[chain.actuated_index]
        a = chain.actuated_of(q)
        lower, upper = self.limits()
        return np.minimum(a - doubt - (lower + margin), upper - margin - a - doubt)

    def _drop_cm(self, low: float, turned: tuple[np.ndarray, ...]) -> float:
        """How far below ``low`` the tool's lowest point comes at the ``turned`` poses [cm]."""
        return max(0.0, *(low - self.lowest_cm(t) for t in turned))

    def limits(self) -> tuple[np.ndarray, np.ndarray]:
        """The actuated joints' limits with the fit the bus sends (:func:`limits_of`)."""
        return limits_of(self.chain, self.config)

    def travel(self, q: np.ndarray) -> np.ndarray:
        """Each joint servo's room inside its travel at ``q``, within the doubt (:class:`Slack`).

        A servo that turns a combination of joints (the MeArm v1's elbow) can reach the
        end of its shaft's travel inside the joints' limits.
        """
        named = self.chain.named_actuated(q)
        smap = self.bus.servo_map
        values = smap.servo_values(named)
        doubt = self.doubt.servos(smap, named)
        room = []
        for j, d in zip(smap.joints, doubt, strict=True):
            lo, hi = self.shaft[j.name].pulse_limits
            v = values[j.name]
            room.append(min(v - d - lo, hi - v - d) - JOINT_MARGIN)
        return np.array(room)

    def refusal(self, q: np.ndarray, floor: Slack | None = None) -> tuple[str | None, float]:
        """Why the pose ``q`` is not safe within the doubt (``None``: it is), and its reach.

        The reach: how far the doubt could move the tool there [cm]. With ``floor`` (the
        slack where a path starts), a pose may keep as little slack as the start where
        that has less than none: the arm may leave where it is.
        """
        s = self.slack(q)
        chain = self.chain
        scale = chain.scale[chain.actuated_index]
        least = np.zeros_like(s.joints) if floor is None else np.minimum(0.0, floor.joints)
        for i, name in enumerate(chain.actuated):
            if s.joints[i] < least[i] - _TOL:
                unit = chain.unit(int(chain.actuated_index[i]))
                a = chain.actuated_of(q)[i] / scale[i]
                return (
                    f"{name} at {a:.1f} {unit} could come within {JOINT_MARGIN:g} {unit} of "
                    f"its limits (it may be {s.doubt[i] / scale[i]:.1f} {unit} off)",
                    s.reach_cm,
                )
        least = np.zeros_like(s.travel) if floor is None else np.minimum(0.0, floor.travel)
        for i, servo in enumerate(self.bus.servo_map.joints):
            if s.travel[i] < least[i] - _TOL:
                return (
                    f"{servo.servo_text} could come within {JOINT_MARGIN:g} {servo.unit} of the "
                    "end of its travel",
                    s.reach_cm,
                )
        if s.table_cm < (0.0 if floor is None else min(0.0, floor.table_cm)) - _TABLE_TOL_CM:
            return (
                f"the tool, {s.low_cm:.1f} cm above the table, could come down {s.drop_cm:.1f} "
                f"cm (to within {self.floor_cm:g} cm of it)",
                s.reach_cm,
            )
        return None, s.reach_cm

    def path_refusal(self, q_path: np.ndarray) -> tuple[str | None, float]:
        """:meth:`refusal` along a path from its first pose: the first, and the largest reach.

        Checked every :data:`PATH_CHECK_STEP` of the joints' largest turn and at the end:
        the doubt changes little in between (the collisions are checked whole by the
        planner).
        """
        floor = self.slack(q_path[0])
        worst = floor.reach_cm
        for q in thinned(self.chain, q_path)[1:]:
            why, reach = self.refusal(q, floor)
            if why is not None:
                return why, reach
            worst = max(worst, reach)
        return None, worst

    def _raising(self) -> np.ndarray:
        """Each actuated joint's way (±1) that raises the tool's lowest point at home."""
        col = self.collision(self.present.task.clearance_cm)
        home, chain = self.model.home, self.chain
        low = col.tool_lowest_cm(home)[0]
        ways = []
        for i in range(chain.m):
            a = chain.actuated_of(home)
            a[i] += 1e-3
            ways.append(-1.0 if col.tool_lowest_cm(chain.full(a))[0] < low - 1e-9 else 1.0)
        return np.array(ways)

    def turned(self, q: np.ndarray, way: float) -> np.ndarray:
        """``q``, each joint :data:`APPROACH_FROM` the way that raises the tool (-1: lowers)."""
        chain = self.chain
        step = [APPROACH_FROM[chain.unit(int(i))] for i in chain.actuated_index]
        shift = way * self.raises * np.array(step) * chain.scale[chain.actuated_index]
        return chain.full(chain.actuated_of(q) + shift)

    def plan_visit(self, point: Point) -> Visit | str:
        """The moves to ``point``, planned in full and checked, or why not.

        To where the final move starts (every joint :data:`APPROACH_FROM` from the
        point's, the way that raises the tool: :meth:`way_to`), then the final move, a
        straight line in the joints, down to the point. The checks keep the doubt's reach
        of the tool at the start and at the point as clearance; moves that reach farther
        are planned again with their reach.
        """
        q0 = self.executor.q_now()
        target = IKTarget(point.target_cm, self.present.arm.tool.pick_approach)
        planner = self.planner(self.present.task.clearance_cm)
        q_end = solved(planner, target, q0)
        if q_end is not None:  # its free joints as the point has them
            q_end = point.reached(self.chain, q_end)
        if q_end is None or not planner.pose_allowed(q_end):
            return "no solution inside the limits"
        start = self.turned(q_end, 1.0)
        need = max(self.refusal(q0)[1], self.refusal(q_end)[1])
        for _ in range(3):
            clearance = self.clearance_cm(need)
            visit = self.way_to(q0, start, clearance)
            if isinstance(visit, str):
                return visit
            final = joint_line(self.chain, visit.path()[-1], q_end)
            why = self.final_refusal(final, clearance)
            if why is not None:
                return "the final move: " + why
            visit = dataclasses.replace(visit, lines=(*visit.lines, final))
            why, reach = self.path_refusal(visit.path())
            if why is None and visit.timed is not None:  # the lines were checked whole
                why = self.objects_refusal(visit.route.plan.q_path)  # type: ignore[union-attr]
                why = why or self.objects_refusal(visit.timed.q)  # and the route's commands
            if why is not None:
                return why
            if self.clearance_cm(reach) <= clearance:
                return visit
            need = reach
        return f"the doubt's reach grew to {need:.1f} cm with each plan"

    def final_refusal(self, final: np.ndarray, clearance_cm: float) -> str | None:
        """Why the final move may not be sent, kept clear by the doubt's reach along it.

        ``clearance_cm`` is the whole visit's, the doubt's reach where it is largest on
        the way (at home, folded low: some 16 cm on the kit twin). The final move keeps
        ``task.clearance_cm`` plus the doubt's reach along the move itself, which is what
        the tool there may stray by; where the visit's clearance refuses it, that one
        decides. A bin wall within the visit's clearance where the move starts may
        come no closer than it starts, so a point above a table whose walls stand within
        it (two objects on the kit twin: every point) was refused for coming 0.01 cm
        nearer a wall 16 cm away.
        """
        why = self.line_refusal(final, clearance_cm)
        if why is None:
            return None
        other, reach = self.path_refusal(final)
        if other is not None:
            return why
        own = self.clearance_cm(reach)
        if own < clearance_cm and self.line_refusal(final, own) is None:
            return None
        return why

    def way_to(self, q0: np.ndarray, start: np.ndarray, clearance_cm: float) -> Visit | str:
        """The way from ``q0`` to ``start``, or why there is none.

        A straight line in the joints where that is clear; else a planned route to its TCP
        (which may go up, over and down), and a line from where that ends where that is
        not ``start`` (an arm with joints to spare).
        """
        line = joint_line(self.chain, q0, start)
        if self.line_refusal(line, clearance_cm) is None:
            return Visit(None, (line,))
        approach = None  # the approach axis as it is there, where picks keep one
        if self.present.arm.tool.pick_approach is not None:
            ax, ay, az = (float(v) for v in self.model.approach(start))
            approach = (ax, ay, az)
        x, y, z = (float(v) for v in self.model.fk_cm(start))
        route = Route("", "", "approach", 1, IKTarget((x, y, z), approach))
        if not self.planner(clearance_cm).plan(route, q0).planned or route.plan is None:
            return route.failure or "no plan"
        timed = self.followed(route, clearance_cm)
        if isinstance(timed, str):
            return timed
        turn = np.abs(self.chain.actuated_of(self.turned(start, -1.0) - start))
        off = np.abs(self.chain.actuated_of(route.plan.q - start))
        if np.all(off <= 0.1 * turn):  # there, to the solver's tolerance
            return Visit(route, (), timed)
        line = joint_line(self.chain, route.plan.q, start)
        why = self.line_refusal(line, clearance_cm)
        if why is not None:
            return "the way to where its final move starts: " + why
        return Visit(route, (line,), timed)

    def followed(self, route: Route, clearance_cm: float) -> TimedPath | str:
        """``route``'s commands as the servos follow them, checked at ``clearance_cm``; or why not.

        Between two commands a servo moves on the chord between them, a little off the
        planned polyline where it turns: the chords are checked as the plan was, and the
        sort's (:meth:`Executor.followed <mearm.task.execute.Executor.followed>`: slower
        where they come too close).
        """
        ex = self.executor
        ex.collision = self.collision(clearance_cm)
        try:
            return ex.followed(route, carrying=False)
        except CollisionError as exc:
            return str(exc)
        finally:
            ex.collision = None

    def line_refusal(self, path: np.ndarray, clearance_cm: float) -> str | None:
        """Why a straight line in the joints may not be sent: the limits or a collision."""
        planner = self.planner(clearance_cm)
        if not planner.pose_allowed(path):
            return "it leaves the limits"
        contact = self.collision(clearance_cm).first_contact(path)
        if contact is not None:
            return contact.describe(self.chain.names, self.chain.scale)
        return self.objects_refusal(path)

    def objects_refusal(self, path: np.ndarray) -> str | None:
        """Why ``path`` comes within ``task.clearance_cm`` of an object seen, or ``None``.

        Only with :attr:`over_objects` (the planners with the doubt's reach leave them out).
        """
        if not self.over_objects or not self.objects:
            return None
        contact = self.collision(self.present.task.clearance_cm).first_contact(path)
        return None if contact is None else contact.describe(self.chain.names, self.chain.scale)

    def go(self, visit: Visit) -> None:
        """Stream a visit's route, if any, then its lines (as checked)."""
        if visit.route is not None:
            self.executor.stream(visit.route, "travel", closed=False, timed=visit.timed)
        for line in visit.lines:
            self.line(line)

    def line(self, path: np.ndarray) -> None:
        """Move along a checked straight line in the joints, from where the arm is.

        The executor steps its own line from the arm's last confirmed pose to the same end:
        the line checked when it starts where that one does. Its poses may be one more or
        fewer: the pose the bus confirms can differ from the one planned in the last bit,
        and a turn of a whole number of :data:`~mearm.task.execute.JOINT_STEP` then tips
        into one more step or not. Nothing sent leaves the line checked: the checks hold
        between the poses (the collisions along each step; the limits, box-shaped with a
        linear coupling, on the whole line), and the commands are sampled on the line.

        Raises:
            CameraCalibrationFailed: the executor's line is not the one checked (a bug).
        """
        ex = self.executor
        sent = ex.joint_path(path[-1])
        if not np.allclose(sent[[0, -1]], path[[0, -1]], atol=1e-9):
            raise CameraCalibrationFailed("the move is not the one checked (a bug); stopped")
        ex.move_joints(path[-1], "travel", closed=False)

    def from_below(self) -> str | None:
        """Each joint :data:`APPROACH_FROM` the way that lowers the tool and back; or why not."""
        q = self.executor.q_now()
        over = self.turned(q, -1.0)
        there, back = joint_line(self.chain, q, over), joint_line(self.chain, over, q)
        path = np.vstack([there, back[1:]])
        why, reach = self.path_refusal(path)
        if why is None:
            why = self.line_refusal(path, self.clearance_cm(reach))
        if why is not None:
            return why
        self.line(there)
        self.line(back)
        return None

    def park(self) -> None:
        """Home along a straight line in the joints, first straight up if that is not clear.

        The line keeps ``task.clearance_cm`` and the doubt's reach from the bins and
        objects, as far as home itself does (the arm started there).

        Raises:
            CameraCalibrationFailed: no way home is clear; the arm stays where it is.
        """
        ex, home = self.executor, self.model.home
        room_cm = self.collision(self.present.task.clearance_cm).gap(home)[0] * 100.0
        reach = max(self.slack(q).reach_cm for q in ex.joint_path(home)[::5])
        clearance = self.clearance_cm(min(reach, room_cm - CLEARANCE_STEP_CM))
        planner = self.planner(clearance)
        why = self.line_refusal(ex.joint_path(home), clearance)
        if why is not None:  # up first, to where the line home is clear
            x, y, z = (float(v) for v in ex.ee_now_cm())
            safe = planner.safe_height_cm(ex.q_now())
            approach = self.present.arm.tool.pick_approach
            up = Route("", "", "home", 1, IKTarget((x, y, max(z, safe)), approach))
            timed = self.way_up(up, clearance)
            if isinstance(timed, str):
                why = f"{why}, and the way up: {timed}"
            else:
                ex.stream(up, "travel", closed=False, timed=timed)
                why = self.line_refusal(ex.joint_path(home), clearance)
        if why is not None:
            raise CameraCalibrationFailed(
                f"not parked: the way home: {why}; the arm stays where it is"
            )
        ex.move_joints(home, "travel", closed=False)
        ex.home_pose()

    def way_up(self, up: Route, clearance_cm: float) -> TimedPath | str:
        """``up`` planned from where the arm is, its commands checked; or why not.

        Its commands as the servos follow them (:meth:`followed`), and both its plan and
        its commands against the objects seen. Why not is said with the line home's
        refusal, whichever check it was: until 2026-12-07 only the commands' was, and a
        way up that could not be planned or came near an object was refused in silence, as
        if it had never been tried.
        """
        if not self.planner(clearance_cm).plan(up, self.executor.q_now()).planned:
            return up.failure or "no plan"
        assert up.plan is not None
        timed = self.followed(up, clearance_cm)
        if isinstance(timed, str):
            return timed
        why = self.objects_refusal(up.plan.q_path) or self.objects_refusal(timed.q)
        return timed if why is None else why
