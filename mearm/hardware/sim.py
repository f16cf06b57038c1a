"""The simulated arm: a servo backend that moves a model arm over a :class:`World`.

Each move realises the command the way a real servo would miss it (SPEC §5, the
``servo.error_model`` of the config):

1. quantisation — ``microsecond``: the integer-µs pulse the serial backends send;
   ``degree``: the whole servo degree of ``Servo.write`` (its 0–180° scale spans the
   channel's [min_us, max_us]; Arduino's integer ``map()`` gives the pulse); ``none``;
2. the pulse is mapped back to a DH angle through the channel's mapping;
3. a static per-joint offset and per-move Gaussian noise are added (θ1–θ3).

The end effector is the forward kinematics of the realised joints (θ4 from the
parallelogram). Closing the gripper grips the table object nearest the EE if the EE is
within ``servo.grip_tolerance_cm`` of it in the plane and of ``robot.gripper.
pick_height_cm`` in z; otherwise the pick fails and the object stays. Opening it drops the
held object into the nearest bin within ``servo.bin_radius_cm`` (in the plane), or, with
no bin that close, onto the table under the EE. θ5 does not enter the EE (the DH table's
a4 = 14 cm already folds in the gripper arm, SPEC §2).

The sim does not sleep unless ``servo.sim_realtime`` is set.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Literal

import numpy as np

from mearm.config import Color, Config
from mearm.exceptions import TargetError
from mearm.hardware.bus import ArmCommand, ServoBus
from mearm.hardware.mapping import JointMap, ServoMap
from mearm.kinematics import ArmModel, check_target, couple
from mearm.world import World

log = logging.getLogger(__name__)

Quantization = Literal["none", "degree", "microsecond"]


def quantize_deg(jmap: JointMap, angle_deg: float, mode: Quantization) -> float:
    """The DH angle a servo realises for a commanded one after command quantisation [deg].

    Args:
        jmap: The joint's channel mapping.
        angle_deg: Commanded DH angle [deg], within the joint's limits.
        mode: ``none``, ``microsecond`` (integer-µs pulse) or ``degree`` (``Servo.write``).
    """
    if mode == "none":
        return float(angle_deg)
    if mode == "microsecond":
        return jmap.angle_deg(jmap.command_us(angle_deg))
    if mode == "degree":
        return jmap.angle_deg(jmap.servo_degree_us(jmap.servo_degree(angle_deg)))
    raise ValueError(f"quantization must be none, degree or microsecond, got {mode!r}")


@dataclass(frozen=True)
class GripResult:
    """What closing the gripper did.

    Attributes:
        success: Whether an object was gripped.
        object_id: The nearest table object (gripped or not), or ``None`` if the table is empty.
        distance_cm: EE to that object in the plane [cm].
        dz_cm: EE height minus the pick height [cm].
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
        bin: The bin it fell into, or ``None`` if it landed on the table.
        x_cm: Where it ended, x [cm].
        y_cm: Where it ended, y [cm].
    """

    object_id: str
    bin: Color | None
    x_cm: float
    y_cm: float


class SimArm(ServoBus):
    """Simulated servos, arm and gripper acting on a shared :class:`World`.

    Args:
        config: The whole configuration.
        world: The table the simulated camera renders.
        model: Arm model for the EE (built from ``config.robot`` if omitted).

    Attributes:
        world: The shared world.
        actual_joints_deg: Realised (θ1, θ2, θ3) [deg], (3,); home before the first move.
        actual_gripper_arm_deg: Realised θ5 [deg].
        gripper_closed: Whether the gripper is closed.
        last_grip: The outcome of the last close, or ``None``.
        last_release: The outcome of the last release of an object, or ``None``.
    """

    def __init__(self, config: Config, world: World, *, model: ArmModel | None = None):
        super().__init__(config, paced=config.servo.sim_realtime)
        self.world = world
        self.model = model if model is not None else ArmModel(config.robot)
        self.error_model = config.servo.error_model
        self._rng = np.random.default_rng(self.error_model.seed)
        self.actual_joints_deg = np.array(config.robot.home_deg, dtype=float)
        self.actual_gripper_arm_deg = float(config.robot.gripper.home_angle_deg)
        self.gripper_closed = False
        self.last_grip: GripResult | None = None
        self.last_release: ReleaseResult | None = None

    @property
    def ee_cm(self) -> np.ndarray:
        """The realised EE position in the base frame [cm], (3,)."""
        return ee_from_joints_cm(self.model, self.actual_joints_deg)

    def realise_deg(self, command: ArmCommand) -> np.ndarray:
        """Realised (θ1, θ2, θ3) for a command: quantised, offset, noisy [deg], (3,).

        Draws the noise, so each call is one move's worth of it.
        """
        em = self.error_model
        q = np.array(
            [
                quantize_deg(j, a, em.quantization)
                for j, a in zip(self.servo_map.joints, command.joints_deg, strict=True)
            ]
        )
        q += np.asarray(em.offset_deg, dtype=float)
        if em.noise_std_deg > 0:
            q += self._rng.normal(0.0, em.noise_std_deg, size=3)
        return q

    # ----------------------------------------------------------------- backend hooks

    def _connect(self) -> None:
        log.info(
            "sim arm: %d objects on the table, quantization %s",
            len(self.world.table_objects()),
            self.error_model.quantization,
        )

    def _send_move(self, command: ArmCommand, pulses_us: dict[int, int]) -> None:
        # A servo told to hold its angle stays where it is: only a new joint command
        # draws a new error (else gripping would re-roll the pose the route ended in).
        if self.state is None or self.state.joints_deg != command.joints_deg:
            self.actual_joints_deg = self.realise_deg(command)
        self.actual_gripper_arm_deg = quantize_deg(
            self.servo_map.gripper_arm, command.gripper_arm_deg, self.error_model.quantization
        )
        if command.gripper_closed and not self.gripper_closed:
            self.gripper_closed = True
            self.last_grip = self._close_gripper()
        elif not command.gripper_closed and self.gripper_closed:
            self.gripper_closed = False
            self._open_gripper()

    def _stop(self) -> None:
        """Moves are instantaneous in the sim: nothing is in progress to stop."""

    def _close(self) -> None:
        """Nothing to release."""

    # ----------------------------------------------------------------- gripper

    def _close_gripper(self) -> GripResult:
        x, y, z = self.ee_cm
        obj, dist = self.world.nearest_on_table(float(x), float(y))
        dz = float(z) - self.config.robot.gripper.pick_height_cm
        if obj is None:
            log.info("sim grip: nothing on the table")
            return GripResult(False, None, float("inf"), dz)
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

    def _open_gripper(self) -> None:
        if self.world.held_object() is None:
            return
        x, y, _ = self.ee_cm
        color, dist = self.world.nearest_bin(float(x), float(y))
        if color is not None and dist <= self.config.servo.bin_radius_cm:
            obj = self.world.release_into_bin(color)
            self.last_release = ReleaseResult(obj.id, color, obj.x_cm, obj.y_cm)
        else:
            obj = self.world.release_on_table(float(x), float(y))
            self.last_release = ReleaseResult(obj.id, None, obj.x_cm, obj.y_cm)
        log.info("sim release %s: %s", obj.id, f"bin {color}" if obj.bin else "on the table")


def ee_from_joints_cm(model: ArmModel, joints_deg: np.ndarray) -> np.ndarray:
    """EE position [cm], (3,), of (θ1, θ2, θ3) [deg] with θ4 from the parallelogram."""
    return model.fk_cm(np.radians(couple(joints_deg)))


def random_reachable_joints_deg(config: Config, n: int, seed: int = 0) -> np.ndarray:
    """Joint angles of ``n`` random reachable EE targets [deg], (n, 3).

    Targets are drawn uniformly in the Table 3 box (SPEC §3); those out of reach are
    dropped and redrawn; the joints come from the closed-form IK.
    """
    rng = np.random.default_rng(seed)
    box = config.robot.target_box
    lo = np.array([box.x_cm.min, box.y_cm.min, box.z_cm.min])
    hi = np.array([box.x_cm.max, box.y_cm.max, box.z_cm.max])
    out: list[np.ndarray] = []
    while len(out) < n:
        target = rng.uniform(lo, hi)
        try:
            out.append(check_target(target, config.robot)[:3])
        except TargetError:
            continue
    return np.array(out)


def quantization_ee_error_cm(
    config: Config, mode: Quantization, n: int = 2000, seed: int = 0
) -> np.ndarray:
    """EE error caused by command quantisation alone over random reachable poses [cm], (n,).

    Each pose's joints are quantised as :func:`quantize_deg` does; the error is the
    distance between the FK of the quantised and of the exact joints.
    """
    smap = ServoMap.from_config(config)
    model = ArmModel(config.robot)
    errors = np.empty(n)
    for i, q in enumerate(random_reachable_joints_deg(config, n, seed)):
        qq = np.array([quantize_deg(j, a, mode) for j, a in zip(smap.joints, q, strict=True)])
        errors[i] = np.linalg.norm(ee_from_joints_cm(model, qq) - ee_from_joints_cm(model, q))
    return errors
