r"""The physical twin's servo bus: the real bus's pulses drive hobby-servo models in MuJoCo.

:class:`TwinArm` takes the same checked, whole-µs pulses a serial backend sends
(:meth:`~mearm.hardware.bus.ServoBus.move`) and runs the twin's physics
(:func:`~mearm.sim.twin.mjcf.twin_model`) for one command period per move. Each actuator —
every actuated joint and the gripper — is a :class:`~mearm.sim.twin.servo_model.ServoModel`
built from its
:class:`~mearm.sim.twin.mjcf.ServoSpec` datasheet facts and its pulse calibration
(:mod:`mearm.sim.twin.servo_model`):

1. **quantisation** — the pulse p is mapped back through the actuator's calibration,
   :math:`v = (p - p_0)/(s\,k)`, so the bus's 1 µs step is the finest command there is;
   v is the servo's value: its joint's, or for a servo that turns a combination of
   joints (the MeArm's elbow servo: shoulder + elbow) that combination, which the MJCF's
   actuator drives through a fixed tendon (:mod:`mearm.sim.twin.mjcf`);
2. **dead band** — a servo ignores a target within ``deadband_us`` / ``us_per_unit`` of
   where its potentiometer (the joint's measured position, or the combination of the
   joints it turns; the jaws' opening) says it is, and keeps driving to the target it
   last accepted;
3. **speed limit** — the motor's setpoint :math:`x` moves toward the accepted target at
   most at the no-load speed, :math:`|\dot x| \le \omega_0` (``speed_rad_s``; a
   prismatic joint and the jaws' opening turn it into a linear speed through
   :data:`~mearm.sim.twin.mjcf.SERVO_LEVER_M`), updated at every physics step;
4. **backlash** — the setpoint the joint sees, :math:`y` (the actuator's ``ctrl``), follows
   :math:`x` through a play of width :math:`b`: :math:`y \leftarrow \mathrm{clip}(y,\;
   x - b/2,\; x + b/2)`, so it lags by up to b/2 after a reversal
   (:data:`BACKLASH_DEG`);
5. **torque limit** — the actuator's ``forcerange`` (the stall torque) in the MJCF; the
   jaws stop on an object they close on (contact), their servo pushing at its limit.

The servo's own position loop (its gain, damping, the motor's back-EMF) is the MJCF's
position actuator. What is left out: the amplifier switching off inside the dead band
while holding (the twin's servo stiffly holds its accepted target instead), the
``error_model``'s offsets and noise (the twin's errors are its physics), ``Servo.write``'s
whole-degree quantisation, and the tool actuators (the paper's ``gripper_arm``), which the
MJCF has no joint for: their pulses are checked by the base class and not simulated.

**What is not stepped.** Steps 3 and 4 are computed for a whole run of steps at once
(:func:`~mearm.sim.twin.servo_model.ramp`, equal to the step-by-step model to the bit),
so Python runs once per run, not at every step. MuJoCo puts bodies at rest to sleep (the
twin's model enables it, :mod:`mearm.sim.twin.mjcf`): objects lying still, and the arm
holding still between commands. A sleeping body is exactly where it was; contact wakes
it, and the twin keeps the arm awake while its setpoints move (a nil applied force,
:data:`_NUDGE`: jaws pressed on an object do not move until the opening command passes
where they are, and must not sleep meanwhile). While everything sleeps, a hold only
advances the time (:meth:`TwinArm._hold_steps`).

The sim does not wait for the wall clock unless ``servo.sim_realtime`` is set; then its
moves, holds and waits for arrival each take their time on it.
"""

from __future__ import annotations

import copy
import logging
import math
import time
from collections.abc import Iterable
from dataclasses import dataclass

import mujoco
import numpy as np

from mearm.config import Config
from mearm.config.servo_file import replaced_calibration
from mearm.config.twin_faults_config import LimpServo
from mearm.hardware.bus import ArmCommand, ServoBus
from mearm.hardware.errors import ServoError, ServoStallError
from mearm.kinematics.bodies import TableContents, object_name, object_of, wall_height_m
from mearm.kinematics.chain import Chain
from mearm.kinematics.mjspec import yaw_quat
from mearm.kinematics.urdf import TCP_FRAME, jaw_joint_names
from mearm.sim.belt import Arrival, belt_arrivals
from mearm.sim.errors import WorldError
from mearm.sim.twin.mjcf import M_PER_CM, ServoSpec, arrival_centre_m, object_ids, twin_model
from mearm.sim.twin.servo_kit import ServoUnit
from mearm.sim.twin.servo_model import (  # noqa: F401  (the servo model, re-exported)
    BACKLASH_DEG,
    ServoModel,
    _catalogued,
    _joint_servo,
    kit_servos,
    ramp,
    servo_models,
)
from mearm.sim.twin.servo_model import calibrated_kit as _calibrated_kit  # noqa: F401
from mearm.sim.twin.servo_model import servo_models as _servo_models  # noqa: F401
from mearm.sim.twin.servo_model import with_kit as _with_kit  # noqa: F401
from mearm.sim.twin.twin_faults import FaultSchedule

log = logging.getLogger(__name__)

#: An object is at rest when its centre moves slower than this [m/s].
REST_SPEED_M_S = 1e-3
#: A joint servo has arrived when its potentiometer is within this of the command, in
#: turns of its shaft (1° is 10 µs of pulse on a nominal hobby servo) [deg].
ARRIVED_SHAFT_DEG = 1.0
#: A joint servo whose motor has reached the command and whose joint moves less than this
#: in one command period is at rest [deg of shaft]; at rest farther than
#: :data:`STALLED_SHAFT_DEG` from the command it has stalled.
AT_REST_SHAFT_DEG = 0.02
#: How far short of the command a joint servo at rest has stalled [deg of shaft].
STALLED_SHAFT_DEG = 5.0
#: An object touches a jaw when one of its geoms is within this of one of the jaw's
#: [m] (a gripped object's pads sink into it: their distance is below zero).
JAW_TOUCH_M = 5e-4
#: Steps between checks whether every body sleeps while the setpoints hold (then the
#: rest of the hold is only time passing; :meth:`TwinArm._hold_steps`).
SLEEP_CHECK_STEPS = 10
#: A force on the arm's first joint that changes nothing but keeps the arm awake (MuJoCo
#: wakes, and does not put to sleep, a tree with any force applied) [N·m or N].
_NUDGE = 1e-300
#: The physics warnings that mean the twin diverged (MuJoCo resets the data on them).
_DIVERGED = (
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQACC,
)


def _body_geoms(model: mujoco.MjModel, body: int) -> list[int]:
    """The ids of a body's geoms."""
    first = int(model.body_geomadr[body])
    return list(range(first, first + int(model.body_geomnum[body])))


def _mujoco_warning(text: str) -> None:
    """MuJoCo's warnings go to this module's logger, not to MUJOCO_LOG.TXT in the cwd."""
    log.warning("MuJoCo: %s", text)


mujoco.set_mju_user_warning(_mujoco_warning)


@dataclass(frozen=True)
class ObjectPose:
    """Where a scene object is in the twin.

    Attributes:
        object_id: Its id (``red1``, …).
        position_cm: Its body's centre in the base frame [cm], (3,).
        quat: Its orientation (w, x, y, z) [-], (4,).
        speed_cm_s: Its centre's speed [cm/s].
    """

    object_id: str
    position_cm: np.ndarray
    quat: np.ndarray
    speed_cm_s: float


class TwinArm(ServoBus):
    """The servo bus of the MuJoCo twin: pulses in, physics out.

    Args:
        config: The whole configuration.
        model: The twin's model (:func:`~mearm.sim.twin.mjcf.twin_model` of ``config``);
            built if omitted.
        servo: The joints' servo; ``None`` takes the one the model records
            (:data:`~mearm.sim.twin.mjcf.JOINT_SERVO_TEXT`), looked up in
            :data:`~mearm.sim.twin.mjcf.SERVO_CATALOGUE`; for a model that records none, the
            first catalogue servo with its actuator's stall torque and speed.
        gripper_servo: The gripper's servo; ``None`` takes the one the model records
            (:data:`~mearm.sim.twin.mjcf.GRIPPER_SERVO_TEXT`), else
            :data:`~mearm.sim.twin.mjcf.GRIPPER_SERVO`.
        backlash_deg: Each servo's gear play [deg] (:data:`BACKLASH_DEG`), for a twin
            without a kit.
        kit: One :class:`~mearm.sim.twin.servo_kit.ServoUnit` per servo (joints in chain
            order, then the gripper): each servo's own zero, scale, backlash and dead band.
            ``None`` draws the kit ``config.twin.kit`` asks for (its seed; with
            ``per_trial`` mixed with ``servo.error_model.seed``, which ``mearm experiment``
            sets to each trial's seed), or with no ``twin.kit`` gives every servo the
            datasheet's nominal one.

    Attributes:
        model: The MuJoCo model.
        data: Its state, starting at the ``home`` keyframe.
        servos: Each actuator's :class:`ServoModel`, joints in chain order then the gripper.
        kit: The servos' units, or ``None`` (every servo nominal).
        faults: The faults ``config.twin.faults`` injects, each struck once as the
            simulated time passes it (:mod:`mearm.sim.twin.twin_faults`).

    Raises:
        ModelError: the model lacks an actuator or joint of ``config``'s arm, or it
            records a servo the catalogue lacks (or, recording none, its joints' servos
            match no catalogue servo) and ``servo``/``gripper_servo`` is not given; or
            ``kit`` has not one unit per servo.
        WorldError: a ``twin.faults`` entry knocks an object the scene does not have.
    """

    def __init__(
        self,
        config: Config,
        model: mujoco.MjModel | None = None,
        *,
        servo: ServoSpec | None = None,
        gripper_servo: ServoSpec | None = None,
        backlash_deg: float = BACKLASH_DEG,
        kit: tuple[ServoUnit, ...] | None = None,
    ):
        super().__init__(config.arm, config.servo, paced=config.servo.sim_realtime)
        self.config = config
        if model is None:  # with a kit, its physics as without the calibration file
            physical = replaced_calibration(config) if kit or config.twin.kit else None
            model = twin_model(physical or config, servo, gripper_servo)
        if any(f.kind == "limp_servo" for f in config.twin.faults):
            model = copy.copy(model)  # the fault changes its actuator: not the caller's model
        self.model = model
        self.data = mujoco.MjData(model)
        self._chain = Chain.from_description(config.arm)
        self.servos = servo_models(model, config, self._chain, servo, gripper_servo, backlash_deg)
        self.servos, self.kit = kit_servos(self.servos, config, kit)
        nu = len(self.servos)
        self._ctrl = np.array([s.ctrl_index for s in self.servos])
        self._speed = np.array([s.speed for s in self.servos])
        self._half_play = np.array([s.backlash / 2 for s in self.servos])
        self._deadband = np.array([s.deadband for s in self.servos])
        self._pot = np.zeros((nu, model.nq))  # (nu, nq)
        for k, s in enumerate(self.servos):
            self._pot[k, list(s.pot_qpos)] = s.pot_coef or 1.0
        self._joint_qpos = {
            name: (int(model.joint(name).qposadr[0]), float(self._chain.scale[i]))
            for name, i in zip(self._chain.actuated, self._chain.actuated_index, strict=True)
        }
        self._arrivals = belt_arrivals(config)
        self._object_ids = object_ids(config) + [a.id for a in self._arrivals]
        #: Each object's class, by its id.
        self._object_classes = dict(
            zip(
                self._object_ids,
                [o.color for o in config.task.scene] + [a.color for a in self._arrivals],
                strict=True,
            )
        )
        table = TableContents.of(config.task, config.belt)
        #: Each bin's walls' top above the table [m], as the scene builds them.
        self._bin_tops_m = {c.name: wall_height_m(c, table.objects(c.name)) for c in table.classes}
        self.faults = FaultSchedule(config.twin.faults, self._object_ids)
        self._jaw_geoms = [
            _body_geoms(model, model.jnt_bodyid[model.joint(j).id])
            for j in jaw_joint_names(config.arm)
        ]
        self._object_geoms = {
            oid: _body_geoms(model, model.body(object_name(oid)).id) for oid in self._object_ids
        }
        self._arm_body = model.body(f"link_{config.arm.joints[0].name}").id
        self._arm_dof = int(model.body_dofadr[self._arm_body])
        self.reset()

    # ----------------------------------------------------------------- state

    def reset(self) -> None:
        """Back to the ``home`` keyframe: arm at home, jaws open, objects on the table.

        The belt's objects wait off the table again, to arrive at their times.
        """
        self._to_arrive = list(self._arrivals)
        mujoco.mj_resetDataKeyframe(self.model, self.data, self.model.key("home").id)
        mujoco.mj_forward(self.model, self.data)
        ctrl = self.data.ctrl[self._ctrl].copy()
        self._target = ctrl.copy()  # accepted targets [rad or m], (nu,)
        self._motor = ctrl.copy()  # motor setpoints x, (nu,)
        self._setpoint = ctrl.copy()  # joint setpoints y (ctrl), (nu,)

    @property
    def object_ids(self) -> tuple[str, ...]:
        """The scene objects' ids (``red1``, …), in scene order."""
        return tuple(self._object_ids)

    @property
    def time_s(self) -> float:
        """Simulated time since the keyframe [s]."""
        return float(self.data.time)

    @property
    def clock_s(self) -> float:
        """The bus's clock: the physics' time [s] (a sampler samples within the physics)."""
        return float(self.data.time)

    @property
    def ee_cm(self) -> np.ndarray:
        """The TCP (the ``tcp`` site) in the base frame [cm], (3,)."""
        return self.data.site(TCP_FRAME).xpos / M_PER_CM

    @property
    def pot(self) -> np.ndarray:
        """Each servo's potentiometer reading [rad or m], (nu,)."""
        return self._pot @ self.data.qpos

    @property
    def actual_joints(self) -> dict[str, float]:
        """Measured actuated joints, name → deg or cm.

        The joints themselves, whatever combination their servos turn.
        """
        q = self.data.qpos
        return {name: float(q[adr] / scale) for name, (adr, scale) in self._joint_qpos.items()}

    @property
    def opening_cm(self) -> float:
        """Measured jaw opening [cm]."""
        return float(self.pot[-1] / M_PER_CM)

    @property
    def setpoint(self) -> np.ndarray:
        """Each actuator's ``ctrl``: the setpoint after speed limit and backlash, (nu,)."""
        return self._setpoint.copy()

    def object_pose(self, object_id: str) -> ObjectPose:
        """Where an object is.

        Raises:
            WorldError: no object has that id; the message lists them.
        """
        if object_id not in self._object_ids:
            raise WorldError(
                f"no object {object_id!r} in the twin; its objects: {', '.join(self._object_ids)}"
            )
        body = self.data.body(object_name(object_id))
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_BODY, body.id, vel, 0)
        return ObjectPose(
            object_id,
            body.xpos / M_PER_CM,
            body.xquat.copy(),
            float(np.linalg.norm(vel[3:]) / M_PER_CM),
        )

    def objects_in_bin(self) -> dict[str, str]:
        """Objects held by a bin: id → the bin's class name.

        Held: the body's centre lies in the bin in the plane (its class's rule,
        :meth:`~mearm.config.ColorClass.in_bin`) and below the walls' top, and it moves too
        slowly to rise over them (``v² < 2·g·(top − z)``): at rest, or settling on others
        in the bin (a leaning object may creep for seconds), but not one still flying
        through.
        """
        out = {}
        g = float(np.linalg.norm(self.model.opt.gravity))
        for oid in self._object_ids:
            pose = self.object_pose(oid)
            v = pose.speed_cm_s * M_PER_CM
            x_cm, y_cm, z_cm = (float(c) for c in pose.position_cm)
            z = z_cm * M_PER_CM
            for cls in self.config.task.classes:
                top = self._bin_tops_m[cls.name]
                if cls.in_bin(x_cm, y_cm) and z < top and v * v < 2.0 * g * (top - z):
                    out[oid] = cls.name
        return out

    def held_classes(self) -> frozenset[str]:
        """The classes of what the jaws bring to a bin now (empty: nothing).

        What they hold: the objects touching either jaw, one of its geoms within
        :data:`JAW_TOUCH_M` of one of the jaw's (:func:`mujoco.mj_geomDistance`; two objects
        gripped side by side each touch one jaw). And what they just let fall into a bin:
        an object still moving (faster than :data:`REST_SPEED_M_S`) that its own class's
        bin holds (:meth:`objects_in_bin`: inside the walls, too slow to rise over them),
        one that slipped out as the arm stopped over it. Being over the bin in the plane
        is not enough: a 1 cm disc flung out as the arm stopped was over the blue bin at
        1 m/s, 5 cm above its walls, and flew on past them to the table. One still above
        the walls is read once the jaws have opened, where it landed
        (:func:`~mearm.task.pick_place.place_failure`). The place reads this over the bin
        before the jaws open (:class:`~mearm.hardware.bus.ReportsHold`).
        """
        in_bin = self.objects_in_bin()
        held = set()
        for oid in self._object_geoms:
            name = self._object_classes[oid]
            if name in held:
                continue
            if self._touches_a_jaw(oid):
                held.add(name)
                continue
            moving = self.object_pose(oid).speed_cm_s * M_PER_CM > REST_SPEED_M_S
            if moving and in_bin.get(oid) == name:
                held.add(name)
        return frozenset(held)

    def held_ids(self) -> frozenset[str]:
        """The objects touching either jaw now (:meth:`held_classes`' first rule)."""
        return frozenset(oid for oid in self._object_geoms if self._touches_a_jaw(oid))

    def _touches_a_jaw(self, object_id: str) -> bool:
        """Whether one of the object's geoms is within :data:`JAW_TOUCH_M` of a jaw's."""
        m, d = self.model, self.data
        fromto = np.zeros(6)
        return any(
            mujoco.mj_geomDistance(m, d, g, j, 2 * JAW_TOUCH_M, fromto) <= JAW_TOUCH_M
            for jaw in self._jaw_geoms
            for j in jaw
            for g in self._object_geoms[object_id]
        )

    def where(self, object_id: str) -> str:
        """Where an object is now, as the end of a sentence: in which bin, or on the table.

        On the table its place is given, ``still moving`` when it has not come to rest.
        Past the table's drawn edge it is said to be there: the twin's table is a plane
        that goes on (``_table`` in :mod:`~mearm.sim.twin.twin_scene`), where a real table
        would have let it fall (a disc flung out of the jaws rolled 80 cm, simulated).

        Raises:
            WorldError: no object has that id.
        """
        pose = self.object_pose(object_id)
        bin_name = self.objects_in_bin().get(object_id)
        if bin_name is not None:
            return f"fell into the {bin_name} bin"
        x, y, z = (float(c) for c in pose.position_cm)
        moving = ", still moving" if pose.speed_cm_s * M_PER_CM > REST_SPEED_M_S else ""
        over = next((c.name for c in self.config.task.classes if c.in_bin(x, y)), None)
        if over is not None:  # not held: above the walls' top (a stack taller than they)
            top_cm = self._bin_tops_m[over] / M_PER_CM
            return (
                f"is over the {over} bin, above its {top_cm:.1f} cm walls, at ({x:.1f}, "
                f"{y:.1f}, {z:.1f}) cm{moving}"
            )
        lo, hi = self._table_cm
        if lo[0] <= x <= hi[0] and lo[1] <= y <= hi[1]:
            return f"is on the table at ({x:.1f}, {y:.1f}) cm{moving}"
        return f"is past the table's edge, at ({x:.1f}, {y:.1f}) cm{moving}"

    @property
    def _table_cm(self) -> tuple[np.ndarray, np.ndarray]:
        """The table's drawn corners (x, y) [cm], least and greatest; unbounded without one."""
        try:
            g = self.model.geom("table")
        except KeyError:
            return np.full(2, -np.inf), np.full(2, np.inf)
        centre, half = self.model.geom_pos[g.id][:2], g.size[:2]
        return (centre - half) / M_PER_CM, (centre + half) / M_PER_CM

    def astray(self, class_name: str) -> list[str]:
        """Where each object of the class is that no bin of its class holds (:meth:`where`).

        ``red3 is on the table at (8.1, 15.2) cm``: said of a place the sort took as
        done whose object the bin does not hold (not confirmed in its bin).
        """
        held = self.objects_in_bin()
        return [
            f"{oid} {self.where(oid)}"
            for oid in self._object_ids
            if self._object_classes[oid] == class_name and held.get(oid) != class_name
        ]

    def in_own_bin(self, object_id: str) -> str | None:
        """The object's class when a bin of its class holds it (:meth:`objects_in_bin`).

        ``None``: no bin holds it, or another class's does. Read for a place whose jaws
        came to the bin empty: an object that slipped out on the way into its own bin is
        sorted, as :meth:`in_bin_counts` counts it.

        Raises:
            WorldError: no object has that id; the message lists them.
        """
        self.object_pose(object_id)  # (an unknown id is refused there)
        name = self._object_classes[object_id]
        return name if self.objects_in_bin().get(object_id) == name else None

    def in_bin_counts(self) -> dict[str, int]:
        """How many objects of each class a bin of their own class holds (:meth:`objects_in_bin`).

        An object in another class's bin is in none of the counts: it was sorted wrong.
        """
        counts = dict.fromkeys(self.config.task.class_names, 0)
        for oid, name in self.objects_in_bin().items():
            if self._object_classes[oid] == name:
                counts[name] += 1
        return counts

    # ----------------------------------------------------------------- physics

    def _hold(self, seconds: float) -> None:
        """The bus's ``hold``: the physics runs on with the last command (a gripper closing).

        A paced bus (``servo.sim_realtime``) then waits out the rest of the hold on the
        wall clock, as the kinematic sim and a real link do: the gripper's settings are
        most of a sort's motion, and a paced twin ran them at the physics' speed.
        """
        start = time.monotonic()
        self._run(seconds)
        if self.paced:
            time.sleep(max(0.0, seconds - (time.monotonic() - start)))

    def settle(self, seconds: float) -> None:
        """Run the physics for ``seconds`` with no new command (the servos keep driving)."""
        self._run(seconds)

    def settle_objects(
        self, max_s: float = 2.0, step_s: float = 0.05, object_ids: Iterable[str] | None = None
    ) -> bool:
        """Run the physics until every object is at rest, for at most ``max_s`` seconds.

        A dropped object bounces and slides for a moment before it rests in its bin; a
        count taken while it moves would miss it. ``object_ids``: only those need come to
        rest (a place's released object; others, a belt's, may move on); ``None``: all.

        Returns:
            Whether those objects came to rest in time.
        """
        ids = self._object_ids if object_ids is None else tuple(object_ids)
        waited = 0.0
        while True:
            speeds = [self.object_pose(oid).speed_cm_s * M_PER_CM for oid in ids]
            if all(v < REST_SPEED_M_S for v in speeds):
                return True
            if waited >= max_s:
                return False
            self._run(step_s)
            waited += step_s

    def _run(self, seconds: float) -> None:
        """Run the physics ``seconds`` on: faults strike and belt objects land at their times."""
        end = self.time_s + seconds
        events = False
        while True:
            fault_s = self.faults.next_arm_fault_s()
            fault_s = fault_s if fault_s is not None and fault_s < end else None
            land_s = self._to_arrive[0].t_s if self._to_arrive else None
            land_s = land_s if land_s is not None and land_s <= end else None
            if fault_s is None and land_s is None:
                break
            events = True
            if land_s is not None and (fault_s is None or land_s <= fault_s):
                arrival = self._to_arrive.pop(0)
                self._physics(arrival.t_s - self.time_s)
                self._land(arrival)
            else:
                assert fault_s is not None
                self._physics(fault_s - self.time_s)
                self.faults.strike_arm(self.model, self.data)
        # without events, exactly ``seconds`` (the steps a run without faults or a belt takes)
        self._physics(end - self.time_s if events else seconds)

    def _land(self, arrival: Arrival) -> None:
        """Put an object the belt brings on its upstream end, at rest and awake."""
        m, d = self.model, self.data
        joint = m.joint(object_name(arrival.id))
        q, v = int(joint.qposadr[0]), int(joint.dofadr[0])
        yaw = math.radians(arrival.yaw_deg)
        d.qpos[q : q + 7] = [*arrival_centre_m(self.config, arrival), *yaw_quat(yaw)]
        d.qvel[v : v + 6] = 0.0
        d.qfrc_applied[v] = _NUDGE  # wakes its tree (MuJoCo keeps a pushed tree awake)
        mujoco.mj_forward(m, d)
        d.qfrc_applied[v] = 0.0
        log.info("belt: %s arrives at t = %.2f s", arrival.id, d.time)

    def _physics(self, seconds: float) -> None:
        """Run the physics ``seconds`` on: the servos' setpoints ramp, then hold."""
        m, d = self.model, self.data
        n = max(0, round(seconds / m.opt.timestep))
        before = [d.warning[w].number for w in _DIVERGED]
        t0 = d.time  # MuJoCo resets the time with the rest of the state on divergence
        if not np.array_equal(self._motor, self._target) or not np.array_equal(
            d.ctrl[self._ctrl], self._setpoint
        ):
            self._wake()
        while n > 0:
            if np.array_equal(self._motor, self._target):
                d.ctrl[self._ctrl] = self._setpoint
                self._hold_steps(n)
                break
            ramp = self._ramp(n)
            # a setpoint that moves may not yet move a joint (jaws pressed on an object
            # until the command passes where they are): the arm must not sleep meanwhile
            d.qfrc_applied[self._arm_dof] = _NUDGE
            try:
                for setpoint in ramp:
                    d.ctrl[self._ctrl] = setpoint
                    mujoco.mj_step(m, d)
                    if self.sampler is not None and d.time >= self.sampler.due_s - 1e-9:
                        self.sampler.sample(self)
            finally:
                d.qfrc_applied[self._arm_dof] = 0.0
            n -= len(ramp)
        if [d.warning[w].number for w in _DIVERGED] != before or not np.all(np.isfinite(d.qpos)):
            raise ServoError(
                f"the twin's physics diverged within {seconds:.3f} s of t = {t0:.3f} s "
                "(MuJoCo reset its state); rebuild the TwinArm",
                last_state=self.state,
            )

    def _hold_steps(self, n: int) -> None:
        """``n`` steps with the setpoints held: once every body sleeps, only time passes.

        MuJoCo keeps a sleeping body exactly where it is, so a step of a scene where every
        body sleeps and nothing pushes one changes nothing but the time; it is skipped.
        Checked every :data:`SLEEP_CHECK_STEPS` steps.
        """
        m, d = self.model, self.data
        stepped = 0  # since the last check: a sampler's stops leave the checks where they were
        while n > 0:
            if stepped == 0 and self._frozen():
                d.time += n * m.opt.timestep
                self._sample()
                return
            k = min(n, SLEEP_CHECK_STEPS - stepped)
            if self.sampler is not None and math.isfinite(self.sampler.due_s):
                # stop where the next frame is due
                due = math.ceil((self.sampler.due_s - d.time) / m.opt.timestep - 1e-6)
                k = max(1, min(k, due))
            mujoco.mj_step(m, d, nstep=k)
            n -= k
            stepped = (stepped + k) % SLEEP_CHECK_STEPS
            self._sample()

    def _frozen(self) -> bool:
        """Whether every body sleeps and nothing pushes one: a step would only add dt."""
        d = self.data
        return d.nv_awake == 0 and not d.qfrc_applied.any() and not d.xfrc_applied.any()

    def _wake(self) -> None:
        """Wake the arm if it sleeps: a new command moves it (MuJoCo wakes it on contact)."""
        d = self.data
        tree = self.model.body_treeid[self._arm_body]
        if d.tree_asleep[tree] >= 0:
            d.qfrc_applied[self._arm_dof] = _NUDGE
            mujoco.mj_forward(self.model, d)
            d.qfrc_applied[self._arm_dof] = 0.0

    def _ramp(self, n: int) -> np.ndarray:
        """The joints' setpoints y for the next steps while the motors move, ``(k, nu)``.

        :func:`~mearm.sim.twin.servo_model.ramp`: at most ``n`` steps, and at least one;
        leaves x and y where the last step puts them.
        """
        step = self._speed * self.model.opt.timestep
        motor, setpoint = ramp(self._motor, self._setpoint, self._target, step, self._half_play, n)
        self._motor, self._setpoint = motor[-1], setpoint[-1]
        return setpoint

    def _await_arrival(self, timeout_s: float) -> float:
        """Run on with the last command until every joint servo has arrived.

        Arrived: its potentiometer within :data:`ARRIVED_SHAFT_DEG` of the accepted
        target, or at rest (its motor at the target, the joint moving less than
        :data:`AT_REST_SHAFT_DEG` in a period) within :data:`STALLED_SHAFT_DEG` of it, a
        load the servo holds with a small error. The gripper is not waited for: jaws
        closing on an object stop short by design (the tool's hold covers them).

        Raises:
            ServoStallError: a joint at rest farther than :data:`STALLED_SHAFT_DEG`, or
                not arrived after ``timeout_s``.
        """
        joints = slice(0, len(self.servos) - 1)
        shaft = np.array([s.shaft_unit for s in self.servos[joints]])
        waited, before = 0.0, self.pot[joints]
        while True:
            pot = self.pot[joints]
            error = np.abs(self._target[joints] - pot) / shaft
            resting = (self._motor[joints] == self._target[joints]) & (
                np.abs(pot - before) / shaft < AT_REST_SHAFT_DEG
            )
            if waited > 0 and np.any(resting & (error > STALLED_SHAFT_DEG)):
                k = int(np.argmax(np.where(resting, error, -1.0)))
                raise self._stall(k, "stalled", "stalled: at rest short of its command")
            if np.all((error <= ARRIVED_SHAFT_DEG) | (resting & (waited > 0))):
                return waited
            if waited >= timeout_s:
                k = int(np.argmax(error))
                raise self._stall(k, "timeout", f"did not arrive within {timeout_s:.2f} s")
            before = pot
            if self.paced:  # each period of the wait on the wall clock too, as a move's
                self._rate.wait(self.period_s)
            self._run(self.period_s)
            waited += self.period_s

    def _stall(self, k: int, reason: str, detail: str) -> ServoStallError:
        servo = self.servos[k]
        if servo.amap.combined:  # the values are its servo's: say what that turns
            detail += f" ({servo.amap.servo_text})"
        limp = [f for f in self.faults.struck if isinstance(f, LimpServo)]
        if limp:  # the cause, not what the limp arm sank onto (the table, a bin's wall)
            detail += ", in the twin " + ", ".join(
                f"the {f.joint} servo went limp at t = {f.at_s:.3f} s (twin.faults)" for f in limp
            )
        elif (pressed := self._pressed_on()) is not None:  # what only a simulator can say
            detail += f", {pressed}"
        return ServoStallError(
            servo.name,
            servo.value_of(float(self._target[k])),
            servo.value_of(float(self.pot[k])),
            reason,
            detail,
            last_state=self.state,
        )

    def _pressed_on(self) -> str | None:
        """What the arm presses on hardest now, or ``None``.

        ``"in the twin its gripper_jaw_left_pad presses on bin_blue_wall_px"``: geoms as the
        MJCF names them, an object by its id. The jaws on the objects they hold do not count:
        closed, the objects they touch. Open jaws hold nothing: one they touch is pressed on
        (a jaw come down on the rim of a disc too wide for the error the arm lands with:
        ``sim_mearm_v1_mujoco --random 5 --seed 35028 --set
        task.classes.blue.diameter_cm=2.44``, the stall had named nothing).
        """
        m, d = self.model, self.data
        tree = m.body_treeid[self._arm_body]
        state = self.state
        closed = state is not None and state.gripper_closed
        held = {object_name(oid) for oid in self.held_ids()} if closed else set()
        force = np.zeros(6)
        hardest: tuple[float, int, int] | None = None
        for i in range(d.ncon):
            contact = d.contact[i]
            g1, g2 = int(contact.geom1), int(contact.geom2)
            on1, on2 = (m.body_treeid[m.geom_bodyid[g]] == tree for g in (g1, g2))
            if on1 == on2:
                continue
            arm, other = (g1, g2) if on1 else (g2, g1)
            body = m.body(int(m.geom_bodyid[other])).name
            if body in held:
                continue
            mujoco.mj_contactForce(m, d, i, force)
            if hardest is None or force[0] > hardest[0]:
                hardest = (float(force[0]), arm, other)
        if hardest is None:
            return None
        _, arm, other = hardest
        body = m.body(int(m.geom_bodyid[other])).name
        what = object_of(body) or m.geom(other).name or body
        return f"in the twin its {m.geom(arm).name} presses on {what}"

    # ----------------------------------------------------------------- backend hooks

    def _connect(self) -> None:
        log.info(
            "twin arm: %d servos, %d objects, timestep %g s",
            len(self.servos),
            len(self._object_ids),
            self.model.opt.timestep,
        )

    def _send_move(self, command: ArmCommand, pulses_us: dict[int, int]) -> None:
        target = np.array([s.target_of(pulses_us[s.amap.channel]) for s in self.servos])
        accept = np.abs(target - self.pot) > self._deadband
        self._target = np.where(accept, target, self._target)
        self._run(self.period_s)

    def _stop(self) -> None:
        """Hold: the accepted targets become the motors' current setpoints; nothing moves on."""
        self._target = self._motor.copy()

    def _close(self) -> None:
        """The run is over: say the ``twin.faults`` that never struck (nothing to release)."""
        self.faults.never_struck(self.time_s)
