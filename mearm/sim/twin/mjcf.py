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
heavy); the gripper's servo sits behind the TCP. Objects are solid PLA cylinders of their
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
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from mearm.config import ColorClass, Config, Joint
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
    ArmBodies,
    Shape,
    arm_bodies,
    base_radius_m,
    bin_half_outer_m,
    bin_origin_m,
    bin_shapes,
    object_centre_m,
    wall_height_m,
)
from mearm.kinematics.chain import Chain
from mearm.kinematics.errors import ModelError
from mearm.kinematics.mjspec import arm_spec, exact, quat
from mearm.kinematics.urdf import TCP_FRAME, jaw_joint_names, jaw_pad_length_m
from mearm.sim.belt import Arrival, Belt, belt_arrivals
from mearm.sim.twin.twin_optics import CAMERA_HEIGHT_M, camera_pose, homography_view
from mearm.vision.aruco import get_dictionary, marker_image
from mearm.vision.claw_marker import check_marker

M_PER_CM = 0.01
G = 9.81  # m/s²

# --------------------------------------------------------------------------- materials
#: Cast/extruded PMMA (acrylic) sheet: 1.19 g/cm³ (typical sheet datasheets) [kg/m³].
ACRYLIC_DENSITY = 1190.0
#: PLA filament: 1.24 g/cm³ (typical filament datasheets); objects printed solid [kg/m³].
PLA_DENSITY = 1240.0
#: Coulomb friction [-] (estimates: PLA on wood or acrylic 0.3–0.5; rubber jaw pads ~1).
OBJECT_FRICTION = 0.4
TABLE_FRICTION = 0.4
#: A rubber belt's grip on PLA [-] (rubber on plastics: 0.5–0.8).
BELT_FRICTION = 0.6
JAW_FRICTION = 1.0
#: Torsional and rolling friction of the objects [m] (small: they stand flat).
OBJECT_SPIN_FRICTION = 0.005
OBJECT_ROLL_FRICTION = 0.0001

# --------------------------------------------------------------------------- servos


#: Lever turning a servo's torque into a linear force: a prismatic joint's drive and the
#: gripper's jaw linkage (estimate: a 2 cm horn) [m].
SERVO_LEVER_M = 0.02
#: Damping ratio of each servo at home [-]: critical, so it settles without overshoot.
SERVO_DAMPING_RATIO = 1.0
#: Seeded poses at which the servo selection checks the gravity load.
LOAD_POSES = 16

# --------------------------------------------------------------------------- scene
#: The table plane's drawn grid spacing, and the margin it is drawn beyond everything on
#: it [m].
TABLE_GRID_M = 0.05
TABLE_MARGIN_M = 0.05
#: Time step [s]: 2 ms, ten to a command period. With objects and arm asleep at rest and
#: the servo model run once per run of steps (:mod:`mearm.sim.twin.twin_bus`), the 5-DOF
#: arm's physics ran 40× real time on the CPU at 1 ms and 68× at 2 ms (the paper arm's,
#: before those two, 40× and 77×). The servos' step responses (`mearm servo-steps`,
#: plotted in docs/twin.md) run at most 0.24° ahead while they ramp (one step sooner)
#: and settle within 0.1° of the 1 ms model's. What 2 ms costs: see :data:`PAD_SOLREF`.
#: The coupling's constraint time constant and damping ratio follow.
TIMESTEP_S = 0.002
COUPLING_SOLREF = (2 * TIMESTEP_S, 1.0)  # two steps: the stiffest MuJoCo keeps
COUPLING_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)
#: The coupling's play: its tendon's limits are this far apart [rad or m].
COUPLING_PLAY = 1e-4

#: The pads' contact: a 4 ms time constant, two 2 ms steps, the stiffest MuJoCo nominally
#: keeps stable; critically damped, impedance 0.99–0.999 over 0.5 mm of penetration. Under
#: an SG90's jaw force (8.8 N) a 2 cm PLA object reads 1.9975 cm between the pads. Softer
#: pads let a held object creep out of the jaws when a move stops: at 6 and 8 ms the 5-DOF
#: arm's random scenes (seeds 600–619) sorted 179 and 119 of 180, at 4 ms 180 of 180. At a
#: 1 ms step, two steps once let a squeezed object diverge in one of ten random sorts; at
#: 2 ms none diverged in the sweeps of docs/twin.md, and a divergence is a servo fault,
#: never silent (:meth:`~mearm.sim.twin.twin_bus.TwinArm._run`). In one sweep at 2 ms, one
#: held object of 2,520 (paper arm, seed 7008) tipped out of the jaws in a fast lift,
#: which 1 ms held.
PAD_SOLREF = (0.004, 1.0)
PAD_SOLIMP = (0.99, 0.999, 0.0005, 0.5, 2.0)
#: Names of the ``<custom>`` texts recording the joints' and the gripper's servo models.
JOINT_SERVO_TEXT = "mearm_joint_servo"
GRIPPER_SERVO_TEXT = "mearm_gripper_servo"

_ARM_CONTYPE, _ARM_CONAFFINITY = 2, 1  # arm geoms: touch the scene, never each other
_SCENE_CONTYPE, _SCENE_CONAFFINITY = 1, 3


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


# --------------------------------------------------------------------------- checks


def object_ids(config: Config) -> list[str]:
    """Scene objects' ids in scene order (``red1``, ``red2``, … per class)."""
    counts: dict[str, int] = {}
    out = []
    for obj in config.task.scene:
        counts[obj.color] = counts.get(obj.color, 0) + 1
        out.append(f"{obj.color}{counts[obj.color]}")
    return out


#: Where the belt's objects wait for their arrival, off the table: the first at this
#: (x, y) [m], the next ones :data:`PARK_STEP_M` further along x.
PARK_ORIGIN_M = (-3.0, -3.0)
PARK_STEP_M = 0.1


def parked_m(config: Config, index: int, arrival: Arrival) -> list[float]:
    """Where the ``index``-th object the belt brings waits, its centre (x, y, z) [m]."""
    h = config.task.class_named(arrival.color).height_cm * M_PER_CM
    return [PARK_ORIGIN_M[0] - index * PARK_STEP_M, PARK_ORIGIN_M[1], h / 2]


def arrival_centre_m(config: Config, arrival: Arrival) -> list[float]:
    """Where an object the belt brings lands: its centre (x, y, z) [m], on the belt's top."""
    assert config.belt is not None
    h = config.task.class_named(arrival.color).height_cm * M_PER_CM
    top = config.belt.surface_cm * M_PER_CM
    return [arrival.x_cm * M_PER_CM, arrival.y_cm * M_PER_CM, top + h / 2]


def _bin_half_outer_m(config: Config, color: str) -> float:
    return bin_half_outer_m(config, color)


def _check_scene(config: Config) -> None:
    task = config.task
    ids = object_ids(config)
    base_r = base_radius_m(config)
    placed: list[tuple[str, np.ndarray, float]] = []
    for oid, obj in zip(ids, task.scene, strict=True):
        c = task.class_named(obj.color)
        xy = np.array([obj.x, obj.y]) * M_PER_CM
        r = c.footprint_radius_cm * M_PER_CM  # (the circle around a cube's or a prism's)
        for other, oxy, orr in placed:
            d = float(np.linalg.norm(xy - oxy))
            if d < r + orr:
                raise ModelError(
                    f"scene objects {other} and {oid} overlap: centres {d * 100:.3g} cm apart, "
                    f"less than their radii's sum {(r + orr) * 100:.3g} cm; move one "
                    "(task.scene)"
                )
        if float(np.linalg.norm(xy)) < base_r + r:
            raise ModelError(
                f"scene object {oid} at ({obj.x:g}, {obj.y:g}) cm stands on the arm's base "
                f"(radius {base_r * 100:.3g} cm around the origin); move it (task.scene)"
            )
        for b in task.classes:
            h = _bin_half_outer_m(config, b.name)
            bxy = np.array(b.bin_cm[:2]) * M_PER_CM
            if np.all(np.abs(xy - bxy) < h + r):
                raise ModelError(
                    f"scene object {oid} at ({obj.x:g}, {obj.y:g}) cm lies on the bin of "
                    f"class {b.name} (a {2 * h * 100:.3g} cm square around "
                    f"({b.bin_cm[0]:g}, {b.bin_cm[1]:g}) cm); move it (task.scene)"
                )
        placed.append((oid, xy, r))
    if config.belt is not None:
        _check_belt(config, base_r)
    for c in task.classes:
        wall = _wall_height_m(config, c.name)
        release = (c.bin_cm[2] - config.arm.tool.tcp_above_grip_cm - c.grip_z_cm) * M_PER_CM
        if release < wall:
            raise ModelError(
                f"class {c.name}: an object released at bin_cm z = {c.bin_cm[2]:g} cm has its "
                f"bottom {release * 100:.3g} cm above the table, below the bin's "
                f"{wall * 100:.3g} cm walls; raise bin_cm z (task.classes)"
            )


def _check_belt(config: Config, base_r: float) -> None:
    """The belt must lie clear of the arm's base and of every bin."""
    assert config.belt is not None
    belt = Belt(config.belt)
    b = config.belt
    if belt.config.nearest_cm() * M_PER_CM < base_r + b.width_cm / 2 * M_PER_CM:
        raise ModelError(
            f"the belt passes {b.nearest_cm():.3g} cm from the base axis, over the arm's "
            f"base (radius {base_r * 100:.3g} cm) with its {b.width_cm:g} cm width; move it "
            "(belt.start_cm, belt.heading_deg)"
        )
    for c in config.task.classes:
        h = _bin_half_outer_m(config, c.name) / M_PER_CM
        corners = [(sx * h, sy * h) for sx in (-1, 1) for sy in (-1, 1)]
        along_across = [belt.along_across_cm(c.bin_cm[0] + dx, c.bin_cm[1] + dy)
                        for dx, dy in corners]  # fmt: skip
        along = [a for a, _ in along_across]
        across = [x for _, x in along_across]
        # the bin's square against the belt's strip: separated along one of the strip's axes
        # or one of the square's (both pairs are the only candidates for two rectangles)
        apart = (
            max(along) < 0
            or min(along) > b.length_cm
            or max(across) < -b.width_cm / 2
            or min(across) > b.width_cm / 2
            or _strip_clear_of_square(belt, c.bin_cm[:2], h)
        )
        if not apart:
            raise ModelError(
                f"the belt runs over the bin of class {c.name} (a {2 * h:.3g} cm square around "
                f"({c.bin_cm[0]:g}, {c.bin_cm[1]:g}) cm); move the belt or the bin "
                "(belt.start_cm, belt.length_cm, task.classes)"
            )


def _strip_clear_of_square(belt: Belt, centre_cm: Sequence[float], half_cm: float) -> bool:
    """Whether the belt's strip lies wholly beside a square (axis-aligned) in x or in y."""
    b = belt.config
    corners = [
        belt.point_cm(a, w) for a in (0.0, b.length_cm) for w in (-b.width_cm / 2, b.width_cm / 2)
    ]
    for k in (0, 1):
        values = [p[k] - centre_cm[k] for p in corners]
        if min(values) > half_cm or max(values) < -half_cm:
            return True
    return False


def _belt(world: mujoco.MjsBody, config: Config) -> None:
    """The belt: a box on the table whose top moves along its length (``surfacevel``)."""
    assert config.belt is not None
    b = config.belt
    belt = Belt(b)
    cx, cy = belt.centre_cm
    yaw = math.radians(b.heading_deg)
    _scene_geom(
        world,
        "belt",
        "box",
        (b.length_cm / 2 * M_PER_CM, b.width_cm / 2 * M_PER_CM, b.surface_cm / 2 * M_PER_CM),
        pos=exact([cx * M_PER_CM, cy * M_PER_CM, b.surface_cm / 2 * M_PER_CM]),
        quat=exact([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]),
        material="belt",
        friction=[BELT_FRICTION, OBJECT_SPIN_FRICTION, OBJECT_ROLL_FRICTION],
        surfacevel=[b.speed_cm_s * M_PER_CM, 0.0, 0.0, 0.0, 0.0, 0.0],
    )


def _wall_height_m(config: Config, color: str) -> float:
    return wall_height_m(config, color)


def _capacity(joint: Joint, spec: ServoSpec) -> float:
    """What a servo can hold on this joint [N·m, or N for a prismatic one]."""
    if joint.type == "prismatic":
        return spec.stall_torque_nm / SERVO_LEVER_M
    return spec.stall_torque_nm


def _compile(spec: mujoco.MjSpec) -> mujoco.MjModel:
    try:
        return spec.compile()
    except ValueError as exc:
        raise ModelError(f"MuJoCo refused the twin's model: {exc}") from None


def _arm_dofs(m: mujoco.MjModel, config: Config) -> np.ndarray:
    return np.array([m.joint(j.name).dofadr[0] for j in config.arm.joints])


def _home_data(m: mujoco.MjModel) -> mujoco.MjData:
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)
    return d


def _max_load(m: mujoco.MjModel, config: Config) -> np.ndarray:
    r"""Worst gravity load on each joint servo at home and seeded poses, (m,).

    A servo that turns a combination of joints holds the load along its combination:
    :math:`J^\top g` with :math:`J = C\,A^{-1}` (:func:`_servo_jacobian`).
    """
    chain = Chain.from_description(config.arm)
    dofs = _arm_dofs(m, config)
    qadr = np.array([m.joint(j.name).qposadr[0] for j in config.arm.joints])
    d = _home_data(m)
    rng = np.random.default_rng(0)
    lo, hi = chain.actuated_lower, chain.actuated_upper
    J = _servo_jacobian(config, chain)
    worst = np.zeros(chain.m)
    for k in range(LOAD_POSES + 1):
        qa = chain.home[chain.actuated_index] if k == 0 else rng.uniform(lo, hi)
        d.qpos[qadr] = chain.C @ qa + chain.c
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)
        worst = np.maximum(worst, np.abs(J.T @ d.qfrc_bias[dofs]))
    return worst


@dataclass(frozen=True)
class _ServoRow:
    """What one joint servo turns, in model units (rad or m).

    Attributes:
        joint: The joint it sits in (the actuator's name).
        coef: Actuated joint → coefficient of its tendon (model units).
        offset: The combination's offset [rad or m]: servo value = tendon length + offset.
        combined: Whether it turns something other than its joint alone (then a tendon).
    """

    joint: Joint
    coef: dict[str, float]
    offset: float
    combined: bool

    @property
    def tendon(self) -> str:
        """The name of its fixed tendon (a combined servo only)."""
        return servo_tendon(self.joint.name)


def servo_tendon(joint: str) -> str:
    """The fixed tendon a servo sitting in ``joint`` turns when it turns a combination."""
    return f"{joint}_servo"


def _servo_rows(config: Config, chain: Chain) -> list[_ServoRow]:
    """Each actuated joint's servo, in chain order (:meth:`ArmDescription.servo_matrix`)."""
    A, a = config.arm.servo_matrix()
    col_scale = chain.scale[chain.actuated_index]
    rows = []
    for k, name in enumerate(chain.actuated):
        joint = config.arm.joints[int(chain.actuated_index[k])]
        assert joint.servo is not None
        s = float(col_scale[k])
        coef = {n: float(A[k, j] * s / col_scale[j]) for j, n in enumerate(chain.actuated)}
        coef = {n: c for n, c in coef.items() if c != 0.0}
        combined = not (joint.servo.drives is None or (coef == {name: 1.0} and a[k] == 0.0))
        rows.append(_ServoRow(joint, coef, float(a[k] * s), combined))
    return rows


def _servo_jacobian(config: Config, chain: Chain) -> np.ndarray:
    r"""How every joint moves per unit of each joint servo's value: :math:`C A^{-1}`, (n, m).

    Model units; ``C`` itself when every servo turns its own joint.
    """
    rows = _servo_rows(config, chain)
    if not any(r.combined for r in rows):
        return chain.C
    A = np.array([[r.coef.get(n, 0.0) for n in chain.actuated] for r in rows])
    return chain.C @ np.linalg.inv(A)


def _servo_kv(
    m: mujoco.MjModel, config: Config, spec: ServoSpec, gripper_spec: ServoSpec
) -> dict[str, float]:
    r"""Each servo's derivative gain for critical damping at home [N·m·s/rad or N·s/m].

    .. math:: k_{v,k} = 2\zeta\sqrt{k_p\,(J^\top M J)_{kk}} - b_k

    with M the mass matrix at home (armature included), :math:`J = C A^{-1}` the joints'
    motion per unit of each servo's value (C the coupling, A the servos' combinations;
    J = C when every servo turns its own joint) and b_k the servo's own (motor) damping.
    Keyed by actuator name.
    """
    chain = Chain.from_description(config.arm)
    d = _home_data(m)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    dofs = _arm_dofs(m, config)
    J = _servo_jacobian(config, chain)  # C, or C A⁻¹ with servos over combinations
    Meff = J.T @ M[np.ix_(dofs, dofs)] @ J  # M holds the tendons' armature too
    out = {}
    for k, name in enumerate(chain.actuated):
        lever2 = _lever2(config.arm.joints[chain.actuated_index[k]])
        kp, b = spec.kp / lever2, spec.motor_damping / lever2
        out[name] = max(0.0, 2 * SERVO_DAMPING_RATIO * math.sqrt(kp * Meff[k, k]) - b)
    # gear 2 on the left jaw, the right one tied to it: stiffness 4 kp, inertia of both
    left, right = (m.joint(n).dofadr[0] for n in jaw_joint_names(config.arm))
    kp = 4 * gripper_spec.kp / SERVO_LEVER_M**2
    b = 4 * gripper_spec.motor_damping / SERVO_LEVER_M**2
    inertia = float(M[left, left] + M[right, right])
    out[config.arm.tool.gripper.name] = max(
        0.0, (2 * SERVO_DAMPING_RATIO * math.sqrt(kp * inertia) - b) / 4
    )
    return out


def _lever2(joint: Joint) -> float:
    """Squared lever from servo torque to joint force: 1 for a revolute joint [m²]."""
    return SERVO_LEVER_M**2 if joint.type == "prismatic" else 1.0


# --------------------------------------------------------------------------- building


def _rgba(rgb: Sequence[int] | tuple[float, float, float], alpha: float = 1.0) -> list[float]:
    return [*(float(c) / 255 for c in rgb), alpha]


_GEOM_KIND = {
    "box": mujoco.mjtGeom.mjGEOM_BOX,
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
    "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
    "plane": mujoco.mjtGeom.mjGEOM_PLANE,
}


def _geom(
    body: mujoco.MjsBody, name: str, kind: str, size: Sequence[float], **attrs: object
) -> mujoco.MjsGeom:
    geom = body.add_geom(name=name, type=_GEOM_KIND[kind], **attrs)
    geom.size[: len(size)] = size
    return geom


def _scene_geom(
    body: mujoco.MjsBody, name: str, kind: str, size: Sequence[float], **attrs: object
) -> None:
    _geom(body, name, kind, size, contype=_SCENE_CONTYPE, conaffinity=_SCENE_CONAFFINITY, **attrs)


def _shape_geom(body: mujoco.MjsBody, shape: Shape, material: str, **attrs: object) -> None:
    """A geom of :mod:`mearm.kinematics.bodies`' ``shape`` in ``body``."""
    place: dict[str, object] = {"pos": exact(shape.pos)}
    if shape.R is not None:
        place["quat"] = quat(shape.R)
    if shape.mass_kg is not None:
        place["mass"] = shape.mass_kg
    collide = (_ARM_CONTYPE, _ARM_CONAFFINITY) if shape.collides else (0, 0)
    _geom(body, shape.name, shape.kind, shape.size, material=material, contype=collide[0],
          conaffinity=collide[1], **place, **attrs)  # fmt: skip


def _object_geom(
    model: mujoco.MjSpec,
    body: mujoco.MjsBody,
    name: str,
    c: ColorClass,
    material: str | None = None,
) -> None:
    """A scene object of class ``c``: solid PLA of its class's shape, size and colour.

    A cylinder, a box (a cube's footprint, its class's height) or a triangular prism (a
    convex mesh, a corner towards the body's +y), standing on its base; its yaw is its
    body's. ``material``: the model's material it is drawn with (the glossy one of its
    class under a lamp), or none.
    """
    size_m, h = c.diameter_cm * M_PER_CM, c.height_cm * M_PER_CM
    footprint = c.object_shape.footprint
    mass = PLA_DENSITY * c.object_shape.area_cm2(c.diameter_cm) * M_PER_CM**2 * h
    attrs: dict[str, object] = {
        "mass": mass,
        "friction": [OBJECT_FRICTION, OBJECT_SPIN_FRICTION, OBJECT_ROLL_FRICTION],
        # sliding friction only against the table and bins (torsional friction there
        # kept one object rocking on the table plane); against the pads the pads'
        # condim 4 holds, so a held object does not spin
        "condim": 3,
        "rgba": _rgba(c.draw_rgb),
    }
    if material is not None:
        attrs["material"] = material
    if footprint == "disc":
        _scene_geom(body, name, "cylinder", (size_m / 2, h / 2), **attrs)
    elif footprint == "square":
        _scene_geom(body, name, "box", (size_m / 2, size_m / 2, h / 2), **attrs)
    else:
        mesh = f"{name}_prism"
        corners = [
            (size_m / math.sqrt(3) * math.cos(a), size_m / math.sqrt(3) * math.sin(a))
            for a in (math.pi / 2, math.pi / 2 + 2 * math.pi / 3, math.pi / 2 + 4 * math.pi / 3)
        ]
        verts = [v for x, y in corners for z in (-h / 2, h / 2) for v in (x, y, z)]
        model.add_mesh(name=mesh, uservert=verts)
        body.add_geom(
            name=name,
            type=mujoco.mjtGeom.mjGEOM_MESH,
            meshname=mesh,
            contype=_SCENE_CONTYPE,
            conaffinity=_SCENE_CONAFFINITY,
            **attrs,
        )


def _build(config: Config, spec: ServoSpec, gripper_spec: ServoSpec) -> mujoco.MjSpec:
    """The twin's spec for these servos, its servos undamped (:func:`twin_spec` sets ``kv``)."""
    arm, task = config.arm, config.task
    chain = Chain.from_description(arm)
    model = arm_spec(arm, name=f"{arm.name}_twin")
    model.option.timestep = TIMESTEP_S
    model.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    # elliptic cones left light objects rocking (~0.08°, 1e-2 rad/s)
    model.option.cone = mujoco.mjtCone.mjCONE_PYRAMIDAL
    model.option.impratio = 10.0
    model.option.gravity = [0.0, 0.0, -G]
    # Objects at rest sleep until something touches them (MuJoCo's islands): the paper's
    # scene of 12 at rest steps in 14 µs instead of 46 (72 of its 78 dofs asleep). The arm
    # (actuated, which MuJoCo keeps awake by default) may sleep too when it holds still:
    # the twin's bus wakes it for each new command (mearm.sim.twin.twin_bus).
    model.option.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
    model.body(f"link_{arm.joints[0].name}").sleep = mujoco.mjtSleepPolicy.mjSLEEP_ALLOWED
    model.visual.global_.offwidth = config.camera.width_px
    model.visual.global_.offheight = config.camera.height_px
    # The arm is drawn in greys (black acrylic, black metal-gear servos): a saturated
    # colour would be taken for an object of a class by the detector looking at the
    # twin's camera, as it would be on a real table.
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
    world = model.worldbody
    _lights(model, config)
    _table(world, config)
    if config.belt is not None:
        _belt(world, config)
    _camera(world, config)

    # ---- the arm (its shapes: mearm.kinematics.bodies, which the planner checks too)
    shapes = arm_bodies(config, spec, gripper_spec, acrylic_kg_m3=ACRYLIC_DENSITY)
    servo_rows = _servo_rows(config, chain)
    # the servo's motor (reflected inertia, back-EMF) sits on what it turns: its own
    # joint, or the tendon of its combination (below)
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

    # ---- bins and objects
    for c in task.classes:
        _bin(world, config, c.name)
    for oid, obj in zip(object_ids(config), task.scene, strict=True):
        c = task.class_named(obj.color)
        centre = object_centre_m(config, obj.color, obj.x, obj.y)
        yaw = math.radians(obj.yaw_deg)
        body = world.add_body(
            name=f"obj_{oid}",
            pos=exact(centre),
            quat=exact([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]),
        )
        body.add_freejoint(name=f"obj_{oid}")
        gloss = None if config.twin.lamp is None else f"object_{c.name}"  # under a lamp
        _object_geom(model, body, f"obj_{oid}", c, material=gloss)
    arrivals = belt_arrivals(config)
    for i, arrival in enumerate(arrivals):
        name = f"obj_{arrival.id}"
        body = world.add_body(name=name, pos=exact(parked_m(config, i, arrival)))
        body.add_freejoint(name=name)
        gloss = None if config.twin.lamp is None else f"object_{arrival.color}"
        _object_geom(model, body, name, task.class_named(arrival.color), material=gloss)

    # ---- contacts, coupling, actuators, home
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
        (_ON_JOINT, left),
        kp=gripper_spec.kp / SERVO_LEVER_M**2,
        force=gripper_spec.stall_torque_nm / SERVO_LEVER_M,
        ctrl=(max(lo, 0.0) * M_PER_CM, hi * M_PER_CM),
        gear=2.0,
    )
    model.add_text(name=JOINT_SERVO_TEXT, data=spec.name)
    model.add_text(name=GRIPPER_SERVO_TEXT, data=gripper_spec.name)
    half_open = g.open_cm * M_PER_CM / 2
    qpos = list(chain.home) + [half_open, half_open]
    for obj in task.scene:  # where and at what yaw the scene puts each (as its body)
        h = task.class_named(obj.color).height_cm * M_PER_CM
        yaw = math.radians(obj.yaw_deg)
        turn = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
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
    model.comment = (
        "Generated by mearm.sim.twin.mjcf from the config; do not edit: change the config "
        f"and regenerate. Joint servos: {spec.name} ({spec.source}). "
        f"Gripper servo: {gripper_spec.name}. Units: m, kg, rad."
    )
    return model


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


def _ctrl_range(row: _ServoRow, chain: Chain, i: int) -> tuple[float, float]:
    """A joint servo's ``ctrlrange`` [rad or m].

    Its joint's limits; for a servo over a combination (a tendon), the lengths its pulse
    range allows, within what the joints' limits allow.
    """
    if not row.combined:
        return (float(chain.lower[i]), float(chain.upper[i]))
    servo = row.joint.servo
    assert servo is not None
    s = float(chain.scale[i])
    lo, hi = (v * s - row.offset for v in servo.value_range())
    box_lo = box_hi = 0.0
    for name, c in row.coef.items():
        j = chain.names.index(name)
        ends = (c * chain.lower[j], c * chain.upper[j])
        box_lo, box_hi = box_lo + min(ends), box_hi + max(ends)
    if max(lo, box_lo) < min(hi, box_hi):
        lo, hi = max(lo, box_lo), min(hi, box_hi)
    return (float(lo), float(hi))


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


def _field_corners_m(config: Config) -> np.ndarray:
    """The calibrated field's corners and centre on the table, (5, 2) [m]."""
    H = np.asarray(config.calibration.homography, dtype=float)
    w, h = config.camera.width_px, config.camera.height_px
    px = np.array([[0, 0, 1], [w, 0, 1], [w, h, 1], [0, h, 1], [w / 2, h / 2, 1]], dtype=float)
    xyw = px @ H.T
    return xyw[:, :2] / xyw[:, 2:] * M_PER_CM


def _table(world: mujoco.MjsBody, config: Config) -> None:
    pts = [np.zeros(2), *_field_corners_m(config)]
    for c in config.task.classes:
        h = _bin_half_outer_m(config, c.name)
        centre = np.array(c.bin_cm[:2]) * M_PER_CM
        pts += [centre - h, centre + h]
    for obj in config.task.scene:
        pts.append(np.array([obj.x, obj.y]) * M_PER_CM)
    lo = np.min(pts, axis=0) - TABLE_MARGIN_M
    hi = np.max(pts, axis=0) + TABLE_MARGIN_M
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    # a plane: drawn over everything on the table and a margin, it collides everywhere
    # (an object pushed past the drawn edge slides on out of view instead of falling);
    # cylinder-plane contacts are analytic, and cost a third less per step than
    # cylinder-box ones (the twin's physics runs 12x instead of 8x real time)
    _scene_geom(
        world,
        "table",
        "plane",
        (half[0], half[1], TABLE_GRID_M),
        pos=[centre[0], centre[1], 0.0],
        material="table",
        friction=[TABLE_FRICTION, OBJECT_SPIN_FRICTION, OBJECT_ROLL_FRICTION],
    )


def _lights(model: mujoco.MjSpec, config: Config) -> None:
    """The twin's light: an even light straight down, or ``twin.lamp``.

    Without a lamp: a directional light ``top`` straight down and MuJoCo's headlight (a
    light on the camera). With one (:class:`~mearm.config.twin_lamp_config.TwinLampConfig`):
    the light ``lamp`` where it stands, pointed at its target, casting shadows if it says
    so; the headlight gives only the room's ``ambient`` light; each class's objects get a
    material ``object_<class>`` of the lamp's ``object_specular`` and ``object_shininess``.
    """
    lamp = config.twin.lamp
    world = model.worldbody
    if lamp is None:
        world.add_light(name="top", pos=[0.0, 0.0, 1.5], dir=[0.0, 0.0, -1.0],
                        type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)  # fmt: skip
        return
    pos = np.array(lamp.position_cm) * M_PER_CM
    if lamp.target_cm is not None:
        target = np.array([*lamp.target_cm, 0.0]) * M_PER_CM
    else:
        target = np.array([*homography_view(config)[0], 0.0])
    direction = target - pos  # never zero: the lamp stands ≥ 1 cm above the table
    distance = float(np.linalg.norm(direction))
    kind = {"spot": mujoco.mjtLightType.mjLIGHT_SPOT,
            "directional": mujoco.mjtLightType.mjLIGHT_DIRECTIONAL}[lamp.kind]  # fmt: skip
    light = world.add_light(name="lamp", pos=exact(pos), dir=exact(direction / distance),
                            type=kind, castshadow=lamp.shadows)  # fmt: skip
    light.diffuse = [lamp.diffuse] * 3
    light.specular = [lamp.specular] * 3
    light.ambient = [0.0] * 3
    light.cutoff = lamp.cutoff_deg
    light.exponent = lamp.exponent
    model.visual.quality.shadowsize = lamp.shadow_map_px
    headlight = model.visual.headlight
    headlight.ambient = [lamp.ambient] * 3
    headlight.diffuse = [0.0] * 3
    headlight.specular = [0.0] * 3
    for c in config.task.classes:
        model.add_material(
            name=f"object_{c.name}",
            rgba=_rgba(c.draw_rgb),
            specular=lamp.object_specular,
            shininess=lamp.object_shininess,
        )


def _camera(world: mujoco.MjsBody, config: Config) -> None:
    """The camera ``camera``: :func:`~mearm.sim.twin.twin_optics.camera_pose` of the config.

    Unconfigured (``twin.camera`` null) it looks straight down over the calibrated field's
    centre and sees that field; configured, it stands, tilts and sees as
    ``twin.camera`` says (its lens distortion is applied to the rendered frames by
    :class:`~mearm.sim.twin.twin_camera.TwinCamera`).
    """
    if config.twin.camera is None:
        centre, yaw, extent = homography_view(config)
        fovy = 2 * math.degrees(math.atan(extent / 2 / CAMERA_HEIGHT_M))
        world.add_camera(
            name="camera",
            pos=[centre[0], centre[1], CAMERA_HEIGHT_M],
            quat=[math.cos(yaw / 2), 0, 0, math.sin(yaw / 2)],
            fovy=fovy,
        )
        return
    pose = camera_pose(config)
    # MuJoCo's camera: x right and y up in the image, looking along its -z
    camera = world.add_camera(name="camera", pos=pose.centre_m, fovy=pose.fovy_deg)
    camera.alt.type = mujoco.mjtOrientation.mjORIENTATION_XYAXES
    camera.alt.xyaxes = exact([*pose.R_base_mj[:, 0], *pose.R_base_mj[:, 1]])


def _bin(world: mujoco.MjsBody, config: Config, color: str) -> None:
    """A bin on the table under ``bin_cm``: a floor and four walls."""
    body = world.add_body(name=f"bin_{color}", pos=exact(bin_origin_m(config, color)))
    for shape in bin_shapes(config, color):
        _scene_geom(body, shape.name, "box", shape.size, pos=exact(shape.pos), material="bin")
