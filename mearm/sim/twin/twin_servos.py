r"""The twin's servos in the model: what each turns, its gains and the catalogue choice.

A joint servo turns its own joint or, with ``drives``, a combination of joints (a fixed
tendon; :mod:`mearm.sim.twin.mjcf` says why). :func:`_servo_kv` damps each critically at
home through the coupling; :func:`_max_load` is the gravity load the catalogue choice
weighs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from mearm.config import Config, Joint
from mearm.config.servo_models import ServoSpec
from mearm.kinematics.chain import Chain
from mearm.kinematics.urdf import jaw_joint_names

#: Lever turning a servo's torque into a linear force: a prismatic joint's drive and the
#: gripper's jaw linkage (estimate: a 2 cm horn) [m].
SERVO_LEVER_M = 0.02
#: Damping ratio of each servo at home [-]: critical, so it settles without overshoot.
SERVO_DAMPING_RATIO = 1.0
#: Seeded poses at which the servo selection checks the gravity load.
LOAD_POSES = 16


def _capacity(joint: Joint, spec: ServoSpec) -> float:
    """What a servo can hold on this joint [N·m, or N for a prismatic one]."""
    if joint.type == "prismatic":
        return spec.stall_torque_nm / SERVO_LEVER_M
    return spec.stall_torque_nm


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
