r"""The twin's hobby-servo model: one :class:`ServoModel` per actuator, a kit, the ramp.

Each actuator — every actuated joint and the gripper — is a :class:`ServoModel` built from
its :class:`~mearm.sim.twin.mjcf.ServoSpec` datasheet facts and its pulse calibration
(:func:`servo_models`); a kit gives each servo its own unit's zero, scale, backlash and dead
band (:func:`kit_servos`). :func:`ramp` is the model's steps 3 and 4 (speed limit and
backlash) over a run of physics steps at once; the bus that drives it is
:class:`~mearm.sim.twin.twin_bus.TwinArm`.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from mearm.config import Config
from mearm.config.arm import US_PER_SERVO_DEG
from mearm.config.servo_file import replaced_calibration
from mearm.hardware.mapping import ActuatorMap, ServoMap
from mearm.kinematics.chain import Chain
from mearm.kinematics.errors import ModelError
from mearm.kinematics.urdf import jaw_joint_names
from mearm.sim.twin.mjcf import (
    GRIPPER_SERVO,
    GRIPPER_SERVO_TEXT,
    JOINT_SERVO_TEXT,
    M_PER_CM,
    SERVO_CATALOGUE,
    SERVO_LEVER_M,
    ServoSpec,
    recorded_servo,
    servo_tendon,
)
from mearm.sim.twin.servo_kit import ServoUnit, draw_kit, kit_seed

log = logging.getLogger(__name__)

#: Gear play of a hobby servo at its output, seen at the joint [deg]. An estimate: plastic-
#: gear micro servos (SG90 class) are commonly measured at 0.5–1° of play at the horn,
#: metal-gear ones (MG996R class) at the low end; no datasheet states it.
BACKLASH_DEG = 0.5


@dataclass(frozen=True)
class ServoModel:
    """One actuator's servo as the twin models it, in the model's units (rad or m).

    The setpoint and the potentiometer are in the units of the actuator's ``ctrl``: the
    joint's position, the jaws' opening, or for a servo that turns a combination of
    joints its tendon's length, the servo's value less its combination's offset.

    Attributes:
        name: The actuator's name (the joint's, or the gripper's).
        amap: Its pulse calibration and channel.
        scale: Model units per command unit (π/180 per deg, 0.01 per cm) [-].
        deadband: Targets this close to the potentiometer are ignored [rad or m].
        backlash: Play between the motor's setpoint and the joint's [rad or m].
        speed: Fastest the setpoint moves: the no-load speed [rad/s or m/s].
        ctrl_index: Its actuator's index in ``data.ctrl``.
        pot_qpos: The ``qpos`` entries the potentiometer reads (one joint; the joints of
            a combination; the gripper's two jaws, whose sum is its opening).
        pot_coef: Each entry's coefficient (model units); empty: 1 each.
        offset: The servo's value at ctrl 0 [rad or m]: its combination's offset.
        lever: Model units per radian of shaft: 1 for a revolute joint,
            :data:`~mearm.sim.twin.mjcf.SERVO_LEVER_M` for a linear one and the jaws.
        unit: The kit's unit this servo is (its own zero and scale,
            :mod:`mearm.sim.twin.servo_kit`); ``None``: the nominal servo.
        nominal: The arm's nominal calibration of this servo, which the kit's unit
            deviates from, when the bus's (``amap``) is another: a config whose servo
            calibration file was fitted to this kit (:func:`calibrated_kit`); ``None``:
            ``amap`` is the nominal one.
    """

    name: str
    amap: ActuatorMap
    scale: float
    deadband: float
    backlash: float
    speed: float
    ctrl_index: int
    pot_qpos: tuple[int, ...]
    pot_coef: tuple[float, ...] = ()
    offset: float = 0.0
    lever: float = 1.0
    unit: ServoUnit | None = None
    nominal: ActuatorMap | None = None

    @property
    def physical(self) -> ActuatorMap:
        """The nominal servo's mapping, which the unit's own is relative to."""
        return self.amap if self.nominal is None else self.nominal

    def target_of(self, pulse_us: float) -> float:
        """The setpoint a pulse asks for [rad or m]: where this unit turns for it."""
        if self.unit is not None:
            pulse_us = self.unit.nominal_pulse(pulse_us)
        return self.physical.value_of(pulse_us) * self.scale - self.offset

    def value_of(self, setpoint: float) -> float:
        """The servo's value [deg or cm] at a setpoint or potentiometer reading."""
        return (setpoint + self.offset) / self.scale

    @property
    def shaft_unit(self) -> float:
        """One degree of the servo's shaft in the model's units [rad or m per deg]."""
        return US_PER_SERVO_DEG / self.physical.us_per_unit * self.scale


def ramp(
    motor: np.ndarray,
    setpoint: np.ndarray,
    target: np.ndarray,
    step: np.ndarray,
    half_play: np.ndarray,
    n: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The motors' setpoints x and the joints' setpoints y for the next steps, ``(k, nu)`` each.

    Step by step, each motor's setpoint x moves toward its target by at most ``step``
    (``speed · dt``) and y follows x through the play (the twin's steps 3 and 4). The
    target holds for the whole run, so x is monotone and both have closed forms over the
    steps at once: x is the running sum of its steps (NumPy accumulates in order, so it
    is the step-by-step sum to the last bit) until it is within one step of the target,
    then the target; y is the running maximum of x − b/2 (x rising) or the running
    minimum of x + b/2 (x falling), from where it was. At most ``n`` steps, at least one.

    Args:
        motor: Each motor's setpoint x now [rad or m], (nu,).
        setpoint: Each joint's setpoint y now (its ``ctrl``) [rad or m], (nu,).
        target: Each servo's accepted target [rad or m], (nu,).
        step: How far x moves in one physics step [rad or m], (nu,).
        half_play: Half each servo's backlash, b/2 [rad or m], (nu,).
        n: The most steps to return.
    """
    gap = target - motor
    k = min(n, int(np.max(np.ceil(np.abs(gap) / step))) + 1)
    x = np.cumsum(np.vstack([motor, np.tile(np.sign(gap) * step, (k, 1))]), axis=0)
    arrived = np.logical_or.accumulate(np.abs(target - x[:-1]) <= step, axis=0)
    x = np.where(arrived, target, x[1:])
    low, high = x - half_play, x + half_play
    y = np.where(
        gap > 0,
        np.maximum(setpoint, np.maximum.accumulate(low, axis=0)),
        np.minimum(setpoint, np.minimum.accumulate(high, axis=0)),
    )
    return x, np.clip(y, low, high)


def kit_servos(
    servos: tuple[ServoModel, ...], config: Config, kit: tuple[ServoUnit, ...] | None
) -> tuple[tuple[ServoModel, ...], tuple[ServoUnit, ...] | None]:
    """The servos as a kit's units, and the kit: ``kit``, or the one ``config.twin.kit`` draws.

    ``None`` draws the kit ``config.twin.kit`` asks for (its seed; with ``per_trial``
    mixed with ``servo.error_model.seed``), or with no ``twin.kit`` leaves every servo
    nominal (returned as it is, with no kit).
    """
    if kit is None and config.twin.kit is not None:
        asked = config.twin.kit
        trial = config.servo.error_model.seed if asked.per_trial else None
        deadbands = [round(s.deadband / s.scale * s.amap.us_per_unit, 9) for s in servos]
        kit = draw_kit(deadbands, kit_seed(asked.seed, trial), asked.spread)
    if kit is None:
        return servos, None
    return with_kit(calibrated_kit(servos, config), tuple(kit)), tuple(kit)


def with_kit(servos: tuple[ServoModel, ...], kit: tuple[ServoUnit, ...]) -> tuple[ServoModel, ...]:
    """The servos as the kit's units: their own zero, scale, backlash and dead band."""
    if len(kit) != len(servos):
        raise ModelError(
            f"a kit of {len(kit)} servos for a twin of {len(servos)} "
            f"({', '.join(s.name for s in servos)}): one unit per servo"
        )
    out = []
    for s, unit in zip(servos, kit, strict=True):
        out.append(
            dataclasses.replace(
                s,
                unit=unit,
                deadband=unit.deadband_us / s.physical.us_per_unit * s.scale,
                backlash=math.radians(unit.backlash_deg) * s.lever,
            )
        )
    return tuple(out)


def calibrated_kit(servos: tuple[ServoModel, ...], config: Config) -> tuple[ServoModel, ...]:
    """The servos of a kit whose bus runs a servo calibration file fitted to it.

    A kit's unit turns relative to the arm's nominal servo; a config whose
    ``servo.calibration_file`` replaced that calibration sends the pulses the file gives,
    while each unit still turns as it is: its nominal is the calibration the file
    replaced (each actuator's ``replaces``, :func:`~mearm.config.servo_file.replaced_calibration`).
    Without a file, or one recording nothing replaced, the servos are returned as they are.
    """
    nominal_config = replaced_calibration(config)
    if nominal_config is None:
        if config.servo.calibration_file is not None:
            log.warning(
                "%s records no replaced calibration: the kit's units are taken relative "
                "to the calibration it gives",
                config.servo.calibration_file,
            )
        return servos
    nominal = ServoMap.from_arm(nominal_config.arm)
    out = []
    for s in servos:
        n = nominal[s.name]
        out.append(s if n == s.amap else dataclasses.replace(s, nominal=n))
    return tuple(out)


def _catalogued(m: mujoco.MjModel, text: str, what: str) -> ServoSpec | None:
    """The catalogue servo the model records in ``text``; None if it records none."""
    name = recorded_servo(m, text)
    if name is None:
        return None
    for spec in (*SERVO_CATALOGUE, GRIPPER_SERVO):
        if spec.name == name:
            return spec
    raise ModelError(
        f"the model's {what} servo {name!r} is none of the catalogue's "
        f"({', '.join(s.name for s in SERVO_CATALOGUE)}); pass "
        f"{'servo' if text == JOINT_SERVO_TEXT else 'gripper_servo'}=..."
    )


def _joint_servo(m: mujoco.MjModel, config: Config, chain: Chain) -> ServoSpec:
    """The joints' servo the model records.

    For a model without the record, the catalogue servo whose stall torque and speed the
    first joint's actuator has.
    """
    recorded = _catalogued(m, JOINT_SERVO_TEXT, "joint")
    if recorded is not None:
        return recorded
    name = chain.actuated[0]
    joint = config.arm.joints[int(chain.actuated_index[0])]
    lever = SERVO_LEVER_M if joint.type == "prismatic" else 1.0
    stall = float(m.actuator(name).forcerange[1]) * lever
    if m.actuator(name).trntype[0] == mujoco.mjtTrn.mjTRN_TENDON:  # a servo over joints
        damping = float(m.tendon_damping[m.tendon(servo_tendon(name)).id])
    else:
        damping = float(m.joint(name).damping[0])
    speed = stall / (damping * lever**2)
    for spec in SERVO_CATALOGUE:  # (MuJoCo writes a model's numbers to six digits)
        if math.isclose(spec.stall_torque_nm, stall, rel_tol=1e-4) and math.isclose(
            spec.speed_rad_s, speed, rel_tol=1e-4
        ):
            return spec
    raise ModelError(
        f"the model's servo on {name} ({stall:.3g} N·m, {speed:.3g} rad/s) is none of the "
        f"catalogue's ({', '.join(s.name for s in SERVO_CATALOGUE)}); pass servo=..."
    )


def servo_models(
    m: mujoco.MjModel,
    config: Config,
    chain: Chain,
    servo: ServoSpec | None,
    gripper_servo: ServoSpec | None,
    backlash_deg: float,
) -> tuple[ServoModel, ...]:
    """Each actuator's nominal :class:`ServoModel`: joints in chain order, then the gripper.

    Raises:
        ModelError: the model lacks an actuator or joint of ``config``'s arm, or its
            servo is none of the catalogue's and ``servo``/``gripper_servo`` is not given.
    """
    smap = ServoMap.from_arm(config.arm)
    play = math.radians(backlash_deg)
    out = []
    try:
        spec = servo if servo is not None else _joint_servo(m, config, chain)
        gripper_spec = gripper_servo or _catalogued(m, GRIPPER_SERVO_TEXT, "gripper")
        gripper_spec = gripper_spec or GRIPPER_SERVO
        for k, name in enumerate(chain.actuated):
            i = int(chain.actuated_index[k])
            lever = SERVO_LEVER_M if config.arm.joints[i].type == "prismatic" else 1.0
            amap = smap[name]
            scale = float(chain.scale[i])
            # the potentiometer reads what the servo turns: its joint, or its combination
            # (in model units, as the MJCF's tendon has it)
            terms = amap.terms if amap.combined else ((name, 1.0),)
            pot_qpos = tuple(int(m.joint(n).qposadr[0]) for n, _ in terms)
            pot_coef = tuple(c * scale / float(chain.scale[chain.names.index(n)]) for n, c in terms)
            out.append(
                ServoModel(
                    name,
                    amap,
                    scale,
                    spec.deadband_us / amap.us_per_unit * scale,
                    play * lever,
                    spec.speed_rad_s * lever,
                    m.actuator(name).id,
                    pot_qpos,
                    pot_coef,
                    amap.offset * scale if amap.combined else 0.0,
                    lever,
                )
            )
        g = smap.gripper
        jaws = tuple(int(m.joint(j).qposadr[0]) for j in jaw_joint_names(config.arm))
        out.append(
            ServoModel(
                g.name,
                g,
                M_PER_CM,
                gripper_spec.deadband_us / g.us_per_unit * M_PER_CM,
                play * SERVO_LEVER_M,
                gripper_spec.speed_rad_s * SERVO_LEVER_M,
                m.actuator(g.name).id,
                jaws,
                lever=SERVO_LEVER_M,
            )
        )
    except KeyError as exc:
        raise ModelError(
            f"the model is not the twin of arm {config.arm.name}: {exc}; build it with "
            "twin_model(config)"
        ) from None
    return tuple(out)
