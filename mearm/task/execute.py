"""Execute: send a planned route to the servos, pose by pose, and set the tool.

Only routes whose plan converged are sent (:attr:`Route.planned`); every command goes
through the bus's own checks (limits, pulse ranges) before a byte is sent. A plan is
streamed as :func:`mearm.task.timing.time_path` samples it: points of the planned path,
one per servo period, none faster than a servo's speed limit; a tool setting is held for
its servos' travel and settling (:func:`mearm.task.timing.tool_move_s`). The executor adds
both up in :attr:`Executor.motion`.

The executor also keeps the view (if any) in step with the arm. On a bus that measures
the world — the physical twin (:class:`mearm.sim.twin.twin_bus.TwinArm`), recognised by its
``object_pose``, ``actual_joints`` and ``opening_cm`` — it pushes what the physics has
(:meth:`Executor.show_world`): the measured joints and jaw opening and every object's
pose, so a carried object moves with the jaws and a dropped one lands in its bin. On
any other bus the view shows the commanded joints.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterable
from typing import Literal, Protocol

import numpy as np
import numpy.typing as npt

from mearm.config import Config
from mearm.errors import MearmError
from mearm.hardware.bus import MeasuresTcp, MeasuresWorld, ReportsHold, ServoBus
from mearm.hardware.command import ArmCommand
from mearm.kinematics import ArmModel, Chain
from mearm.kinematics.collision import TOUCH_M, CollisionModel
from mearm.task.route import Route
from mearm.task.timing import MotionTime, SpeedLimits, TimedPath, time_path, tool_move_s

Phase = Literal["home", "travel", "grip"]

#: How long a bus that measures its joints (the twin) is given, after the last command of
#: a move, for every joint to arrive before the move is a fault [s]: a servo at half its
#: rated speed is about 0.3 s behind at the end of a full-speed 180° swing.
ARRIVAL_TIMEOUT_S = 2.0

#: The largest step between two planned poses of a joint-space move: [rad] for a revolute joint
#: (2°), [m] for a prismatic one (0.5 cm).
JOINT_STEP = {False: np.deg2rad(2.0), True: 0.005}

#: A route whose commands' chords come too close to something is timed again at these
#: fractions of the servos' speeds, in turn (:meth:`Executor.stream`): each chord is that
#: much shorter, and nearer the plan's polyline.
SLOWER = (0.5, 0.25, 0.125, 0.0625)

#: The view is shown the arm at most this often in the stream's own time [Hz]: a faster
#: stream (``servo.rate_hz``) shows every k-th move and each route's last. A frame costs
#: one meshcat round trip per body (about 6.5 ms for the paper arm), which at 1000 Hz
#: held a paced run back to half speed.
VIEW_HZ = 60.0


def carry_limits(limits: SpeedLimits, config: Config, chain: Chain) -> SpeedLimits:
    r"""The limits while the jaws hold an object: ``task.carry_accel_deg_s2`` caps each servo.

    A servo's shaft acceleration :math:`a` [deg/s²] is :math:`a\,k_s/k` of its value (as
    :meth:`~mearm.config.ServoCalibration.value_accel` has it); each servo keeps the lower of
    that and its own limit. ``limits`` as they are where the task sets no cap.
    """
    cap_deg_s2 = config.task.carry_accel_deg_s2
    if cap_deg_s2 is None:
        return limits
    servos = {j.name: j.servo for j in config.arm.joints if j.servo is not None}
    scale = chain.scale[chain.actuated_index]
    cap = np.array([servos[n].value_accel(cap_deg_s2) for n in chain.actuated]) * scale
    return dataclasses.replace(limits, acceleration=np.minimum(limits.acceleration, cap))


class CollisionError(MearmError):
    """A motion would bring the arm's body too close to something; nothing of it was sent.

    Too close: within ``task.clearance_cm`` of a bin or an object, or touching the table
    (:mod:`mearm.kinematics.collision`).
    """


class View(Protocol):
    """What the executor and the loop call on the meshcat view (:class:`mearm.view.ArmView`)."""

    def show_joints(self, q: npt.ArrayLike, opening_cm: float | None = None) -> None: ...  # noqa: D102
    def show_bodies(  # noqa: D102
        self,
        q: npt.ArrayLike,
        opening_cm: float,
        objects: Iterable[tuple[str, str, np.ndarray, np.ndarray]],
    ) -> None: ...
    def set_objects(self, objects: object) -> None: ...  # noqa: D102
    def set_camera_frame(  # noqa: D102
        self, frame_bgr: npt.ArrayLike, pixel_to_table: Callable[[np.ndarray], npt.ArrayLike]
    ) -> None: ...
    def set_target(self, target_cm: npt.ArrayLike | None) -> None: ...  # noqa: D102
    def hold(self, held: tuple[str, str] | None) -> None: ...  # noqa: D102
    def add_path(self, ee_path_cm: npt.ArrayLike, color: str) -> object: ...  # noqa: D102


def twin_object_ids(bus: object) -> tuple[str, ...] | None:
    """The ids of the objects a bus measures (the physical twin's), or ``None``.

    A bus measures the world when it is a :class:`~mearm.hardware.bus.MeasuresWorld`.
    """
    return tuple(bus.object_ids) if isinstance(bus, MeasuresWorld) else None


class Executor:
    """Streams plans to a servo bus and moves the tool.

    Args:
        config: The whole configuration.
        bus: The servo bus (connected by the caller).
        model: The arm model.
        view: A view to follow the arm, or ``None``.
        view_every: Show the view the arm after every this many moves (the twin's whole
            world, else the commanded joints); always at the end of a route or a joint
            path, at home, and after a tool setting. ``None``: as often as
            :data:`VIEW_HZ` allows at ``servo.rate_hz`` (every move at 60 Hz or less).
        collision: The model the routes were planned against (its world as the planner
            left it): a route's commands are checked against it as the servos follow
            them, chord by chord (:meth:`stream`); ``None``: not checked.

    Attributes:
        twin_ids: The objects the bus measures (:func:`twin_object_ids`), or ``None``:
            then the view is shown the commanded joints.
        limits: The actuated joints' speed limits (from their servo calibrations).
        carry_limits: The same while the jaws hold an object (:func:`carry_limits`).
        motion: The motion commanded so far: streamed arm motion and tool settings.
    """

    def __init__(
        self,
        config: Config,
        bus: ServoBus,
        model: ArmModel,
        view: View | None = None,
        *,
        view_every: int | None = None,
        collision: CollisionModel | None = None,
    ):
        if view_every is None:
            view_every = max(1, math.ceil(config.servo.rate_hz / VIEW_HZ))
        if view_every < 1:
            raise ValueError(f"view_every must be at least 1, not {view_every}")
        self.config = config
        self.bus = bus
        self.model = model
        self.view = view
        self.view_every = view_every
        self.chain = model.chain
        self._tool = config.arm.tool
        self.twin_ids = twin_object_ids(bus)
        self._classes = {c.name for c in config.task.classes}
        self._unshown = 0  # moves sent since the view was last shown the world
        self._unshown_q: np.ndarray | None = None  # the last joints sent, not yet shown
        self._unshown_opening_cm: float | None = None  # and the jaws' opening sent with them
        self.limits = SpeedLimits.of_arm(config.arm, self.chain)
        self.carry_limits = carry_limits(self.limits, config, self.chain)
        self.motion = MotionTime(stream_hz=1.0 / bus.period_s)
        self.collision = collision

    # ----------------------------------------------------------------- state

    def q_now(self) -> np.ndarray:
        """The last confirmed joints (home before the first move), model units, (n,)."""
        state = self.bus.state
        if state is None:
            return self.model.home
        return self.chain.from_named(state.joints)

    def ee_now_cm(self) -> np.ndarray:
        """Where the TCP is [cm], (3,): the simulated arm's truth, else the FK of the command."""
        if isinstance(self.bus, MeasuresTcp):
            return np.asarray(self.bus.ee_cm, dtype=float)
        return self.model.fk_cm(self.q_now())

    def world_now(self) -> tuple[np.ndarray, float, list[tuple[str, str, np.ndarray, np.ndarray]]]:
        """What the twin measures: joints (full, model units), jaw opening [cm], objects.

        Each object is ``(id, class_name, position_cm, quat)``: its body's centre in the
        base frame [cm] and orientation (w, x, y, z); its class is its id's prefix
        (``red3`` → ``red``); ids of no class are left out.

        Raises:
            ValueError: the bus does not measure the world (:attr:`twin_ids` is None).
        """
        bus = self.bus
        if self.twin_ids is None or not isinstance(bus, MeasuresWorld):
            raise ValueError("the bus measures no world: it is not the physical twin")
        q = self.chain.from_named(bus.actual_joints)
        objects = []
        for oid in self.twin_ids:
            class_name = oid.rstrip("0123456789")
            if class_name not in self._classes:
                continue
            pose = bus.object_pose(oid)
            objects.append(
                (oid, class_name, np.array(pose.position_cm, dtype=float), np.array(pose.quat))
            )
        return q, float(bus.opening_cm), objects

    def show_world(self) -> None:
        """Show the view the arm now: the twin's measured world, else the joints last sent.

        Nothing without a view, or on the kinematic rig when every move was shown.
        """
        if self.view is None:
            return
        self._unshown = 0
        if self.twin_ids is not None:
            self.view.show_bodies(*self.world_now())
        elif self._unshown_q is not None:
            # the jaws as commanded (the kinematic rig measures no opening): closed on what
            # they carry, not drawn open all the way
            self.view.show_joints(self._unshown_q, self._unshown_opening_cm)
            self._unshown_q = None

    def show_held(self, held: tuple[str, str] | None) -> None:
        """Have the view draw ``held``, ``(id, class)``, in the jaws (``None``: nothing).

        Only where the view draws the joints as commanded (the twin's view draws what it
        measures), and only while the bus does not say the jaws hold nothing of that class
        (a simulator knows: a missed grip is not drawn carried; a real rig does not).
        """
        if self.view is None or self.twin_ids is not None:
            return
        bus = self.bus
        if held is not None and isinstance(bus, ReportsHold) and held[1] not in bus.held_classes():
            held = None
        self.view.hold(held)

    def _flush_view(self) -> None:
        """Show the world if a move was sent since it was last shown."""
        if self._unshown:
            self.show_world()

    def tool_settings(self, phase: Phase) -> dict[str, float]:
        """Every tool actuator's value for a phase of the pick [deg]."""
        return {a.name: a.setting(phase) for a in self._tool.actuators}

    # ----------------------------------------------------------------- commands

    def send(self, q: npt.ArrayLike, phase: Phase, *, closed: bool) -> None:
        """Command the joints ``q`` (full, model units) with the tool set for ``phase``."""
        joints = self.chain.named_actuated(q)
        self.bus.move(ArmCommand(joints, self.tool_settings(phase), closed))
        if self.view is None:
            return
        if self.twin_ids is None:
            self._unshown_q = self.chain.full(self.chain.actuated_of(np.asarray(q)))
            self._unshown_opening_cm = self._tool.gripper.opening_cm(closed=closed)
        self._unshown += 1
        if self._unshown >= self.view_every:
            self.show_world()

    def _tool_change_s(self, phase: Phase, *, closed: bool) -> float:
        """How long setting the tool for ``phase`` takes from the last command [s]."""
        state = self.bus.state
        before = None if state is None else dict(state.tool)
        before_closed = None if state is None else state.gripper_closed
        return tool_move_s(
            self._tool,
            before,
            self.tool_settings(phase),
            before_closed=before_closed,
            after_closed=closed,
        )

    def set_tool(self, phase: Phase, *, closed: bool) -> None:
        """Hold the joints; set the tool and the gripper, held for its travel and settling."""
        seconds = self._tool_change_s(phase, closed=closed)
        self.send(self.q_now(), phase, closed=closed)
        self.bus.hold(seconds)
        self._count_tool(seconds)
        self.show_world()  # the jaws closed or opened, and what they hold
        if not closed:  # opened: they let go of what the view drew in them
            self.show_held(None)

    def close_following(self, q_path: npt.ArrayLike, phase: Phase, seconds: float) -> None:
        """Close the gripper for ``phase`` while the joints follow ``q_path``, one command a period.

        A moving object's catch (:mod:`mearm.task.conveyor`): the jaws close as the arm keeps
        them on the object, then the rest of the close's ``seconds`` is held. The path is
        the caller's, planned and checked in full; its first pose is where the arm is.
        """
        q = np.asarray(q_path, dtype=float)
        for pose in q[1:]:
            self.send(pose, phase, closed=True)
        followed_s = (len(q) - 1) * self.bus.period_s
        if seconds > followed_s:
            self.bus.hold(seconds - followed_s)
        self._arrive()
        self._count_tool(seconds)
        self.show_world()

    def rest(self, seconds: float) -> None:
        """Hold the arm still for ``seconds`` while something on the table comes to rest."""
        self.bus.hold(seconds)
        self.motion.rest_s += seconds

    def _count_tool(self, seconds: float) -> None:
        if seconds > 0:
            self.motion.tool_s += seconds
            self.motion.tool_moves += 1

    def _arrive(self) -> float:
        """Wait for the joints to reach the last command where the bus measures them [s].

        On the physical twin the servos' real speed under load may fall short of the
        config's ``seconds_per_60deg``; the tool must not act before the arm is there.
        The wait is counted in :attr:`MotionTime.wait_s`.

        Raises:
            ServoStallError: a joint stalled or did not arrive within
                :data:`ARRIVAL_TIMEOUT_S`.
        """
        waited = self.bus.await_arrival(ARRIVAL_TIMEOUT_S)
        self.motion.wait_s += waited
        return waited

    def timed(self, q_path: npt.ArrayLike, *, carrying: bool = False) -> TimedPath:
        """A planned path sampled within every speed limit (:func:`time_path`).

        ``carrying``: the jaws hold an object, and :attr:`carry_limits` hold.

        Its steps are sized for the bus's step time, its duration one bus period a
        command. The two differ on a board that glides each move over its own time and then
        answers a query on the wire (the SSC-32: at 9600 baud 20 ms of glide in a 93 ms
        period): the steps are what the speed limits allow in the glide, and the move
        takes a period per step.
        """
        period = self.bus.period_s  # known in full once the board has answered
        self.motion.stream_hz = 1.0 / period
        limits = self.carry_limits if carrying else self.limits
        timed = time_path(q_path, self.chain, limits, 1.0 / self.bus.step_s)
        return dataclasses.replace(timed, period_s=period)

    def stream(
        self,
        route: Route,
        phase: Phase,
        *,
        closed: bool,
        color: str = "#202020",
        timed: TimedPath | None = None,
    ) -> Route:
        """Send every pose of a planned route; refuse one that is not fully planned.

        Args:
            route: The route, planned.
            phase: The tool's setting on the way.
            closed: Whether the gripper is closed on the way.
            color: The route's colour in the view.
            timed: Its commands as :meth:`followed` gave them, checked in the world the
                route was planned in (a caller that checks several routes before sending
                the first); ``None``: timed and checked here, in the world as it is.

        Raises:
            ValueError: the route's plan is missing or failed (a bug: callers check).
            CollisionError: its commands' chords come too close to something
                (:meth:`followed`); nothing of the route was sent.
        """
        if not route.planned:
            raise ValueError(f"route {route.step} {route.object_id} is not planned: not sent")
        assert route.plan is not None
        # in full, checked, before anything is sent
        if timed is None:
            timed = self.followed(route, carrying=closed)
        if self.view is not None:
            self.view.set_target(route.target.position_cm)
        for q in timed.q[1:]:
            self.send(q, phase, closed=closed)
        waited = self._arrive()
        self._flush_view()
        route.executed = True
        route.motion_s = timed.duration_s + waited
        self.motion.arm_s += timed.duration_s
        if self.view is not None:
            self.view.add_path(route.plan.ee_path_cm, color)
        return route

    def followed(self, route: Route, *, carrying: bool) -> TimedPath:
        """``route``'s plan timed, with its commands' chords as clear as the plan.

        Between two commands the servos move on the chord between them
        (:mod:`mearm.task.timing`), which cuts across a corner of the plan's polyline: a
        route that rises out of a bin and then turns (the jaws open between its walls)
        swings the jaws into a wall a command early. With a collision model the chords
        are checked as the plan was; where they come too close to something, the route
        is timed again at each of :data:`SLOWER` of the servos' speeds in turn, its
        chords shorter and nearer the plan. The chords are held to the clearance the
        plan keeps between the poses its check looked at, not to the hair more it keeps
        at them (``allowance_m``): a pick whose plan passed within that hair of its
        object, every timing's chords did too, and the route was a fault.

        Raises:
            CollisionError: even the slowest timing's chords come too close; nothing of
                the route was sent.
        """
        assert route.plan is not None
        q_path = route.plan.q_path
        timed = self.timed(q_path, carrying=carrying)
        if self.collision is None:
            return timed
        target = route.object_id if route.step == "pick" and route.object_id else None
        contact = self.collision.first_contact(timed.q, target=target, allowance_m=TOUCH_M)
        limits = self.carry_limits if carrying else self.limits
        slowest = 1.0
        for fraction in SLOWER:
            if contact is None:
                return timed
            slowest = fraction
            slower = SpeedLimits(
                limits.velocity * fraction, limits.acceleration * fraction**2, limits.drive
            )
            timed = dataclasses.replace(
                time_path(q_path, self.chain, slower, 1.0 / self.bus.step_s),
                period_s=self.bus.period_s,
            )
            contact = self.collision.first_contact(timed.q, target=target, allowance_m=TOUCH_M)
        if contact is None:
            return timed
        chain = self.chain
        raise CollisionError(
            f"{route.step} {route.object_id}: not sent: followed command by command, even "
            f"at {slowest:g} of the servos' speeds, " + contact.describe(chain.names, chain.scale)
        )

    def joint_path(self, q_to: npt.ArrayLike) -> np.ndarray:
        """A straight line in joint space from the last confirmed pose to ``q_to``, (k, n).

        Planned in full before anything is sent (and then streamed as :meth:`timed`
        samples it): each step moves an actuated joint by at most :data:`JOINT_STEP`,
        passive joints follow their coupling, and every pose is checked against the
        limits (a straight line between two poses within box-shaped limits and a linear
        coupling stays inside them).

        Raises:
            ValueError: a pose of the path leaves the limits (a bug: both ends are
                checked poses).
        """
        chain = self.chain
        a0 = chain.actuated_of(self.q_now())
        a1 = chain.actuated_of(np.asarray(q_to, dtype=float))
        prismatic = chain.prismatic[chain.actuated_index]
        step = np.where(prismatic, JOINT_STEP[True], JOINT_STEP[False])
        k = max(1, int(np.ceil(np.max(np.abs(a1 - a0) / step))))
        path = np.array([chain.full(a0 + (a1 - a0) * t) for t in np.linspace(0, 1, k + 1)])
        for q in path:
            if not chain.within_limits(q, tol=1e-6):
                raise ValueError(f"joint path leaves the limits at {chain.named(q)}")
        return path

    def move_joints(self, q_to: npt.ArrayLike, phase: Phase, *, closed: bool) -> None:
        """Go to ``q_to`` along :meth:`joint_path`, planned and timed in full first."""
        timed = self.timed(self.joint_path(q_to), carrying=closed)
        for q in timed.q[1:]:
            self.send(q, phase, closed=closed)
        self.motion.arm_s += timed.duration_s
        self._arrive()
        self._flush_view()

    def home_pose(self, *, closed: bool = False) -> None:
        """Command the home joints and the tool's home settings (gripper open by default).

        Sent as one command: the arm is at home already (before the first move, or after
        :meth:`move_joints` home); the tool's travel to its home settings is counted in
        :attr:`motion` and, once the arm has moved, held for.
        """
        seconds = self._tool_change_s("home", closed=closed) if self.bus.state is not None else 0.0
        self.send(self.model.home, "home", closed=closed)
        if seconds > 0:
            self.bus.hold(seconds)
            self._count_tool(seconds)
        self._flush_view()

    def finish(self, route: Route, t0: float) -> Route:
        """Record where the TCP ended and how long the step took."""
        route.ee_cm = self.ee_now_cm()
        route.elapsed_s = time.perf_counter() - t0
        return route
