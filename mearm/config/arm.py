r"""The arm as data: joints, their actuators or couplings, the tool, the target box.

An arm is an ordered list of joints, each one standard Denavit–Hartenberg row

.. math:: T_{i-1,i} = R_z(\theta_i)\,T_z(d_i)\,T_x(a_i)\,R_x(\alpha_i)

whose variable is θ (``revolute``, degrees) or d (``prismatic``, centimetres). A joint is
either *actuated* — it has a ``servo`` with its pulse calibration, its limits and its home
value — or *passive*: an affine function of the actuated joints,

.. math:: q_p = \sum_j c_{pj}\, q_j + c_p

(the paper's parallelogram: θ4 = −θ2 − θ3). The actuated joints are the chain's
independent coordinates. Each one's servo turns, by default, that joint alone; a servo
may instead turn a linear combination of actuated joints (its ``drives``),

.. math:: v_k = \sum_j a_{kj}\, q_j + a_k

(the MeArm's elbow servo sets the forearm's angle to the table: v = θ2 + θ3), and its
calibration maps v, not the joint's own value, to a pulse. The servos' combinations must
be independent — the square matrix :math:`A = (a_{kj})` invertible — so that the pulses
fix every actuated joint (:meth:`ArmDescription.servo_matrix`).

The tool sits on the last frame: the tool centre point (TCP), the axis it approaches
along, the gripper (a named actuator with its own calibration, open/closed settings and
jaw geometry) and any tool actuators that do not move the TCP (the paper's gripper-arm
servo).

Everything is checked when the config loads: names unique, couplings and servo
combinations naming actuated joints, the combinations independent, every limit and
setting inside its servo's pulse range (for a servo over several joints: its value at
home, since its pulse then depends on the pose), a chain that can move the TCP in three
directions. For planning, a passive joint that follows a servo over several joints is held
to what that servo reaches (:meth:`ArmDescription.within_servos`).
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field, model_validator

from mearm.config.base import Name, Range, Strict
from mearm.config.joints import Coupling, DHRow, Joint, JointType
from mearm.config.servo_calibration import (
    ACCEL_DEG_S2_RANGE,
    MAX_COUPLING,
    MAX_PLAY_US,
    MAX_ZERO_US,
    SECONDS_PER_60DEG_RANGE,
    US_PER_SERVO_DEG,
    US_PER_UNIT_RANGE,
    Coefficient,
    JointServo,
    ServoCalibration,
    ServoDrives,
    combination_text,
)
from mearm.config.tool import MIN_JAW_CM, ClawMarker, Gripper, Tool, ToolActuator

__all__ = [
    "ACCEL_DEG_S2_RANGE",
    "MAX_COUPLING",
    "MAX_PLAY_US",
    "MAX_ZERO_US",
    "MIN_JAW_CM",
    "SECONDS_PER_60DEG_RANGE",
    "US_PER_SERVO_DEG",
    "US_PER_UNIT_RANGE",
    "ArmDescription",
    "ClawMarker",
    "Coefficient",
    "Coupling",
    "DHRow",
    "Gripper",
    "Joint",
    "JointServo",
    "JointType",
    "ServoCalibration",
    "ServoDrives",
    "TargetBox",
    "Tool",
    "ToolActuator",
    "combination_text",
]


class TargetBox(Strict):
    """Where TCP targets may lie, base frame [cm] (the paper's Table 3 for its arm)."""

    x_cm: Range = Range(min=-40, max=40)
    y_cm: Range = Range(min=20, max=60)
    z_cm: Range = Range(min=10, max=60)


def _interval(terms: dict[str, float], offset: float, limits: dict[str, Range]) -> Range:
    lo = hi = offset
    for name, c in terms.items():
        a, b = c * limits[name].min, c * limits[name].max
        lo, hi = lo + min(a, b), hi + max(a, b)
    if not lo < hi:
        hi = lo + 1e-9
    return Range.model_construct(min=lo, max=hi)  # derived, may exceed a config's bounds


def _servo_reach(
    coupling: Coupling, combo: ServoDrives, servo: ServoCalibration
) -> tuple[float, float] | None:
    r"""The passive joint's values the servo's pulse range allows, or ``None``.

    ``None`` unless the coupling :math:`q_p = \sum_j c_j q_j + c_p` is a multiple of the
    servo's combination :math:`v = \sum_j a_j q_j + a_0`, :math:`c = k\,a`: then
    :math:`q_p = k\,(v - a_0) + c_p`, and :math:`v` ranges over the servo's values at
    ``min_us`` and ``max_us``.
    """
    names = set(combo.terms) | set(coupling.terms)
    first = next(iter(combo.terms))
    if combo.terms[first] == 0 or set(combo.terms) != set(coupling.terms):
        return None
    k = coupling.terms[first] / combo.terms[first]
    if k == 0 or any(
        not math.isclose(coupling.terms[n], k * combo.terms[n], rel_tol=1e-12, abs_tol=1e-12)
        for n in names
    ):
        return None
    v_lo, v_hi = servo.value_range()
    a, b = (k * (v - combo.offset) + coupling.offset for v in (v_lo, v_hi))
    return (min(a, b), max(a, b))


#: Seeded poses tried by the chain's rank check.
_RANK_POSES = 24


class ArmDescription(Strict):
    """The whole arm: the chain, the tool and the target box.

    Attributes:
        name: The arm's name (the URDF's robot name).
        joints: The chain, base first.
        tool: TCP, approach axis, gripper and tool actuators.
        target_box: Where targets may lie.
        closed_form: A registered closed-form IK plug-in for this arm, or ``null``.
    """

    name: Name
    joints: list[Joint] = Field(min_length=1, max_length=12)
    tool: Tool
    target_box: TargetBox = TargetBox()
    closed_form: Name | None = None

    @model_validator(mode="after")
    def _consistent(self) -> ArmDescription:
        names = [j.name for j in self.joints]
        tool_names = [a.name for a in self.tool.actuators] + [self.tool.gripper.name]
        seen: set[str] = set()
        for n in names + tool_names:
            if n in seen:
                raise ValueError(f"name '{n}' is used twice (joints and tool actuators)")
            seen.add(n)
        actuated = [j.name for j in self.joints if j.actuated]
        if not actuated:
            raise ValueError("@joints: no joint is actuated: give at least one a 'servo'")
        for j in self.joints:
            if j.coupling is None:
                continue
            for term in j.coupling.terms:
                if term not in actuated:
                    allowed = ", ".join(actuated)
                    raise ValueError(
                        f"@joints.{j.name}.coupling.terms: '{term}' is not an actuated joint of "
                        f"this arm (actuated: {allowed})"
                    )
        channels: dict[int, str] = {}
        servos: list[tuple[str, ServoCalibration]] = [
            (j.name, j.servo) for j in self.joints if j.servo is not None
        ]
        servos += [(a.name, a.servo) for a in self.tool.actuators]
        servos.append((self.tool.gripper.name, self.tool.gripper.servo))
        for name, servo in servos:
            if servo.channel in channels:
                raise ValueError(
                    f"@joints: {name} and {channels[servo.channel]} share servo channel "
                    f"{servo.channel}"
                )
            channels[servo.channel] = name
        self._check_drives()
        self._check_rank()
        return self

    def _check_drives(self) -> None:
        """Refuse servo combinations naming a missing or passive joint, or not independent.

        Also a servo over several joints whose value at home needs a pulse outside its
        range: the arm could not go home.
        """
        index = {j.name: i for i, j in enumerate(self.joints)}
        actuated = [j.name for j in self.joints if j.actuated]
        for j in self.joints:
            if j.servo is None or j.servo.drives is None:
                continue
            for term in j.servo.drives.terms:
                if term not in index:
                    raise ValueError(
                        f"@joints.{j.name}.servo.drives.terms: '{term}' is not a joint of this arm "
                        f"(its actuated joints: {', '.join(actuated)})"
                    )
                if term not in actuated:
                    raise ValueError(
                        f"@joints.{j.name}.servo.drives.terms: '{term}' is a passive joint (its "
                        "coupling sets it); a servo turns actuated joints: "
                        f"{', '.join(actuated)}"
                    )
        A, _ = self.servo_matrix()
        act = self.actuated_joints()
        scale = np.abs(A).max(axis=1, keepdims=True)
        rows = A / scale  # each row's largest coefficient 1: the rank test sees shapes
        for k in range(len(act)):
            if np.linalg.matrix_rank(rows[: k + 1], tol=1e-9) == k + 1:
                continue
            # the rows that depend on each other: a left null vector of rows[:k + 1]
            _, _, vt = np.linalg.svd(rows[: k + 1].T)
            involved = [r for r in range(k + 1) if abs(vt[-1, r]) > 1e-6]
            named = [r for r in involved if getattr(act[r].servo, "drives", None) is not None]
            blame = named[-1] if named else k
            joint = act[blame]
            assert joint.servo is not None
            others = [act[r].name for r in involved if r != blame]
            raise ValueError(
                f"@joints.{joint.name}.servo.drives: {joint.name}'s servo turns "
                f"{joint.servo.combination(joint.name).text()}, which depends on what the "
                f"servo{'s' if len(others) > 1 else ''} of {', '.join(others)} turn"
                f"{'' if len(others) > 1 else 's'}: the servos' combinations must be "
                "independent, or the pulses cannot set every actuated joint"
            )
        home = self.home()
        for j in self.joints:
            if j.servo is None or j.servo.drives_only(j.name):
                continue
            combo = j.servo.combination(j.name)
            v = combo.offset + sum(c * home[n] for n, c in combo.terms.items())
            p = j.servo.pulse_us(v)
            if not j.servo.min_us - 1e-6 <= p <= j.servo.max_us + 1e-6:
                lo, hi = j.servo.value_range()
                raise ValueError(
                    f"@joints.{j.name}.servo.drives: at home its servo's value {combo.text()} is "
                    f"{v:g}, which needs a {p:.0f} µs pulse, outside the servo's "
                    f"[{j.servo.min_us}, {j.servo.max_us}] µs, which allows [{lo:.4g}, {hi:.4g}]"
                )

    # ----------------------------------------------------------------- derived

    def actuated_joints(self) -> list[Joint]:
        """The actuated joints, in chain order."""
        return [j for j in self.joints if j.actuated]

    def joint_limits(self) -> dict[str, Range]:
        """Every joint's limits; a passive joint without its own, from its coupling."""
        limits = {j.name: j.limits for j in self.joints if j.limits is not None}
        out: dict[str, Range] = {}
        for j in self.joints:
            if j.limits is not None:
                out[j.name] = j.limits
            else:
                assert j.coupling is not None
                out[j.name] = _interval(j.coupling.terms, j.coupling.offset, limits)
        return out

    def within_servos(self) -> ArmDescription:
        """This arm with its limits narrowed to what its servos reach: what plans keep to.

        A servo that turns its own joint alone holds the joint's limits in its pulse range
        (the config is refused otherwise). One over a combination of joints need not: the
        box of the MeArm's shoulder and elbow limits holds poses its elbow servo, turning
        shoulder + elbow within ±75°, cannot take. A passive joint that follows such a
        servo (its coupling a multiple of the servo's combination, plus an offset: the
        levelled wrist is −(shoulder + elbow)) takes what the servo reaches as its own
        limits (:func:`_servo_reach`), so a model of this arm — its chain, closed form and
        every solver on it — keeps inside the pulse range, and a target only beyond it is
        refused by the solve, naming the servo (:meth:`limits_reason`). Where nothing
        narrows, ``self``. Not validated again: the passive value at home is inside the
        servo's reach (the config checks the servo's value there), so the limits meet.
        """
        limits = self.joint_limits()
        joints = []
        for j in self.joints:
            lo, hi = limits[j.name].min, limits[j.name].max
            for _, reach in self._servo_bounds(j):
                lo, hi = max(lo, reach[0]), min(hi, reach[1])
            if (lo, hi) == (limits[j.name].min, limits[j.name].max):
                joints.append(j)
            else:
                narrowed = Range.model_construct(min=lo, max=max(hi, lo + 1e-9))
                joints.append(j.model_copy(update={"limits": narrowed}))
        if joints == self.joints:
            return self
        return self.model_copy(update={"joints": joints})

    def limits_reason(self, name: str) -> str | None:
        """Why joint ``name``'s limits end where they do, when a servo sets an end, or ``None``.

        A passive joint held to what a servo over a combination reaches
        (:meth:`within_servos`): ``what elbow's servo (shoulder + elbow) reaches in its pulse
        range, 544..2400 µs``.
        """
        joint = next((j for j in self.joints if j.name == name), None)
        if joint is None:
            return None
        own = self.joint_limits()[name]
        for servo_joint, reach in self._servo_bounds(joint):
            ends = zip(reach, (own.min, own.max), strict=True)
            if any(math.isclose(a, b, abs_tol=1e-9) for a, b in ends):
                assert servo_joint.servo is not None  # _servo_bounds yields servos' joints
                s = servo_joint.servo
                return (
                    f"what {servo_joint.name}'s servo "
                    f"({s.combination(servo_joint.name).text()}) reaches in its pulse "
                    f"range, {s.min_us}..{s.max_us} µs"
                )
        return None

    def _servo_bounds(self, joint: Joint) -> list[tuple[Joint, tuple[float, float]]]:
        """Each servo over a combination a passive joint follows, and what it allows it."""
        if joint.coupling is None:
            return []
        out = []
        for j in self.joints:
            if j.servo is None or j.servo.drives_only(j.name):
                continue
            reach = _servo_reach(joint.coupling, j.servo.combination(j.name), j.servo)
            if reach is not None:
                out.append((j, reach))
        return out

    def full_values(self, actuated: dict[str, float]) -> dict[str, float]:
        """Every joint's value from the actuated ones [deg or cm]."""
        out: dict[str, float] = {}
        for j in self.joints:
            if j.coupling is None:
                out[j.name] = float(actuated[j.name])
            else:
                out[j.name] = j.coupling.offset + sum(
                    c * float(actuated[n]) for n, c in j.coupling.terms.items()
                )
        return out

    def servo_matrix(self) -> tuple[np.ndarray, np.ndarray]:
        r"""What the actuated joints' servos turn: :math:`v = A\,q_a + a`, config units.

        Returns:
            ``A`` (m, m): row k is the combination the servo of the k-th actuated joint
            turns, columns the actuated joints in chain order (the identity when every
            servo turns its own joint); ``a`` (m,): the offsets.
        """
        act = self.actuated_joints()
        col = {j.name: k for k, j in enumerate(act)}
        A = np.zeros((len(act), len(act)))
        a = np.zeros(len(act))
        for k, j in enumerate(act):
            assert j.servo is not None
            combo = j.servo.combination(j.name)
            for name, c in combo.terms.items():
                if name in col:  # a name outside them is refused by the validator
                    A[k, col[name]] = c
            a[k] = combo.offset
        return A, a

    def home(self) -> dict[str, float]:
        """Home of the actuated joints [deg or cm]."""
        return {j.name: float(j.home) for j in self.joints if j.home is not None}

    def tcp_cm(self, values: dict[str, float]) -> np.ndarray:
        """TCP position [cm], (3,), by the DH product (values of every joint, deg or cm)."""
        T = np.eye(4)
        for j in self.joints:
            v = values[j.name]
            T = T @ j.dh.transform(math.radians(v) if j.type == "revolute" else v, j.type)
        return (T @ np.array([*self.tool.tcp_cm, 1.0]))[:3]

    def _check_rank(self) -> None:
        """Refuse a chain that cannot move the TCP in three independent directions."""
        act = self.actuated_joints()
        limits = {j.name: j.limits for j in act}
        rng = np.random.default_rng(0)
        need = min(3, len(act))
        best = 0
        for k in range(_RANK_POSES):
            if k == 0:
                base = self.home()
            else:
                base = {
                    n: float(rng.uniform(r.min, r.max)) for n, r in limits.items() if r is not None
                }
            p0 = self.tcp_cm(self.full_values(base))
            cols = []
            for n in base:
                h = 1e-4
                moved = dict(base)
                moved[n] += h
                cols.append((self.tcp_cm(self.full_values(moved)) - p0) / h)
            rank = int(np.linalg.matrix_rank(np.stack(cols, axis=1), tol=1e-6))
            best = max(best, rank)
            if best >= need:
                return
        raise ValueError(
            f"@joints: singular chain: the TCP moves in at most {best} independent direction(s) "
            f"at {_RANK_POSES} poses within the limits; a sorting arm needs {need}"
            " (check the DH rows: lengths a_cm/d_cm and twists alpha_deg)"
        )


def link_width_m(arm: ArmDescription) -> float:
    """The plates' width: a sixtieth of the arm's reach, 6–20 mm (as the URDF draws it).

    Here, with the arm's description, so that the config's own checks (a belt clear of
    the base plate) and every model (:mod:`mearm.kinematics.bodies`) size the plates
    alike.
    """
    reach = sum(abs(j.dh.a_cm) + abs(j.dh.d_cm) for j in arm.joints) * 0.01  # [m]
    return max(0.006, min(0.02, reach / 60))


def base_radius_m(arm: ArmDescription) -> float:
    """The base plate's radius [m]."""
    return link_width_m(arm) * 3.3
