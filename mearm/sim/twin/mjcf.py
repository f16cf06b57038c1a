r"""The physical twin's MuJoCo model from the config: arm, table, bins, objects, camera.

Never hand-written: :func:`twin_spec` builds it with :class:`mujoco.MjSpec` (primitive
geoms only, metres, kilograms, radians) from :class:`~mearm.config.Config` and compiles
it once; :func:`generate_mjcf` writes it as MJCF text (MuJoCo's writer: six significant
digits).

**The chain** is :func:`~mearm.kinematics.mjspec.arm_spec`'s, the one the mink
cross-check solves on: body ``link_<joint>`` per joint, placed by the fixed part of the
DH row before it exactly as in the URDF, so the twin's FK is the DH product, and a body
``tcp`` with a site ``tcp`` at the tool centre point. The gripper's two jaws (slide joints
named as in the URDF) hang from it.

**The jaws and the grip point.** The planner sends the TCP ``tcp_above_grip_cm`` above
the height where the jaws are to close (:meth:`~mearm.task.plan.Planner.pick_target`),
the tool's approach axis :math:`\hat a` pointing down when it picks from above. So the
*grip point*, where the pads close on an object, is :math:`p_{tcp} + h\,\hat a` with
:math:`h` = ``tcp_above_grip_cm`` (a site ``grip``). The jaws open along an axis
across :math:`\hat a` that is level with the arm at home, since they close on objects
standing on the table (a claw pointing forward and level opens sideways, not up and
down); when :math:`\hat a` is vertical at home every axis across it is level, and the
first of the TCP frame's y and x made perpendicular to :math:`\hat a` is taken. Each jaw
is a plate ``jaw_thickness_cm`` thick whose inner face is the jaw joint's position; along
:math:`\hat a` it is ``jaw_length_cm`` long and ends in a pad (geom ``<jaw>_pad``,
:func:`pad_length_m` long) centred on the grip point, so the tips reach
:math:`h + \ell_{pad}/2` beyond the TCP and no further; the rest of the jaw (geom
``<jaw>_finger``) runs back from the pad toward the wrist, and a plate ``<gripper>_mount``
bridges the TCP to the jaws' roots when they start beyond it. The gripper's servo sits
behind both the TCP and the jaws' roots, its shaft along :math:`\hat a` and its case's
long side along the opening axis; the last DH row's plates, which run to the DH
end between the jaws, are drawn but do not collide. The pads have
:data:`PAD_SOLREF`/:data:`PAD_SOLIMP` and ``priority`` 1, so their contact with an
object is theirs alone (not mixed with the object's softer default): a closed jaw sinks
less than 0.1 mm into the object under the servo's full force.

**The passive coupling** :math:`q_p = \sum_j c_{pj} q_j + c_p` is a fixed tendon of length
:math:`L = q_p - \sum_j c_{pj} q_j` held at :math:`c_p` by its limits, a range
:data:`COUPLING_PLAY` wide centred on :math:`c_p`. Chosen over

- a ``<connect>`` four-bar loop: the description has no bar geometry (the paper arm's
  a = 14 cm row folds its gripper arm in; the MeArm's bars are not in the DH table), so
  the loop would be invented; and it only exists for two-joint parallelograms;
- a position actuator making the passive joint follow the sum: the load on the passive
  joint would be carried by a fictitious motor instead of the shoulder and elbow servos,
  and the coupling would only hold as stiffly as its gain;
- a tendon equality (the same tendon held at :math:`c_p` exactly), which this model used
  until MuJoCo's sleeping was wanted: MuJoCo 4.0 cannot put bodies to sleep in a model
  that has one ("tendon equality does not yet support sleeping"), and a limit is a
  constraint sleeping supports. The play is a linkage's: 1e-4 rad (0.006°), a hundredth
  of the servos' backlash; the wrist holds within 6e-5 rad of the coupling under the
  arm's weight, as the equality held within 1e-5.

The tendon's limits are an ideal massless linkage: their reaction acts along the coupling's
Jacobian, so the servos feel exactly the load the real parallelogram hands them (virtual
work), for any number of terms, prismatic or revolute. Its stiffness is the constraint's
``solref``; :data:`COUPLING_SOLREF` holds it within 1e-3 rad under the arm's own weight.
The jaw mimic is a joint equality (one other joint). What it leaves out: the bars' own
mass and their compliance and play.

**Masses** are estimated from sizes and materials: every DH segment (a and d) is a laser-
cut acrylic plate :data:`LINK_THICKNESS_M` thick and as wide as the URDF draws it; each
actuated joint's servo is a box of its datasheet size and mass at the joint, in the body
before it (a real MeArm keeps its shoulder and elbow servos at the base: this errs
heavy); the gripper's servo sits behind the TCP. A body that holds neither (a row with
a = d = 0 before a passive joint) gets a hub's mass, a square plate as wide as the links
(:func:`_hubs`): MuJoCo moves no massless body. Objects are solid PLA cylinders of their
class's size.

**The servos** are :class:`ServoSpec` records from typical datasheets
(:data:`SERVO_CATALOGUE`). The config names no servo model, so the joints get the
smallest catalogue servo whose stall torque is :data:`SERVO_LOAD_FACTOR` times the worst
gravity load at home and at seeded poses; the gripper gets :data:`GRIPPER_SERVO`. The
model records both by name (``<custom>`` texts :data:`JOINT_SERVO_TEXT` and
:data:`GRIPPER_SERVO_TEXT`, read back by :func:`recorded_servo`). Each
actuated joint has a ``position`` actuator: ``kp`` reaches the stall torque at
:data:`FULL_TORQUE_ERROR_RAD` of error, ``forcerange`` is the stall torque, ``ctrlrange``
the joint limits. The joint's ``armature`` is the motor's reflected inertia and its
``damping`` the motor's back-EMF slope :math:`\tau_s/\omega_0` (so a saturated servo turns
at its datasheet speed); the actuator's ``kv`` (the servo's D-term, inside the torque
limit) makes each servo critically damped at home through the coupling: a 10° step
settles without overshoot in about 0.05 s. The gripper is one ``position`` actuator on
the left jaw with ``gear`` 2 (its ctrl is the opening [m]), the right jaw tied to it by a
joint equality; a jaw's force limit is the servo's stall torque on :data:`SERVO_LEVER_M`.
The speed limit, deadband, backlash and the bus's command quantisation are *not* in the MJCF: the
twin's servo bus (next step) shapes ``ctrl`` with the :class:`ServoSpec` figures
(``speed_rad_s``, ``deadband_us``) and the joints' pulse calibrations.

**A servo that turns a combination of joints** (its ``drives``,
:class:`~mearm.config.ServoDrives`: the MeArm's elbow servo sets the forearm's angle to
the table, shoulder + elbow) is a ``position`` actuator on a fixed tendon ``<joint>_servo``
with the combination's coefficients (in model units): the tendon's length is the servo's
value less its offset, and so is its ``ctrl``. The motor's reflected inertia and back-EMF
are the tendon's ``armature`` and ``damping``, not the joint's. A fixed tendon *is* a
linear transmission: the actuator's force f acts on each joint by its coefficient
(:math:`\tau_j = a_j f`, virtual work), its length and speed are the combination's, so
the servo's gain, damping and stall torque act on exactly what the servo turns, and the
load it holds is the load along that combination. Chosen over

- a position actuator on the DH joint whose target is recomputed from the other joints'
  measured angles: a controller the kit does not have. The real servo holds the
  combination, so a shoulder that sags under load turns the DH elbow the other way;
  only an actuator on the combination does that;
- the kit's linkage bars as ``<connect>`` loops: the description has no bar geometry
  (as for the passive coupling above).

Its ``ctrlrange`` is what its pulse range allows within what the joints' limits allow;
its ``kv`` damps the inertia along its own coordinate (:func:`_servo_kv`), and the servo
choice weighs the load along it (:func:`_max_load`). What it leaves out, as for the
coupling: the linkage's own mass, compliance and play.

**The scene**: a table whose top is z = 0 in the base frame; per class a bin (floor and
four walls, inner width the class's ``bin_inner_width_cm``) under its
``bin_cm``; one free body ``obj_<id>`` per scene object (ids as :class:`~mearm.sim.World`
gives them); a camera ``camera`` looking straight down from :data:`CAMERA_HEIGHT_M` above
the centre of the calibrated field, its ``fovy`` chosen so that it sees that field (the
calibration stays true for the twin's pictures at ``camera.width_px × height_px``) or,
with ``twin.camera`` set, a perspective camera placed, tilted and with the field of view
it gives (:func:`mearm.sim.twin.twin_optics.camera_pose`; the lens distortion is applied to
the rendered frames).

**The belt** (``config.belt``): a box lying on the table, ``surface_cm`` thick, whose top
moves at ``speed_cm_s`` along its length: MuJoCo's ``surfacevel`` (since 3.11), which
makes the contacts with it move what lies on it as a real belt's friction does. A driven
body would do the same with a joint, an actuator and a length of travel that runs out;
the moving surface has none of these, and a carried object still slips, tips or stops
against the jaws as the contacts decide. Each object the belt brings
(:func:`~mearm.sim.belt.belt_arrivals`) is a free body ``obj_<id>`` that waits off the
table (:func:`parked_m`) until the twin's bus puts it on the belt's upstream end at its
time.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import mujoco
import numpy as np

from mearm.config import Config
from mearm.config.root import TWIN_TIMESTEP_S
from mearm.config.servo_models import (  # noqa: F401  (the twin's servos, re-exported)
    FULL_TORQUE_ERROR_RAD,
    GRIPPER_SERVO,
    KGCM_TO_NM,
    MG90S,
    MG996R,
    MOTOR_TIME_CONSTANT_S,
    RDS3135,
    SERVO_CATALOGUE,
    SERVO_LOAD_FACTOR,
    SG90,
    ServoSpec,
    servo_named,
)
from mearm.fileio import write_atomic
from mearm.kinematics.bodies import (
    BIN_MIN_WALL_HEIGHT_M,  # noqa: F401  (re-exported)
    BIN_WALL_HEIGHT_PER_HEIGHT,  # noqa: F401
    LINK_THICKNESS_M,
    ArmBodies,
    arm_bodies,
    link_width_m,
    plate_mass_kg,
)
from mearm.kinematics.chain import Chain
from mearm.kinematics.errors import ModelError
from mearm.kinematics.mjspec import arm_spec, exact, quat, yaw_quat
from mearm.kinematics.urdf import TCP_FRAME, jaw_joint_names, jaw_pad_length_m
from mearm.sim.belt import Arrival
from mearm.sim.twin.twin_geoms import (  # noqa: F401  (re-exported)
    _ARM_CONAFFINITY,
    _ARM_CONTYPE,
    _GEOM_KIND,
    _SCENE_CONAFFINITY,
    _SCENE_CONTYPE,
    ACRYLIC_DENSITY,
    BELT_FRICTION,
    JAW_FRICTION,
    M_PER_CM,
    OBJECT_FRICTION,
    OBJECT_ROLL_FRICTION,
    OBJECT_SPIN_FRICTION,
    PLA_DENSITY,
    TABLE_FRICTION,
    G,
    _geom,
    _rgba,
    _scene_geom,
    _shape_geom,
)
from mearm.sim.twin.twin_optics import CAMERA_HEIGHT_M  # noqa: F401  (re-exported)
from mearm.sim.twin.twin_scene import (  # noqa: F401  (re-exported)
    TABLE_GRID_M,
    TABLE_MARGIN_M,
    _belt,
    _bin,
    _camera,
    _field_corners_m,
    _lights,
    _object_geom,
    _objects,
    _table,
)
from mearm.sim.twin.twin_scene_check import (  # noqa: F401  (re-exported)
    PARK_ORIGIN_M,
    PARK_STEP_M,
    _bin_half_outer_m,
    _check_belt,
    _check_scene,
    _strip_clear_of_square,
    _wall_height_m,
    arrival_centre_m,
    object_ids,
    parked_m,
)
from mearm.sim.twin.twin_servos import (  # noqa: F401  (re-exported)
    LOAD_POSES,
    SERVO_DAMPING_RATIO,
    SERVO_LEVER_M,
    _arm_dofs,
    _capacity,
    _ctrl_range,
    _home_data,
    _lever2,
    _max_load,
    _servo_jacobian,
    _servo_kv,
    _servo_rows,
    _ServoRow,
    servo_tendon,
)
from mearm.vision.aruco import get_dictionary, marker_image
from mearm.vision.claw_marker import check_marker

#: Time step [s]: 2 ms, ten to a command period; the servos' step responses settle
#: within 0.1° of a 1 ms model's (docs/twin.md). The coupling's constraint time constant
#: and damping ratio follow.
TIMESTEP_S = TWIN_TIMESTEP_S
COUPLING_SOLREF = (2 * TIMESTEP_S, 1.0)  # two steps: the stiffest MuJoCo keeps
COUPLING_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)
#: The coupling's play: its tendon's limits are this far apart [rad or m].
COUPLING_PLAY = 1e-4

#: The pads' contact: a 4 ms time constant, two 2 ms steps, the stiffest MuJoCo nominally
#: keeps stable; impedance 0.99–0.999 over 0.5 mm of penetration. Softer pads let a held
#: object creep out of the jaws when a move stops (the sweeps: docs/twin.md). Damping
#: ratio 2, not 1: at a time constant of two steps a critically damped pad rang, the
#: held object lost one pad every few steps and slid 0.1–0.2 cm down the jaws in a carry
#: (traced step by step, docs/twin.md); overdamped, a rubber pad's contact neither rings
#: nor rebounds, and the object stays where the jaws closed on it.
PAD_SOLREF = (0.004, 2.0)
PAD_SOLIMP = (0.99, 0.999, 0.0005, 0.5, 2.0)
#: Names of the ``<custom>`` texts recording the joints' and the gripper's servo models.
JOINT_SERVO_TEXT = "mearm_joint_servo"
GRIPPER_SERVO_TEXT = "mearm_gripper_servo"


def twin_spec(
    config: Config,
    servo: ServoSpec | None = None,
    gripper_servo: ServoSpec | None = None,
) -> tuple[mujoco.MjSpec, mujoco.MjModel]:
    """Build the twin, arm, table, bins, objects and camera, and compile it.

    The arm's chain is :func:`~mearm.kinematics.mjspec.arm_spec`'s (the mink cross-check
    solves on the same one). The model is compiled once for the joints' servo (once per
    catalogue servo tried when the config names none); the servos' damping, which
    depends on the compiled model's inertia, is then set in both.

    Args:
        config: The whole config (arm, task, camera, calibration).
        servo: The joints' servo; ``None`` takes the config's ``twin.joint_servo`` or, if
            that is null too, picks from :data:`SERVO_CATALOGUE` by load.
        gripper_servo: The gripper's servo; ``None`` takes the config's
            ``twin.gripper_servo``.

    Returns:
        The spec and its compiled model (metres, kilograms, radians); keyframe ``home``
        holds the arm at home with the jaws open and the objects on the table, ``ctrl``
        at home.

    Raises:
        ModelError: the scene cannot be built (objects overlapping each other, a bin or
            the arm's base; a bin too tall for the release height; no straight-down
            camera sees the calibrated field; MuJoCo refuses the model); the message
            names the parts.
    """
    _check_scene(config)
    if servo is None and config.twin.joint_servo is not None:
        servo = servo_named(config.twin.joint_servo)
    if gripper_servo is None:
        gripper_servo = servo_named(config.twin.gripper_servo)
    for candidate in (servo,) if servo is not None else SERVO_CATALOGUE:
        spec = _build(config, candidate, gripper_servo)
        model = _compile(spec)
        if servo is not None:
            break
        load = _max_load(model, config)
        capacity = np.array([_capacity(j, candidate) for j in config.arm.actuated_joints()])
        if np.all(SERVO_LOAD_FACTOR * load <= capacity):
            break  # else the largest servo of the catalogue, the last one built
    for name, kv in _servo_kv(model, config, candidate, gripper_servo).items():
        spec.actuator(name).biasprm[2] = -kv  # a position actuator's bias: -kp q - kv q̇
        model.actuator(name).biasprm[2] = -kv
    return spec, model


def twin_model(
    config: Config,
    servo: ServoSpec | None = None,
    gripper_servo: ServoSpec | None = None,
) -> mujoco.MjModel:
    """The twin's compiled model (:func:`twin_spec`)."""
    return twin_spec(config, servo, gripper_servo)[1]


def generate_mjcf(
    config: Config,
    servo: ServoSpec | None = None,
    gripper_servo: ServoSpec | None = None,
) -> str:
    """The twin as MJCF text (:func:`twin_spec`), loadable by ``mujoco.MjModel.from_xml_string``."""
    return twin_spec(config, servo, gripper_servo)[0].to_xml()


def save_mjcf(config: Config, path: str | Path) -> Path:
    """Write :func:`generate_mjcf` of ``config`` to ``path`` atomically; returns the file."""
    return write_atomic(path, generate_mjcf(config))


def pad_length_m(config: Config) -> float:
    """A jaw pad's length: :func:`~mearm.kinematics.urdf.jaw_pad_length_m` of the gripper [m]."""
    return jaw_pad_length_m(config.arm.tool.gripper)


def recorded_servo(model: mujoco.MjModel, text: str) -> str | None:
    """The servo model name a twin records in its ``<custom>`` text ``text``; None if absent."""
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXT, text)
    if i < 0:
        return None
    start, size = int(model.text_adr[i]), int(model.text_size[i])
    return bytes(model.text_data[start : start + size]).rstrip(b"\0").decode()


def _compile(spec: mujoco.MjSpec) -> mujoco.MjModel:
    try:
        return spec.compile()
    except ValueError as exc:
        raise ModelError(f"MuJoCo refused the twin's model: {exc}") from None


def _build(config: Config, spec: ServoSpec, gripper_spec: ServoSpec) -> mujoco.MjSpec:
    """The twin's spec for these servos, its servos undamped (:func:`twin_spec` sets ``kv``)."""
    arm = config.arm
    chain = Chain.from_description(arm)
    model = arm_spec(arm, name=f"{arm.name}_twin")
    _options(model, config)
    _materials(model)
    world = model.worldbody
    _lights(model, config)
    _table(world, config)
    if config.belt is not None:
        _belt(world, config)
    _camera(world, config)
    servo_rows = _servo_rows(config, chain)
    _arm(model, config, servo_rows, spec, gripper_spec)
    for c in config.task.classes:
        _bin(world, config, c.name)
    arrivals = _objects(model, config)
    _couplings(model, config, chain)
    _actuators(model, config, chain, servo_rows, spec, gripper_spec)
    _home_key(model, config, chain, servo_rows, arrivals)
    model.comment = (
        "Generated by mearm.sim.twin.mjcf from the config; do not edit: change the config "
        f"and regenerate. Joint servos: {spec.name} ({spec.source}). "
        f"Gripper servo: {gripper_spec.name}. Units: m, kg, rad."
    )
    return model


def _options(model: mujoco.MjSpec, config: Config) -> None:
    """The simulation's options (step, integrator, friction cones, sleep) and frame size."""
    model.option.timestep = TIMESTEP_S
    model.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    # pyramidal by default: faster, and elliptic cones left light objects rocking (~0.08°,
    # 1e-2 rad/s); elliptic where grips by slanted faces must hold (TwinConfig.friction_cone)
    model.option.cone = (
        mujoco.mjtCone.mjCONE_ELLIPTIC
        if config.twin.friction_cone == "elliptic"
        else mujoco.mjtCone.mjCONE_PYRAMIDAL
    )
    model.option.impratio = 10.0
    model.option.gravity = [0.0, 0.0, -G]
    # Objects at rest sleep until something touches them (MuJoCo's islands). The arm
    # (actuated, which MuJoCo keeps awake by default) may sleep too when it holds still:
    # the twin's bus wakes it for each new command (mearm.sim.twin.twin_bus).
    model.option.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
    first = f"link_{config.arm.joints[0].name}"
    model.body(first).sleep = mujoco.mjtSleepPolicy.mjSLEEP_ALLOWED
    model.visual.global_.offwidth = config.camera.width_px
    model.visual.global_.offheight = config.camera.height_px


def _materials(model: mujoco.MjSpec) -> None:
    """The materials of the arm and the scene.

    The arm is drawn in greys (black acrylic, black metal-gear servos): a saturated
    colour would be taken for an object of a class by the detector looking at the twin's
    camera, as it would be on a real table.
    """
    for name, rgba in (
        ("base", (0.25, 0.25, 0.28, 1.0)),
        ("link", (0.18, 0.18, 0.20, 1.0)),
        ("gripper", (0.70, 0.70, 0.75, 1.0)),
        ("servo", (0.08, 0.08, 0.09, 1.0)),
        ("table", (0.62, 0.46, 0.30, 1.0)),
        ("bin", (0.85, 0.85, 0.85, 1.0)),
        ("belt", (0.12, 0.12, 0.13, 1.0)),  # black rubber
        ("marker", (1.0, 1.0, 1.0, 1.0)),  # the claw marker's white plate
    ):
        model.add_material(name=name, rgba=list(rgba))


def _arm(
    model: mujoco.MjSpec,
    config: Config,
    servo_rows: list[_ServoRow],
    spec: ServoSpec,
    gripper_spec: ServoSpec,
) -> None:
    """The arm's geoms (:mod:`mearm.kinematics.bodies`, which the planner checks too).

    The servo's motor (reflected inertia, back-EMF) sits on what it turns: its own joint
    here, or the tendon of its combination (:func:`_actuators`).
    """
    arm = config.arm
    shapes = arm_bodies(config.arm, spec, gripper_spec, acrylic_kg_m3=ACRYLIC_DENSITY)
    for row in servo_rows:
        if not row.combined:
            joint = model.joint(row.joint.name)
            joint.armature = spec.armature / _lever2(row.joint)
            joint.damping[0] = spec.motor_damping / _lever2(row.joint)
    # the last row's plates run to the DH end, between the jaws: drawn, but the
    # gripper's servo and jaws are what collides there
    last = f"link_{arm.joints[-1].name}"
    material = {"base_link": "base"} | {f"link_{j.name}": "link" for j in arm.joints}
    material[last] = "gripper"
    _tool(model.body(TCP_FRAME), config, shapes, gripper_spec)
    for shape in shapes.shapes:
        if shape.jaw:
            continue  # the jaws' geoms: _tool, with their contact properties
        if shape.part == "link":
            kind = material[shape.body]
        else:
            kind = shape.part if shape.part in ("base", "servo", "marker") else "gripper"
        _shape_geom(model.body(shape.body), shape, kind)
    if shapes.marker_in_tcp is not None:
        _claw_marker(model, model.body(TCP_FRAME), config, shapes.marker_in_tcp)
    _hubs(model, config, shapes)


def _hubs(model: mujoco.MjSpec, config: Config, shapes: ArmBodies) -> None:
    """A hub's mass in each link body that carries no shape, so MuJoCo can move it.

    A row with a = d = 0 has no plate, and a servo sits in the body before its joint:
    a zero-length row followed by a passive joint (a wrist roll coupled to the base)
    leaves its body empty, and MuJoCo refuses a moving body without mass. What joins the
    two joints there is a hub; it gets a square acrylic plate's mass, as wide as the
    links, with that plate's inertia, and no geom (nothing to draw or collide with).
    """
    width = link_width_m(config.arm)
    mass = plate_mass_kg(width, width, ACRYLIC_DENSITY)
    filled = {shape.body for shape in shapes.shapes}
    for joint in config.arm.joints:
        name = f"link_{joint.name}"
        if name in filled:
            continue
        body = model.body(name)
        body.explicitinertial = True
        body.mass = mass
        edge, thick = mass * width**2 / 12, mass * LINK_THICKNESS_M**2 / 12
        body.inertia = [edge + thick, edge + thick, 2 * edge]


def _couplings(model: mujoco.MjSpec, config: Config, chain: Chain) -> None:
    """The passive couplings' tendons (module docstring) and the jaws' mimic."""
    arm = config.arm
    model.add_exclude(bodyname1="world", bodyname2=f"link_{arm.joints[0].name}")
    for i, joint in enumerate(arm.joints):
        if joint.coupling is None:
            continue
        tendon = model.add_tendon(name=f"{joint.name}_coupling")
        tendon.wrap_joint(joint.name, 1.0)
        for k, a in enumerate(chain.actuated):
            if chain.C[i, k] != 0.0:
                tendon.wrap_joint(a, float(-chain.C[i, k]))
        tendon.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        tendon.range = [chain.c[i] - COUPLING_PLAY / 2, chain.c[i] + COUPLING_PLAY / 2]
        tendon.solref_limit = list(COUPLING_SOLREF)
        tendon.solimp_limit = list(COUPLING_SOLIMP)
    left, right = jaw_joint_names(arm)
    _equality(model, mujoco.mjtEq.mjEQ_JOINT, f"{right}_mimic", right, left, (0, 1, 0, 0, 0))


def _actuators(
    model: mujoco.MjSpec,
    config: Config,
    chain: Chain,
    servo_rows: list[_ServoRow],
    spec: ServoSpec,
    gripper_spec: ServoSpec,
) -> None:
    """Each servo's ``position`` actuator (a combined one's on its tendon), and their names."""
    arm = config.arm
    for row in servo_rows:
        if not row.combined:
            continue
        tendon = model.add_tendon(
            name=row.tendon,
            armature=spec.armature / _lever2(row.joint),
        )
        tendon.damping[0] = spec.motor_damping / _lever2(row.joint)
        for name, coef in row.coef.items():
            tendon.wrap_joint(name, coef)
    for k, a in enumerate(chain.actuated):
        i = int(chain.actuated_index[k])
        joint = arm.joints[i]
        row = servo_rows[k]
        cap = _capacity(joint, spec)
        _position(
            model,
            a,
            (mujoco.mjtTrn.mjTRN_TENDON, row.tendon)
            if row.combined
            else (mujoco.mjtTrn.mjTRN_JOINT, a),
            kp=spec.kp / _lever2(joint),
            force=cap,
            ctrl=_ctrl_range(row, chain, i),
        )
    g = arm.tool.gripper
    lo, hi = g.servo.value_range()
    _position(
        model,
        g.name,
        (_ON_JOINT, jaw_joint_names(arm)[0]),
        kp=gripper_spec.kp / SERVO_LEVER_M**2,
        force=gripper_spec.stall_torque_nm / SERVO_LEVER_M,
        ctrl=(max(lo, 0.0) * M_PER_CM, hi * M_PER_CM),
        gear=2.0,
    )
    model.add_text(name=JOINT_SERVO_TEXT, data=spec.name)
    model.add_text(name=GRIPPER_SERVO_TEXT, data=gripper_spec.name)


def _home_key(
    model: mujoco.MjSpec,
    config: Config,
    chain: Chain,
    servo_rows: list[_ServoRow],
    arrivals: list[Arrival],
) -> None:
    """Keyframe ``home``: the arm at home, jaws open, objects where the scene puts them."""
    task, g = config.task, config.arm.tool.gripper
    half_open = g.open_cm * M_PER_CM / 2
    qpos = list(chain.home) + [half_open, half_open]
    for obj in task.scene:  # where and at what yaw the scene puts each (as its body)
        h = task.class_named(obj.color).height_cm * M_PER_CM
        yaw = math.radians(obj.yaw_deg)
        turn = yaw_quat(yaw)
        qpos += [obj.x * M_PER_CM, obj.y * M_PER_CM, h / 2, *exact(turn)]
    for i, arrival in enumerate(arrivals):
        qpos += [*parked_m(config, i, arrival), 1, 0, 0, 0]
    home_ctrl = [
        sum(c * chain.home[chain.names.index(n)] for n, c in row.coef.items())
        if row.combined
        else chain.home[chain.actuated_index[k]]
        for k, row in enumerate(servo_rows)
    ]
    model.add_key(name="home", qpos=qpos, ctrl=[*home_ctrl, g.open_cm * M_PER_CM])


_ON_JOINT = mujoco.mjtTrn.mjTRN_JOINT


def _equality(
    model: mujoco.MjSpec,
    kind: mujoco.mjtEq,
    name: str,
    name1: str,
    name2: str,
    polycoef: Sequence[float],
) -> None:
    """An equality ``name1 = poly(name2)``, as stiff as the coupling."""
    eq = model.add_equality(type=kind, name=name, name1=name1, solref=list(COUPLING_SOLREF))
    eq.name2 = name2
    eq.data[:5] = polycoef


def _position(
    model: mujoco.MjSpec,
    name: str,
    target: tuple[mujoco.mjtTrn, str],
    *,
    kp: float,
    force: float,
    ctrl: tuple[float, float],
    gear: float = 1.0,
) -> None:
    """A ``position`` actuator: the servo's gain, damping, stall force and range."""
    act = model.add_actuator(name=name, trntype=target[0], target=target[1])
    act.set_to_position(kp=kp, kv=0.0)
    act.gear[0] = gear
    act.forcerange = [-force, force]
    act.ctrlrange = list(ctrl)


def _tool(tcp: mujoco.MjsBody, config: Config, shapes: ArmBodies, gripper_spec: ServoSpec) -> None:
    """The grip site and the two jaws on slide joints, with their pads' contact.

    The jaws' geometry (pads, fingers) is :func:`~mearm.kinematics.bodies.arm_bodies`';
    the gripper's servo and mount are added with the arm's other shapes.
    """
    arm = config.arm
    g = arm.tool.gripper
    across = shapes.across
    site = tcp.add_site(
        name="grip", pos=exact(shapes.approach * shapes.grip_m), rgba=[0, 1, 1, 1], group=4
    )
    site.size[0] = 0.003  # group 4: not drawn by the camera
    hi = g.servo.value_range()[1] * M_PER_CM / 2
    # the opening o = 2q: the servo's inertia and damping on o, J/r² and b/r², are 4×
    # that on q, shared by the two jaws
    jaw_armature = 2 * gripper_spec.armature / SERVO_LEVER_M**2
    for name, sign in zip(jaw_joint_names(arm), (1.0, -1.0), strict=True):
        body = tcp.add_body(name=f"link_{name}")
        joint = body.add_joint(
            name=name,
            type=mujoco.mjtJoint.mjJNT_SLIDE,
            axis=exact(across * sign),
            range=[0.0, hi],
            armature=jaw_armature,
        )
        joint.damping[0] = 2 * gripper_spec.motor_damping / SERVO_LEVER_M**2
        for shape in shapes.shapes:
            if shape.body != f"link_{name}":
                continue
            attrs: dict[str, object] = {
                "friction": [JAW_FRICTION, OBJECT_SPIN_FRICTION, OBJECT_ROLL_FRICTION],
                "condim": 4,
            }
            if shape.part == "pad":
                attrs |= {"priority": 1, "solref": list(PAD_SOLREF), "solimp": list(PAD_SOLIMP)}
            _shape_geom(body, shape, "gripper", **attrs)


def _claw_marker(
    model: mujoco.MjSpec, tcp: mujoco.MjsBody, config: Config, face: np.ndarray
) -> None:
    """The claw marker's print on its white plate: one thin black box per black module.

    Boxes, not a texture, so that the twin's MJCF stays one self-contained file
    (:func:`generate_mjcf`). Drawn only (no contacts). Module (row, column) of the
    marker's image lies at (column, −row) from its top-left corner along the face's x and
    y (its top edge along +y), as :func:`~mearm.vision.claw_marker.square_corners` has it.
    """
    m = config.arm.tool.marker
    assert m is not None
    check_marker(m)  # the error names arm.tool.marker's field
    modules = get_dictionary(m.dictionary).markerSize + 2
    cells = marker_image(m.id, modules, m.dictionary) < 128  # one pixel a module
    side = m.size_cm * M_PER_CM
    module = side / modules
    R = face[:3, :3]
    model.add_material(name="claw_marker", rgba=[0.0, 0.0, 0.0, 1.0])
    for row, col in zip(*np.nonzero(cells), strict=True):
        local = np.array([(col + 0.5) * module - side / 2, side / 2 - (row + 0.5) * module, 1e-4])
        _geom(tcp, f"claw_marker_{row}_{col}", "box", (module / 2, module / 2, 1e-4),
              pos=exact(face[:3, 3] + R @ local), quat=exact(quat(R)), material="claw_marker",
              contype=0, conaffinity=0, mass=0.0)  # fmt: skip
