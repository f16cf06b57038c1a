r"""Closed-form IK as plug-ins, registered for the arms that have one; the target checks.

An arm description may name a closed form (``arm.closed_form``); :func:`closed_form_for`
builds it, checking that the arm really has the structure the formula assumes. The
generic solvers never need one: it seeds and cross-checks them where it exists.

``planar_wrist`` — a base yaw joint (α = 90°), two planar links and a passive wrist held
level by a parallelogram (wrist = −shoulder − elbow): the paper's arm and the MeArm.
The TCP then sits at

.. math::
    \rho = a_1 + a_2\cos\theta_2 + a_3\cos(\theta_2+\theta_3) + a_4 + t_x, \qquad
    z = d_1 + a_2\sin\theta_2 + a_3\sin(\theta_2+\theta_3) + t_y

along the horizontal direction θ1 (``t`` the TCP offset in the last frame). With θ3 < 0
(the elbow-up branch) each base angle gives one solution, and two base angles put the TCP
over the target: θ1 = atan2(y, x) with ρ = √(x² + y²), the base facing the target, and
θ1 ± 180° with ρ = −√(x² + y²), the arm reaching back over the top. The first is taken
whenever it is within the limits; the second only where the first is out of reach or
outside them (a target behind the base, which a wide target box may hold). A link length
a2 or a3 may be negative (the link points the other way from its joint's zero): the wrist
point then lies within [||a2| − |a3||, |a2| + |a3|] of the shoulder, the formula holds
with the signs, and each angle, known up to a turn, is taken within its limits.
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from math import acos, atan2, cos, hypot, isfinite, pi, sin  # local names: a solve is ~1 µs

import numpy as np
import numpy.typing as npt

from mearm.config import ArmDescription
from mearm.kinematics.chain import Chain, require_description
from mearm.kinematics.errors import (
    InvalidTargetError,
    JointLimitTargetError,
    ModelError,
    SingularTargetError,
    TargetOutsideBoxError,
    UnreachableTargetError,
)

_EPS = 1e-12
_TURN = 2.0 * pi


def as_target_cm(target_cm: npt.ArrayLike) -> np.ndarray:
    """A target as a (3,) float array [cm]; :class:`InvalidTargetError` if it is not one."""
    try:
        t = np.asarray(target_cm, dtype=float)
    except (TypeError, ValueError):
        raise InvalidTargetError(
            f"a target is three finite numbers (x, y, z) in cm, got {target_cm!r}"
        ) from None
    if t.shape != (3,) or not np.all(np.isfinite(t)):
        given = target_cm if t.dtype == object or t.ndim == 0 else t.tolist()
        raise InvalidTargetError(f"a target is three finite numbers (x, y, z) in cm, got {given!r}")
    return t


def check_in_box(target_cm: npt.ArrayLike, arm: ArmDescription) -> None:
    """Raise :class:`TargetOutsideBoxError` if the target leaves the arm's target box."""
    t = as_target_cm(target_cm)
    box = arm.target_box
    for axis, value, rng in zip("xyz", t, (box.x_cm, box.y_cm, box.z_cm), strict=True):
        if not rng.contains(float(value)):
            raise TargetOutsideBoxError(tuple(t), axis, (rng.min, rng.max))


def scalar_target_cm(target_cm: npt.ArrayLike) -> tuple[float, float, float]:
    """A target as three Python floats [cm]; a tuple, list or (3,) array without NumPy."""
    t = target_cm
    if isinstance(t, np.ndarray):
        t = t.tolist()  # one call, where indexing makes three NumPy scalars
    if isinstance(t, (tuple, list)) and len(t) == 3:  # a tuple of types: faster than a union
        try:
            x, y, z = float(t[0]), float(t[1]), float(t[2])
        except (TypeError, ValueError):
            pass
        else:
            if isfinite(x + y + z):
                return x, y, z
    x, y, z = as_target_cm(t).tolist()  # raises InvalidTargetError, naming the value
    return x, y, z


class ClosedForm(abc.ABC):
    """A closed-form IK for one family of arms.

    Args:
        arm: The description; the constructor raises :class:`ModelError` if the arm does
            not have the structure the formula needs.
    """

    #: The name an arm description gives in ``closed_form``.
    name: str = ""

    def __init__(self, arm: ArmDescription):
        self.arm = arm
        self.chain = Chain.from_description(arm)

    def solve(self, target_cm: npt.ArrayLike) -> np.ndarray:
        """Every joint, model units, (n,), putting the TCP at ``target_cm``; within limits.

        Raises:
            UnreachableTargetError: out of reach; its subclasses
                :class:`JointLimitTargetError` (needs a joint outside its limits) and
                :class:`SingularTargetError` (where the formula is singular).
        """
        return np.array(self.solve_checked(scalar_target_cm(target_cm)))

    def solve_list(self, target_cm: npt.ArrayLike) -> list[float]:
        """:meth:`solve` as a list of Python floats [model units], without the array."""
        return self.solve_checked(scalar_target_cm(target_cm))

    @abc.abstractmethod
    def solve_checked(self, target_cm: tuple[float, float, float]) -> list[float]:
        """:meth:`solve` for a target already read as three finite floats [cm].

        What a plug-in writes: the joints as Python floats [model units]. The solvers
        call it (:class:`~mearm.ik.AnalyticSolver`), which read and check the target
        once: a solve is then scalar arithmetic and one small array.
        """

    def _check_limits(self, target: tuple[float, float, float], q: np.ndarray) -> None:
        ch = self.chain
        for i, name in enumerate(ch.names):
            if not ch.lower[i] - 1e-9 <= q[i] <= ch.upper[i] + 1e-9:
                limits = self.arm.joint_limits()[name]  # as the config writes them
                raise JointLimitTargetError(
                    target,
                    name,
                    q[i] / ch.scale[i],
                    limits.min,
                    limits.max,
                    ch.unit(i),
                    self.arm.limits_reason(name),
                )


CLOSED_FORMS: dict[str, type[ClosedForm]] = {}


def register_closed_form(cls: type[ClosedForm]) -> type[ClosedForm]:
    """Class decorator: make ``cls`` available under ``cls.name``."""
    CLOSED_FORMS[cls.name] = cls
    return cls


def closed_form_for(arm: ArmDescription) -> ClosedForm | None:
    """The closed form ``arm.closed_form`` names, built for ``arm``; ``None`` if none.

    Raises:
        ModelError: an unknown name, an arm without the structure it needs, or ``arm``
            not an :class:`ArmDescription`.
    """
    require_description(arm, "closed_form_for")
    if arm.closed_form is None:
        return None
    cls = CLOSED_FORMS.get(arm.closed_form)
    if cls is None:
        raise ModelError(
            f"arm.closed_form: unknown closed form {arm.closed_form!r} "
            f"(registered: {', '.join(sorted(CLOSED_FORMS))}); or set it to null"
        )
    return cls(arm)


@register_closed_form
class PlanarWrist(ClosedForm):
    """Base yaw, two planar links, a wrist levelled by a parallelogram (module docstring)."""

    name = "planar_wrist"

    def __init__(self, arm: ArmDescription):
        super().__init__(arm)
        j = arm.joints
        problems = []
        if len(j) != 4 or any(x.type != "revolute" for x in j):
            problems.append("four revolute joints")
        elif not (j[0].actuated and j[1].actuated and j[2].actuated and not j[3].actuated):
            problems.append("three actuated joints and a passive fourth")
        else:
            c = j[3].coupling
            assert c is not None
            if c.terms != {j[1].name: -1.0, j[2].name: -1.0} or c.offset != 0.0:
                problems.append(f"{j[3].name} = -{j[1].name} - {j[2].name}")
            if (j[0].dh.alpha_deg, j[1].dh.alpha_deg, j[2].dh.alpha_deg, j[3].dh.alpha_deg) != (
                90.0,
                0.0,
                0.0,
                0.0,
            ):
                problems.append("alpha = (90, 0, 0, 0) deg")
            if any(x.dh.theta_deg != 0.0 for x in j) or any(x.dh.d_cm != 0.0 for x in j[1:]):
                problems.append("no theta offsets and d = 0 after the base")
            if arm.tool.tcp_cm[2] != 0.0:
                problems.append("a TCP in the arm's plane (tcp_cm z = 0)")
        if problems:
            raise ModelError(
                f"arm.closed_form: {self.name!r} needs {'; '.join(problems)}; "
                "this arm has another structure (set closed_form to null)"
            )
        tx, ty, _ = arm.tool.tcp_cm
        a2, a3 = j[1].dh.a_cm, j[2].dh.a_cm
        # a DH length may be negative (the link points the other way): the wrist point is
        # then as far from the shoulder as with |a|, and the formula below holds with signs
        self._reach_max, self._reach_min = abs(a2) + abs(a3), abs(abs(a2) - abs(a3))
        self._lower = self.chain.lower.tolist()
        self._upper = self.chain.upper.tolist()
        # every constant of the formula and the checks as Python floats, computed once and
        # read in one unpacking: a solve is then scalar arithmetic (under 1 µs)
        self._constants = (
            j[0].dh.a_cm + j[3].dh.a_cm + tx,  # radial offset of the shoulder and TCP
            j[0].dh.d_cm + ty,  # height of the shoulder and TCP
            self._reach_max + _EPS,
            self._reach_min - _EPS,
            a2 * a2 + a3 * a3,
            1.0 / (2.0 * a2 * a3),
            a2,
            a3,
            *self._lower,
            *self._upper,
        )

    def solve_checked(self, target_cm: tuple[float, float, float]) -> list[float]:
        """Joints (model units, 4 floats) putting the TCP at ``target_cm``; see the module.

        The base facing the target first; where that branch is out of reach or needs a
        joint outside its limits, the base turned half a turn, the arm reaching back over
        the top (:meth:`_solve_branch`). A target neither reaches is refused with the
        first branch's error.
        """
        x, y, z = target_cm
        radial, height, far, near, a2a2_a3a3, inv_2a2a3, a2, a3, l0, l1, l2, l3, h0, h1, h2, h3 = (
            self._constants
        )
        rho = hypot(x, y)
        if rho < _EPS:
            raise SingularTargetError((x, y, z), "on the base axis, where the base is undefined")
        r = rho - radial
        h = z - height
        dist = hypot(r, h)
        if near <= dist <= far:
            cos3 = (dist * dist - a2a2_a3a3) * inv_2a2a3
            theta3 = -acos(1.0 if cos3 > 1.0 else -1.0 if cos3 < -1.0 else cos3)
            theta2 = atan2(h, r) - atan2(a3 * sin(theta3), a2 + a3 * cos(theta3))
            base, wrist = atan2(y, x), -(theta2 + theta3)
            if l0 <= base <= h0 and l1 <= theta2 <= h1 and l2 <= theta3 <= h2 and l3 <= wrist <= h3:
                return [base, theta2, theta3, wrist]  # the usual case, checked in one expression
        base = atan2(y, x)
        try:
            return self._solve_branch((x, y, z), rho, base)
        except UnreachableTargetError as first:
            # over the top: the base half a turn round, the radial distance negated
            flipped = base - pi if base > 0.0 else base + pi
            try:
                return self._solve_branch((x, y, z), -rho, flipped)
            except UnreachableTargetError:
                raise first from None

    def _solve_branch(
        self, target: tuple[float, float, float], rho: float, base: float
    ) -> list[float]:
        """The joints with the base at ``base`` and the TCP ``rho`` along it [cm], or raise.

        ``rho`` is negative for the branch over the top. Each angle, known up to a turn,
        is taken within its limits; one within 1e-9 of a limit is put on it.

        Raises:
            UnreachableTargetError: the wrist point is out of the links' reach;
                :class:`JointLimitTargetError`: a joint outside its limits.
        """
        radial, height, far, near, a2a2_a3a3, inv_2a2a3, a2, a3 = self._constants[:8]
        x, y, z = target
        r = rho - radial
        h = z - height
        dist = hypot(r, h)
        if dist > far or dist < near:
            raise UnreachableTargetError(
                (x, y, z),
                f"out of reach: the wrist point is {dist:.3f} cm from the shoulder, "
                f"the arm reaches [{self._reach_min:.3f}, {self._reach_max:.3f}] cm",
            )
        cos3 = (dist * dist - a2a2_a3a3) * inv_2a2a3
        theta3 = -acos(1.0 if cos3 > 1.0 else -1.0 if cos3 < -1.0 else cos3)
        theta2 = atan2(h, r) - atan2(a3 * sin(theta3), a2 + a3 * cos(theta3))
        lo, hi = self._lower, self._upper
        q = [base, theta2, theta3]
        for i in range(3):  # each angle is known up to a turn: the one within its limits
            v = q[i]
            if not lo[i] - 1e-9 <= v <= hi[i] + 1e-9:
                for turned in (v + _TURN, v - _TURN):
                    if lo[i] - 1e-9 <= turned <= hi[i] + 1e-9:
                        q[i] = turned
                        break
        q.append(-(q[1] + q[2]))
        for i in range(4):
            v = q[i]
            if v < lo[i]:
                if v < lo[i] - 1e-9:
                    self._check_limits((x, y, z), np.array(q))  # raises, naming the joint
                q[i] = lo[i]
            elif v > hi[i]:
                if v > hi[i] + 1e-9:
                    self._check_limits((x, y, z), np.array(q))
                q[i] = hi[i]
        return q


def check_target(
    target_cm: npt.ArrayLike,
    arm: ArmDescription,
    closed_form: ClosedForm | Callable[..., np.ndarray] | None = None,
) -> np.ndarray | None:
    """Validate a target before any motion.

    It must lie inside the box and, where a closed form exists, be reachable within the
    limits.

    Returns:
        The closed-form joints (model units, (n,)), or ``None`` for an arm without one.

    Raises:
        TargetOutsideBoxError: outside the arm's target box.
        UnreachableTargetError: inside the box but out of reach (closed form only).
    """
    check_in_box(target_cm, arm)
    if closed_form is None:
        return None
    solve = closed_form.solve if isinstance(closed_form, ClosedForm) else closed_form
    return solve(target_cm)
