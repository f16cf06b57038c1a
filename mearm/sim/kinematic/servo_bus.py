"""The simulated servo bus: a backend that moves a model arm over a :class:`World`.

Each move realises the command per actuated joint the way a real servo would miss it
(paper §5, ``servo.error_model``):

1. quantisation of each joint servo's value (the joint's, or the combination it turns:
   the MeArm's elbow servo turns shoulder + elbow) — ``microsecond``: the integer-µs
   pulse the serial backends send; ``degree``: the whole servo degree of ``Servo.write``
   (its 0–180° scale spans the channel's [min_us, max_us]; Arduino's integer ``map()``
   gives the pulse); ``none``;
2. the pulses are mapped back to the joints through the servos' calibrations
   (:meth:`~mearm.hardware.ServoMap.realised`);
3. a static offset per joint (``offset_deg``, by name) and per-move Gaussian noise are
   added; noise that would put the tool into the table, where the offset alone keeps it
   above, leaves it resting on the table instead (the table holds a servo that errs
   down: its jaws press on it, they do not pass through it; the paper arm's jaws, 1.1 cm
   above the table at a pick, met it in 10 of 100 trials with the paper's 0.55°);
4. a joint sent past its limits stops at them, as the twin's joints do
   (:func:`~mearm.sim.kinematic.joint_stops.joints_at_stops`).

The TCP is the forward kinematics of the realised joints (passive joints from their
couplings). Closing the gripper grips the table object nearest the TCP if it lies within
``servo.grip_tolerance_cm`` in the plane and the TCP's height is within that tolerance of
the object class's grip height plus ``tool.tcp_above_grip_cm``; otherwise the pick fails
and the object stays, pushed aside where the closing jaws would end inside it (and on,
where the closed jaws move into it before they open again): jaws do not pass through
an object, and an object they never closed on is still a collision. Opening it drops
the held object into the nearest bin within ``servo.bin_radius_cm`` (in the plane), or,
with no bin that close, onto the table under the TCP. Tool actuators are quantised but
do not move the TCP.

The sim does not sleep unless ``servo.sim_realtime`` is set.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from mearm.config import Config
from mearm.errors import MearmError
from mearm.hardware.bus import ArmCommand, ArmState, ServoBus
from mearm.hardware.errors import ServoError
from mearm.hardware.mapping import ActuatorMap, Quantization, ServoMap
from mearm.kinematics import ArmModel, check_target, closed_form_for
from mearm.kinematics.bodies import object_of
from mearm.kinematics.collision import CollisionModel
from mearm.kinematics.errors import TargetError
from mearm.sim.errors import WorldError
from mearm.sim.kinematic.joint_stops import joints_at_stops
from mearm.sim.kinematic.world import World
from mearm.sim.table_collision import collision_model

log = logging.getLogger(__name__)

#: Random poses drawn per requested pose before :func:`random_reachable_joints` gives up.
_DRAWS_PER_POSE = 10_000


#: A tool the table holds up rests this far above it [cm]: touching, as the move's check
#: counts contact, would be a fault.
RESTING_CM = 0.01
#: Jaws that close beside an object, or on its edge, push it out of their way this far at
#: a time [cm], and no farther in all than :data:`PUSH_MOST_CM`.
PUSH_STEP_CM = 0.05
PUSH_MOST_CM = 5.0


class SimCollisionError(ServoError):
    """The simulated arm's body ran into the table, a bin or an object.

    The kinematic simulator checks every move against the same collision model the
    planner does (:mod:`mearm.kinematics.collision`), so a route the planner let through
    a wall is a fault there, as it would be in physics.
    """


def quantize_deg(amap: ActuatorMap, value: float, mode: Quantization) -> float:
    """The value a servo realises for a commanded one after command quantisation.

    Args:
        amap: The actuator's channel mapping.
        value: Commanded value [deg, or cm], within the actuator's limits.
        mode: ``none``, ``microsecond`` (integer-µs pulse) or ``degree`` (``Servo.write``).
    """
    return amap.realised(value, mode)


@dataclass(frozen=True)
class GripResult:
    """What closing the gripper did.

    Attributes:
        success: Whether an object was gripped.
        object_id: The nearest table object (gripped or not), or ``None`` if the table is empty.
        distance_cm: TCP to that object in the plane [cm] (∞ if the table is empty).
        dz_cm: TCP height minus the height it grips that object at [cm] (NaN if empty).
    """

    success: bool
    object_id: str | None
    distance_cm: float
    dz_cm: float


@dataclass(frozen=True)
class ReleaseResult:
    """What opening the gripper with an object did.

    Attributes:
        object_id: The released object.
        bin: The class name of the bin it fell into, or ``None`` if it landed on the table.
        x_cm: Where it ended, x [cm].
        y_cm: Where it ended, y [cm].
    """

    object_id: str
    bin: str | None
    x_cm: float
    y_cm: float


class SimArm(ServoBus):
    """Simulated servos, arm and gripper acting on a shared :class:`World`.

    Args:
        config: The whole configuration.
        world: The table the simulated camera renders.
        model: Arm model for the TCP (built from ``config.arm`` if omitted).

    Attributes:
        world: The shared world.
        model: The arm model.
        actual_joints: Realised actuated joints, name → deg or cm; home before the first
            move.
        actual_tool: Realised tool actuators, name → deg.
        gripper_closed: Whether the gripper is closed.
        last_grip: The outcome of the last close, or ``None``.
        last_release: The outcome of the last release of an object, or ``None``.
    """

    def __init__(self, config: Config, world: World, model: ArmModel | None = None):
        super().__init__(config.arm, config.servo, paced=config.servo.sim_realtime)
        self.config = config
        self.world = world
        self.model = model if model is not None else ArmModel(config.arm)
        self.error_model = config.servo.error_model
        self._rng = np.random.default_rng(self.error_model.seed)
        self._table: CollisionModel | None = None  # the tool's height (noise meets the table)
        self.actual_joints: dict[str, float] = config.arm.home()
        #: The joints stop at the limits the arm was built with, whatever map a caller
        #: drives it by later (``calibrate-servos`` widens them to the pulses').
        self._stops = config.arm.joint_limits()
        self.actual_tool: dict[str, float] = {a.name: a.home for a in config.arm.tool.actuators}
        self.gripper_closed = False
        self.last_grip: GripResult | None = None
        self.last_release: ReleaseResult | None = None
        #: The arm's body against the world, checked on every move (built on first use).
        self._collision: CollisionModel | None = None
        #: The joints the last checked move ended at, named and in model units.
        self._last_after: tuple[dict[str, float], np.ndarray] | None = None
        self._pushed_cm: dict[str, float] = {}  # how far the arm pushed each object aside
        #: The objects closed jaws that missed pushed aside: the arm is against them until
        #: the jaws open, and pushes them on as it moves.
        self._against: set[str] = set()
        self._jaw_parts: frozenset[str] | None = None  # the jaws' shapes (built on first use)

    @property
    def ee_cm(self) -> np.ndarray:
        """The realised TCP position in the base frame [cm], (3,)."""
        return ee_from_joints_cm(self.model, self.actual_joints)

    @property
    def time_s(self) -> float:
        """The simulated time [s]: one servo period per command, plus every hold."""
        return self.world.time_s

    def realise(self, command: ArmCommand) -> dict[str, float]:
        """Realised actuated joints for a command: quantised, offset, noisy [deg or cm].

        Each servo's value is quantised and the joints solved back from those values
        (:meth:`~mearm.hardware.ServoMap.realised`): where the pulses the serial backends
        send put them, the MeArm's elbow joint included, whose servo turns shoulder +
        elbow. Where the servos send the joints, which may be past their limits:
        :meth:`actuate` stops them there. Draws the noise (one value per actuated joint,
        in chain order), so each call is one move's worth of it.
        """
        em = self.error_model
        quantised = self.servo_map.realised(command.joints, em.quantization)
        out = {n: v + em.offset_deg.get(n, 0.0) for n, v in quantised.items()}
        if em.noise_std_deg > 0:
            noise = self._rng.normal(0.0, em.noise_std_deg, size=len(out))
            noisy = {n: v + float(e) for (n, v), e in zip(out.items(), noise, strict=True)}
            out = self._on_the_table(out, noisy)
        return out

    def _on_the_table(self, steady: dict[str, float], noisy: dict[str, float]) -> dict[str, float]:
        """``noisy``, or where the way from ``steady`` to it meets the table.

        The table holds the tool up: noise that would put it below the table leaves it
        resting there (the last of 12 halvings of the way that keeps it above), when
        ``steady`` (the move without its noise) keeps it above. Anything else, a bin, an
        object, or a table ``steady`` already reaches, is the move's check's to refuse.
        """
        lowest = self._tool_lowest_cm
        if lowest(noisy) >= RESTING_CM or lowest(steady) < RESTING_CM:
            return noisy
        lo, hi = 0.0, 1.0  # the share of the noise taken: above at lo, below at hi
        for _ in range(12):
            mid = (lo + hi) / 2
            if lowest({n: v + mid * (noisy[n] - v) for n, v in steady.items()}) >= RESTING_CM:
                lo = mid
            else:
                hi = mid
        return {n: v + lo * (noisy[n] - v) for n, v in steady.items()}

    def _tool_lowest_cm(self, joints: Mapping[str, float]) -> float:
        """The tool's lowest point above the table at these actuated joints [cm]."""
        if self._table is None:
            self._table = collision_model(
                self.config, self.model, clearance_cm=0.0, bins=self.world.bins_cm
            )
        return self._table.tool_lowest_cm(self.model.chain.from_named(joints))[0]

    # ----------------------------------------------------------------- backend hooks

    def _connect(self) -> None:
        log.info(
            "sim arm: %d objects on the table, quantization %s",
            len(self.world.table_objects()),
            self.error_model.quantization,
        )

    def actuate(
        self,
        joints: Mapping[str, float],
        tool: Mapping[str, float],
        *,
        gripper_closed: bool,
        last_state: ArmState | None,
    ) -> None:
        """Put the arm where its servos are: realised values, not commands.

        A joint sent past its limits stops at them
        (:func:`~mearm.sim.kinematic.joint_stops.joints_at_stops`), whoever drives the
        arm; joints within their limits are taken as they are. Closing the gripper grips
        (or misses) the nearest object, opening it releases the held one, as a move does.
        A refused move leaves the arm where it was, its joints, its tool and its gripper:
        a fault keeps the last confirmed pose. The virtual Uno
        (:class:`~mearm.sim.virtual_uno.VirtualUnoBus`) drives the arm this way with the
        values its measured pulses stand for.

        Args:
            joints: Realised actuated joints, name → deg or cm, within the limits or
                not; joints not named stay.
            tool: Realised tool actuators, name → deg; actuators not named stay.
            gripper_closed: Whether the gripper is closed.
            last_state: The last pose the bus driving the arm confirmed: a collision's
                fault carries it. Given by the caller, as only the bus that drives the
                arm knows it: the virtual Uno's bus never moves this arm through
                :meth:`move`, so the arm's own :attr:`state` stays ``None`` there.

        Raises:
            SimCollisionError: the move runs the arm into something, or the jaws open
                into something.
            InvalidJointsError: ``joints`` names a joint the arm does not have, or a passive
                one off its coupling, or holds a value that is not a finite number.
        """
        before = self.actual_joints
        after = self._at_stops({**before, **joints})
        if after != before:
            self._check_move(before, after, last_state)
        if self.gripper_closed and not gripper_closed:
            self._check_opening(after, last_state)
        self.actual_joints = after
        self.actual_tool = {**self.actual_tool, **tool}
        if gripper_closed and not self.gripper_closed:
            self.gripper_closed = True
            self.last_grip = self._close_gripper()
            if not self.last_grip.success:
                self._push_aside(self.model.chain.from_named(after))
        elif not gripper_closed and self.gripper_closed:
            self.gripper_closed = False
            self._against.clear()
            self._open_gripper()

    def _at_stops(self, joints: dict[str, float]) -> dict[str, float]:
        """Every actuated joint where its servo leaves it, none past its limits [deg or cm].

        Values within the limits are kept bit for bit (solving a servo map that turns
        combinations back and forth would not).
        """
        stops = self._stops
        if all(stops[n].contains(v) for n, v in joints.items() if n in stops):
            return joints
        if not all(n in stops and math.isfinite(v) for n, v in joints.items()):
            return joints  # the move's check refuses the name or the value
        smap = self.servo_map
        return joints_at_stops(smap, smap.servo_values(joints), stops)

    def _check_move(
        self,
        before: Mapping[str, float],
        after: Mapping[str, float],
        last_state: ArmState | None,
    ) -> None:
        """Fault if the arm's body, moving from ``before`` to ``after``, touches anything.

        The same check as the planner's (:meth:`CollisionModel.first_contact`), against
        the world as it is: the objects on the table, the bins, the held object in the
        jaws. The jaws' pads may touch an object standing between them, and closed jaws
        push an object they missed on (:meth:`_push_aside`).

        Raises:
            SimCollisionError: they touch (the table's objects as they were); the fault
                carries ``last_state``, the last pose the driving bus confirmed.
            InvalidJointsError: ``after`` names a joint the arm does not have, or a passive
                one off its coupling, or holds a value that is not a finite number.
        """
        collision = self._world_now()
        chain = self.model.chain
        # a move starts where the last one ended: its joints as worked out then
        last = self._last_after
        start = last[1] if last is not None and last[0] == before else chain.from_named(before)
        end = chain.from_named(after)
        contact = collision.first_contact(np.array([start, end]))
        if contact is None:
            self._last_after = (dict(after), end)
            return
        # closed jaws against an object they missed (they pushed it aside) push it on
        # where they move into it: they do not pass through it; nor through a neighbour
        # their noise swings them into while they hold nothing
        kept = [(o, o.x_cm, o.y_cm) for o in self.world.table_objects()], dict(self._pushed_cm)
        while (
            contact is not None
            and self._pushes(contact.arm_part, contact.obstacle)
            and self._shove(str(object_of(contact.obstacle)), contact.q)
        ):
            contact = self._world_now().first_contact(np.array([start, end]))
        if contact is not None:  # refused: the table as it was
            for obj, x, y in kept[0]:
                obj.x_cm, obj.y_cm = x, y
            self._pushed_cm = kept[1]
            raise SimCollisionError(
                "sim: the arm ran into something: " + contact.describe(chain.names, chain.scale),
                last_state=last_state,
            )
        self._last_after = (dict(after), end)

    def _pushes(self, part: str, obstacle: str) -> bool:
        """Whether the arm's ``part``, touching ``obstacle``, pushes it along.

        An object the closed jaws are against (:meth:`_push_aside`), or any table object a
        jaw of the closed, empty jaws meets: after a miss the lift's and the next move's
        noise (each command draws its own) swings the pads sideways at the table, into a
        neighbour the plan kept its clearance from; jaws push such an object, as the
        twin's do, not pass through it (the paper arm's trials, seed 2: 2 of 100 stopped
        so). Bins, the table and the arm's other parts stay faults.
        """
        name = object_of(obstacle)
        if name is None:
            return False
        if name in self._against:
            return True
        if not self.gripper_closed or self.world.held_object() is not None:
            return False
        if self._jaw_parts is None:
            self._jaw_parts = frozenset(s.name for s in self._world_now().arm_shapes if s.jaw)
        return part in self._jaw_parts

    def _check_opening(self, joints: Mapping[str, float], last_state: ArmState | None) -> None:
        """Fault if the jaws, opening at ``joints``, touch anything (what they held falls).

        Raises:
            SimCollisionError: they touch; the fault carries ``last_state``.
        """
        collision = self._world_now()
        chain = self.model.chain
        q = chain.from_named(joints)
        contact = collision.opening_contact(q, self.config.arm.tool.gripper.open_cm)
        if contact is not None:
            raise SimCollisionError(
                "sim: the jaws opened into something: "
                + contact.describe(chain.names, chain.scale),
                last_state=last_state,
            )

    def _world_now(self) -> CollisionModel:
        """The collision model with the world as it is now.

        The table's objects, the bins, the held object in the jaws at its diameter (else
        the jaws as the gripper has them).
        """
        if self._collision is None:
            self._collision = collision_model(
                self.config, self.model, clearance_cm=0.0, bins=self.world.bins_cm
            )
        held = self.world.held_object()
        g = self.config.arm.tool.gripper
        if held is not None:
            opening = self.config.task.class_named(held.color).diameter_cm
        else:
            opening = g.closed_cm if self.gripper_closed else g.open_cm
        classes = self.config.task.class_names
        self._collision.set_world(
            [
                (o.id, o.color, o.x_cm, o.y_cm)
                for o in self.world.table_objects()
                if o.color in classes  # (another is the grip's error)
            ],
            opening_cm=opening,
            held=None if held is None else (held.id, held.color),
        )
        return self._collision

    def _send_move(self, command: ArmCommand, pulses_us: dict[int, int]) -> None:
        # A servo told to hold its value stays where it is: only a new joint command
        # draws a new error (else gripping would re-roll the pose the route ended in).
        joints = (
            self.realise(command)
            if self.state is None or self.state.joints != command.joints
            else {}
        )
        q = self.error_model.quantization
        tool = {a.name: a.realised(command.tool[a.name], q) for a in self.servo_map.tool}
        self.actuate(joints, tool, gripper_closed=command.gripper_closed, last_state=self.state)
        # the servos take the command for one period, while the table's time runs on
        self.world.advance(self.period_s)

    def _hold(self, seconds: float) -> None:
        """Time passes on the table (a belt carries its objects); a paced bus waits too."""
        self.world.advance(seconds)
        super()._hold(seconds)

    def _stop(self) -> None:
        """Moves are instantaneous in the sim: nothing is in progress to stop."""

    def _close(self) -> None:
        """Nothing to release."""

    # ----------------------------------------------------------------- gripper

    def grip_height_cm(self, class_name: str) -> float:
        """TCP height at which an object of this class is gripped [cm].

        Raises:
            WorldError: the class is not in ``task.classes``.
        """
        try:
            cls = self.config.task.class_named(class_name)
        except KeyError:
            names = ", ".join(self.config.task.class_names)
            raise WorldError(
                f"object class {class_name!r} is not in task.classes ({names})"
            ) from None
        return cls.grip_z_cm + self.config.arm.tool.tcp_above_grip_cm

    def held_classes(self) -> frozenset[str]:
        """The class of the object the gripper holds, or nothing.

        Read by the place before the jaws open (:class:`~mearm.hardware.bus.ReportsHold`):
        ``last_release`` is the last object let go, and an open with nothing held leaves it
        as it was.
        """
        obj = self.world.held_object()
        return frozenset() if obj is None else frozenset({obj.color})

    def _close_gripper(self) -> GripResult:
        x, y, z = (float(v) for v in self.ee_cm)
        obj, dist = self.world.nearest_on_table(x, y)
        if obj is None:
            log.info("sim grip: nothing on the table")
            return GripResult(success=False, object_id=None, distance_cm=math.inf, dz_cm=math.nan)
        belt = self.world.belt  # an object on the belt stands on its surface, not the table
        raised = (
            belt.config.surface_cm if belt is not None and belt.carries(obj.x_cm, obj.y_cm) else 0
        )
        dz = z - self.grip_height_cm(obj.color) - raised
        tol = self.config.servo.grip_tolerance_cm
        ok = dist <= tol and abs(dz) <= tol
        if ok:
            self.world.grip(obj)
        log.info(
            "sim grip %s: %s at %.2f cm in the plane, dz %.2f cm (tolerance %.2f cm)",
            "gripped" if ok else "missed",
            obj.id,
            dist,
            dz,
            tol,
        )
        return GripResult(ok, obj.id, float(dist), dz)

    def _push_aside(self, q: np.ndarray) -> None:
        """Push the table objects the closed jaws are in at pose ``q`` out of their way.

        Jaws do not pass through an object: closing off its middle by more than the
        grip's tolerance, on its edge or beside it, they shove it. Each object the arm
        touches is pushed (:meth:`_shove`) until it no longer does; the arm is then
        against it (:attr:`_against`) until the jaws open, and shoves it on where it moves
        into it (:meth:`_check_move`: the lift after the miss, its servos' noise moving a
        pad sideways). Bins and the table are not moved.
        """
        while True:
            ids = dict.fromkeys(object_of(b) for _, b, _ in self._world_now().touching(q))
            if not any([self._shove(i, q) for i in ids if i is not None]):
                return

    def _shove(self, object_id: str, q: np.ndarray) -> bool:
        """Move a table object :data:`PUSH_STEP_CM` in the plane away from the TCP at ``q``.

        Returns whether it moved: not when it is not on the table, or the arm has pushed
        it :data:`PUSH_MOST_CM` already.
        """
        obj = next((o for o in self.world.table_objects() if o.id == object_id), None)
        if obj is None or self._pushed_cm.get(obj.id, 0.0) >= PUSH_MOST_CM:
            return False
        x, y, _ = (float(v) for v in self.model.fk_cm(q))
        dx, dy = obj.x_cm - x, obj.y_cm - y
        norm = math.hypot(dx, dy) or 1.0
        obj.x_cm += PUSH_STEP_CM * dx / norm
        obj.y_cm += PUSH_STEP_CM * dy / norm
        if obj.id not in self._pushed_cm:
            log.info("sim: the jaws push %s aside", obj.id)
        self._pushed_cm[obj.id] = self._pushed_cm.get(obj.id, 0.0) + PUSH_STEP_CM
        self._against.add(obj.id)
        return True

    def _open_gripper(self) -> None:
        if self.world.held_object() is None:
            return
        x, y, _ = (float(v) for v in self.ee_cm)
        name, dist = self.world.nearest_bin(x, y)
        if name is not None and dist <= self.config.servo.bin_radius_cm:
            obj = self.world.release_into_bin(name)
            self.last_release = ReleaseResult(obj.id, name, obj.x_cm, obj.y_cm)
        else:
            obj = self.world.release_on_table(x, y)
            self.last_release = ReleaseResult(obj.id, None, obj.x_cm, obj.y_cm)
        log.info("sim release %s: %s", obj.id, f"bin {obj.bin}" if obj.bin else "on the table")


def ee_from_joints_cm(model: ArmModel, joints: Mapping[str, float]) -> np.ndarray:
    """TCP position [cm], (3,), of the actuated joints ``{name: deg or cm}``."""
    return model.fk_cm(model.chain.from_named(joints))


def random_reachable_joints(
    config: Config, n: int, seed: int = 0, model: ArmModel | None = None
) -> np.ndarray:
    """Actuated joints of ``n`` random poses whose TCP lies in the target box, (n, m).

    Values in deg / cm, columns in chain order (``model.chain.actuated``). With a
    registered closed form, targets are drawn uniformly in the box and solved (those out
    of reach are redrawn); without one, poses are drawn uniformly within the joint limits
    and kept when their TCP lies in the box.

    Raises:
        MearmError: the box is (almost) never reached from within the limits.
    """
    rng = np.random.default_rng(seed)
    model = model if model is not None else ArmModel(config.arm)
    chain = model.chain
    box = config.arm.target_box
    lo = np.array([box.x_cm.min, box.y_cm.min, box.z_cm.min])
    hi = np.array([box.x_cm.max, box.y_cm.max, box.z_cm.max])
    closed_form = closed_form_for(config.arm)
    out: list[np.ndarray] = []
    for _ in range(_DRAWS_PER_POSE * n):
        if len(out) == n:
            break
        if closed_form is not None:
            try:
                q = check_target(rng.uniform(lo, hi), config.arm, closed_form)
            except TargetError:
                continue
            assert q is not None
        else:
            q = chain.full(rng.uniform(chain.actuated_lower, chain.actuated_upper))
            if not chain.within_limits(q):
                continue
            tcp = model.fk_cm(q)
            if not (np.all(tcp >= lo) and np.all(tcp <= hi)):
                continue
        out.append(chain.to_config_units(q)[chain.actuated_index])
    if len(out) < n:
        raise MearmError(
            f"found {len(out)} of {n} poses with the TCP in the target box after "
            f"{_DRAWS_PER_POSE * n} draws: check arm.target_box against the joint limits"
        )
    return np.array(out)


def quantization_ee_error_cm(
    config: Config, mode: Quantization, n: int = 2000, seed: int = 0
) -> np.ndarray:
    """TCP error caused by command quantisation alone over random reachable poses [cm], (n,).

    Each pose's joint servos are quantised as the simulated arm's are
    (:meth:`~mearm.hardware.ServoMap.realised`); the error is the distance between the FK
    of the quantised and of the exact joints.
    """
    smap = ServoMap.from_arm(config.arm)
    model = ArmModel(config.arm)
    names = model.chain.actuated
    errors = np.empty(n)
    for i, values in enumerate(random_reachable_joints(config, n, seed, model)):
        exact = dict(zip(names, values.tolist(), strict=True))
        quantised = smap.realised(exact, mode)
        errors[i] = np.linalg.norm(
            ee_from_joints_cm(model, quantised) - ee_from_joints_cm(model, exact)
        )
    return errors
