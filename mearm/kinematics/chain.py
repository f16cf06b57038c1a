r"""The arm description as arrays: joint order, units, limits and the coupling matrix.

Joint vectors inside the solvers are in Pinocchio's units — radians for a revolute
joint, metres for a prismatic one — and hold every joint of the chain in order. The
actuated joints :math:`q_a` fix the passive ones, so the whole vector is

.. math:: q = C\,q_a + c

with ``C`` (n, m) and ``c`` (n,) in those units (the paper arm: the wrist row of ``C`` is
(0, −1, −1)). At the edges of the package values are in the config's units (degrees,
centimetres) and keyed by joint name; :class:`Chain` converts both ways.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mearm.config import ArmDescription
from mearm.config.base import short_repr
from mearm.kinematics.errors import InvalidJointsError, ModelError

#: Model units per config unit: degrees → radians, centimetres → metres.
RAD_PER_DEG = math.pi / 180.0
M_PER_CM = 0.01


def require_description(arm: object, user: str) -> None:
    """Raise :class:`ModelError` unless ``arm`` is an :class:`ArmDescription`.

    The kinematics read the description's fields at once: anything else (``None``, a
    whole config, a dict) stopped there on an AttributeError that named neither.
    """
    if not isinstance(arm, ArmDescription):
        given = f"a {type(arm).__name__}: pass its .arm" if hasattr(arm, "arm") else short_repr(arm)
        raise ModelError(
            f"{user} needs an ArmDescription (a config's arm: load_config(...).arm), got {given}"
        )


@dataclass(frozen=True, eq=False)
class Chain:
    """Order, units, limits and coupling of an arm's joints.

    Attributes:
        arm: The description it was built from.
        names: Every joint's name, base first, (n,).
        actuated: Names of the actuated joints, in chain order, (m,).
        actuated_index: Index of each actuated joint in ``names``, (m,).
        prismatic: Whether each joint is prismatic, (n,).
        scale: Model units per config unit of each joint (π/180 or 0.01), (n,).
        C: Coupling matrix in model units, (n, m).
        c: Coupling offset in model units, (n,).
        lower: Lower limits in model units, (n,); a passive joint's from its coupling.
        upper: Upper limits in model units, (n,).
        home: Home pose in model units, (n,).
    """

    arm: ArmDescription
    names: tuple[str, ...]
    actuated: tuple[str, ...]
    actuated_index: np.ndarray
    prismatic: np.ndarray
    scale: np.ndarray
    C: np.ndarray
    c: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    home: np.ndarray

    @classmethod
    def from_description(cls, arm: ArmDescription) -> Chain:
        """Build the arrays of ``arm``.

        Raises:
            ModelError: ``arm`` is not an :class:`ArmDescription`.
        """
        require_description(arm, "Chain.from_description")
        names = tuple(j.name for j in arm.joints)
        actuated = tuple(j.name for j in arm.joints if j.actuated)
        col = {name: k for k, name in enumerate(actuated)}
        prismatic = np.array([j.type == "prismatic" for j in arm.joints])
        scale = np.where(prismatic, M_PER_CM, RAD_PER_DEG)
        n, m = len(names), len(actuated)
        C = np.zeros((n, m))
        c = np.zeros(n)
        for i, j in enumerate(arm.joints):
            if j.coupling is None:
                C[i, col[j.name]] = 1.0
            else:
                for term, coef in j.coupling.terms.items():
                    k = col[term]
                    C[i, k] = coef * scale[i] / scale[names.index(term)]
                c[i] = j.coupling.offset * scale[i]
        limits = arm.joint_limits()
        lower = np.array([limits[nm].min for nm in names]) * scale
        upper = np.array([limits[nm].max for nm in names]) * scale
        home_act = (
            np.array([arm.home()[nm] for nm in actuated])
            * scale[[names.index(a) for a in actuated]]
        )
        for a in (C, c, lower, upper, prismatic, scale):
            a.flags.writeable = False
        home = C @ home_act + c
        home.flags.writeable = False
        index = np.array([names.index(a) for a in actuated])
        index.flags.writeable = False
        return cls(arm, names, actuated, index, prismatic, scale, C, c, lower, upper, home)

    # ----------------------------------------------------------------- sizes

    @property
    def n(self) -> int:
        """Number of joints."""
        return len(self.names)

    @property
    def m(self) -> int:
        """Number of actuated joints."""
        return len(self.actuated)

    @property
    def actuated_lower(self) -> np.ndarray:
        """Lower limits of the actuated joints in model units, (m,)."""
        return self.lower[self.actuated_index]

    @property
    def actuated_upper(self) -> np.ndarray:
        """Upper limits of the actuated joints in model units, (m,)."""
        return self.upper[self.actuated_index]

    @functools.cached_property
    def passive_index(self) -> np.ndarray:
        """Indices of the passive joints in ``names`` (read-only; a chain never changes)."""
        actuated = set(self.actuated_index.tolist())
        index = np.array([i for i in range(self.n) if i not in actuated], dtype=int)
        index.setflags(write=False)
        return index

    # ----------------------------------------------------------------- conversions

    def full(self, q_actuated: npt.ArrayLike) -> np.ndarray:
        """Every joint from the actuated ones, model units: ``C q_a + c``, (n,).

        Raises:
            InvalidJointsError: ``q_actuated`` is not one finite number per actuated
                joint, (m,).
        """
        try:
            q = np.asarray(q_actuated, dtype=float)
        except (TypeError, ValueError):
            raise InvalidJointsError(
                [], f"joint values must be numbers, got {short_repr(q_actuated)}"
            ) from None
        if q.shape != (len(self.actuated),):
            m = len(self.actuated)
            raise InvalidJointsError(
                q.ravel().tolist(),
                f"expected {m} values, one per actuated joint ({', '.join(self.actuated)}) "
                f"in model units (rad, m), got shape {q.shape}"
                + (" (every joint already: chain.actuated_of(q) gives the actuated ones)"
                   if q.shape == (len(self.names),) else ""),
            )  # fmt: skip
        # the sum of the list: one test, cheaper than np.isfinite; its overflow is checked
        if not math.isfinite(sum(q.tolist())) and not np.isfinite(q).all():
            raise InvalidJointsError(q.tolist(), "joint values must be finite")
        return self.C @ q + self.c

    def actuated_of(self, q: npt.ArrayLike) -> np.ndarray:
        """The actuated part of a full joint vector, (m,) (or (N, m) for (N, n))."""
        return np.asarray(q, dtype=float)[..., self.actuated_index]

    def to_config_units(self, q: npt.ArrayLike) -> np.ndarray:
        """Full vector(s) in model units → degrees / centimetres, same shape."""
        return np.asarray(q, dtype=float) / self.scale

    def from_config_units(self, values: npt.ArrayLike) -> np.ndarray:
        """Full vector(s) in degrees / centimetres → model units, same shape."""
        return np.asarray(values, dtype=float) * self.scale

    def named(self, q: npt.ArrayLike) -> dict[str, float]:
        """A full vector in model units as ``{name: value}`` in degrees / centimetres."""
        return {n: float(v) for n, v in zip(self.names, self.to_config_units(q), strict=True)}

    def named_actuated(self, q: npt.ArrayLike) -> dict[str, float]:
        """The actuated joints of a full model-unit vector, ``{name: deg or cm}``."""
        values = self.to_config_units(q)
        return {
            a: float(values[i]) for a, i in zip(self.actuated, self.actuated_index, strict=True)
        }

    def from_named(self, values: Mapping[str, float]) -> np.ndarray:
        """Model-unit full vector from ``{name: deg or cm}``.

        ``values`` names every actuated joint; passive joints it names must agree with
        their coupling (within 1e-6 of a unit), and are otherwise computed.

        Raises:
            InvalidJointsError: a missing or unknown name, a non-finite value, or a passive
                value that breaks its coupling.
        """
        unknown = sorted(set(values) - set(self.names))
        if unknown:
            raise InvalidJointsError(
                list(values.values()),
                f"unknown joint(s) {unknown}; this arm's joints: {', '.join(self.names)}",
            )
        missing = [a for a in self.actuated if a not in values]
        if missing:
            raise InvalidJointsError(list(values.values()), f"missing actuated joint(s) {missing}")
        try:
            act = np.array([float(values[a]) for a in self.actuated])
        except (TypeError, ValueError):
            raise InvalidJointsError(
                list(values.values()), "joint values must be numbers"
            ) from None
        if not np.all(np.isfinite(act)):
            raise InvalidJointsError(act.tolist(), "joint values must be finite")
        q = self.full(act * self.scale[self.actuated_index])
        for i in self.passive_index.tolist():
            name = self.names[i]
            if name in values:
                given = float(values[name])
                expected = q[i] / self.scale[i]
                if not abs(given - expected) <= 1e-6:
                    raise InvalidJointsError(
                        act.tolist(),
                        f"passive joint {name} = {given:g} breaks its coupling, which gives "
                        f"{expected:.6g}: leave it out or pass the coupled value",
                    )
        return q

    def actuated_named(self, q_actuated: npt.ArrayLike) -> dict[str, float]:
        """Actuated model-unit values as ``{name: deg or cm}``."""
        values = np.asarray(q_actuated, dtype=float) / self.scale[self.actuated_index]
        return {a: float(v) for a, v in zip(self.actuated, values, strict=True)}

    def within_limits(self, q: npt.ArrayLike, tol: float = 1e-9) -> bool:
        """Whether every joint of a full model-unit vector lies within its limits."""
        q = np.asarray(q, dtype=float)
        return bool(np.all(q >= self.lower - tol) and np.all(q <= self.upper + tol))

    def unit(self, i: int) -> str:
        """``deg`` or ``cm``: the config unit of joint ``i``."""
        return "cm" if self.prismatic[i] else "deg"
