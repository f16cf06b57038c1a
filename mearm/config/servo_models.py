"""Hobby servos' datasheet facts, with their sources: what the physical twin models.

A config names a servo model by its :attr:`ServoSpec.name` (``twin.joint_servo``,
``twin.gripper_servo``); :mod:`mearm.sim.twin.mjcf` turns the facts into MuJoCo actuators and
:mod:`mearm.sim.twin.twin_bus` into the servo bus's dead band and speed limit. Plain data: it
imports nothing heavier than the standard library.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

KGCM_TO_NM = 9.80665e-2  # 1 kg·cm of servo torque in N·m
#: Error at which a hobby servo's amplifier saturates (estimate: ~1° for the digital and
#: analogue servos above) [rad].
FULL_TORQUE_ERROR_RAD = math.radians(1.0)
#: Mechanical time constant of a small brushed DC motor (estimate: 20–30 ms) [s].
MOTOR_TIME_CONSTANT_S = 0.025


@dataclass(frozen=True)
class ServoSpec:
    """A hobby servo's datasheet facts.

    Attributes:
        name: The model, e.g. ``"SG90"``.
        mass_kg: Mass [kg].
        stall_torque_nm: Stall torque at the rated voltage [N·m].
        seconds_per_60deg: No-load speed at that voltage [s/60°].
        deadband_us: Dead band width [µs] (for the servo bus).
        size_m: Case length, width, height (height along the output shaft) [m].
        source: Where the figures come from.
    """

    name: str
    mass_kg: float
    stall_torque_nm: float
    seconds_per_60deg: float
    deadband_us: float
    size_m: tuple[float, float, float]
    source: str

    @property
    def speed_rad_s(self) -> float:
        """No-load speed [rad/s]."""
        return math.radians(60.0) / self.seconds_per_60deg

    @property
    def kp(self) -> float:
        """Position gain: the stall torque at :data:`FULL_TORQUE_ERROR_RAD` [N·m/rad]."""
        return self.stall_torque_nm / FULL_TORQUE_ERROR_RAD

    @property
    def armature(self) -> float:
        r"""The motor's inertia seen at the output [kg·m²].

        A DC motor's mechanical time constant is :math:`t_m = J\,\omega_0/\tau_s`, so with
        :data:`MOTOR_TIME_CONSTANT_S`, :math:`J = t_m \tau_s / \omega_0`.
        """
        return MOTOR_TIME_CONSTANT_S * self.stall_torque_nm / self.speed_rad_s

    @property
    def motor_damping(self) -> float:
        r"""The motor's back-EMF damping seen at the output [N·m·s/rad].

        The slope of a DC motor's torque–speed line, :math:`b = \tau_s/\omega_0`: with the
        amplifier saturated the servo turns at its datasheet speed.
        """
        return self.stall_torque_nm / self.speed_rad_s


SG90 = ServoSpec(
    name="SG90",
    mass_kg=0.009,
    stall_torque_nm=1.8 * KGCM_TO_NM,
    seconds_per_60deg=0.10,
    deadband_us=10.0,
    size_m=(0.0222, 0.0118, 0.031),
    source=(
        "typical TowerPro SG90 datasheet: 9 g, 1.8 kg·cm at 4.8 V, 0.1 s/60°, dead band 10 µs, "
        "22.2 × 11.8 × 31 mm"
    ),
)
MG90S = ServoSpec(
    name="MG90S",
    mass_kg=0.0134,
    stall_torque_nm=1.8 * KGCM_TO_NM,
    seconds_per_60deg=0.10,
    deadband_us=5.0,
    size_m=(0.0228, 0.0122, 0.0285),
    source=(
        "typical TowerPro MG90S datasheet: 13.4 g, 1.8 kg·cm at 4.8 V, 0.1 s/60°, dead band "
        "5 µs, 22.8 × 12.2 × 28.5 mm"
    ),
)
MG996R = ServoSpec(
    name="MG996R",
    mass_kg=0.055,
    stall_torque_nm=9.4 * KGCM_TO_NM,
    seconds_per_60deg=0.17,
    deadband_us=5.0,
    size_m=(0.0407, 0.0197, 0.0429),
    source=(
        "typical TowerPro MG996R datasheet: 55 g, 9.4 kg·cm at 4.8 V, 0.17 s/60°, dead band "
        "5 µs, 40.7 × 19.7 × 42.9 mm"
    ),
)
RDS3135 = ServoSpec(
    name="RDS3135",
    mass_kg=0.065,
    stall_torque_nm=35.0 * KGCM_TO_NM,
    seconds_per_60deg=0.15,
    deadband_us=3.0,
    size_m=(0.040, 0.020, 0.0405),
    source=(
        "approximate, from vendor listings (DSServo RDS3135, the paper's joint servo): "
        "35 kg·cm at 6.8 V, about 0.15 s/60°, about 65 g, dead band about 3 µs, 40 × 20 × 40.5 mm"
    ),
)
#: The servos the joints may get, weakest first.
SERVO_CATALOGUE: tuple[ServoSpec, ...] = (SG90, MG90S, MG996R, RDS3135)
#: The gripper's servo (a claw needs little torque; the MeArm's is an SG90).
GRIPPER_SERVO = SG90
#: A joint's servo must hold its worst static load with this margin (rule of thumb) [-].
SERVO_LOAD_FACTOR = 3.0


def servo_named(name: str) -> ServoSpec:
    """The catalogue's servo of that name.

    Raises:
        KeyError: no such servo; the message lists the catalogue.
    """
    for spec in SERVO_CATALOGUE:
        if spec.name == name:
            return spec
    raise KeyError(f"no servo model {name!r}; known: {', '.join(SERVO_NAMES)}")


#: The names a config may give (``twin.joint_servo``, ``twin.gripper_servo``).
SERVO_NAMES: tuple[str, ...] = tuple(s.name for s in SERVO_CATALOGUE)
