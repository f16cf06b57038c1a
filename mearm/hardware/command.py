"""The command and state records of the whole arm: actuators by name, values in config units.

Commands name their actuators: each actuated joint of the arm by its name (its value in
degrees, or centimetres for a prismatic joint), each tool actuator by its name [deg], and
whether the gripper is closed. The servo bus (:mod:`mearm.hardware.bus`) sends them; the
mapping (:mod:`mearm.hardware.mapping`) turns them into pulses.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from mearm.config import ArmDescription
from mearm.hardware.errors import InvalidCommandError


def _finite(value: Any, what: str) -> float:
    if isinstance(value, bool):
        raise InvalidCommandError(f"{what} must be a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidCommandError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise InvalidCommandError(f"{what} must be finite, got {v}")
    return v


def _values(values: Any, what: str, example: str) -> Mapping[str, float]:
    """A read-only ``{name: float}`` copy of ``values``, each checked finite."""
    if not isinstance(values, Mapping):
        raise InvalidCommandError(f"{what} must be a mapping {example}, got {values!r}")
    out: dict[str, float] = {}
    for name, value in values.items():
        if not isinstance(name, str) or not name:
            raise InvalidCommandError(f"{what}: names must be non-empty strings, got {name!r}")
        out[name] = _finite(value, f"{what}[{name!r}]")
    return MappingProxyType(out)


def _describe(joints: Mapping[str, float], tool: Mapping[str, float], *, closed: bool) -> str:
    parts = [" ".join(f"{n}={v:.2f}" for n, v in joints.items())]
    if tool:
        parts.append(" ".join(f"{n}={v:.2f}" for n, v in tool.items()))
    parts.append(f"gripper {'closed' if closed else 'open'}")
    return "; ".join(parts)


@dataclass(frozen=True)
class _ArmValues:
    """Named actuator values and the gripper's state; validated, read-only, hashable."""

    joints: Mapping[str, float]
    tool: Mapping[str, float] = field(default_factory=dict)
    gripper_closed: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "joints", _values(self.joints, "joints", "{joint name: deg or cm, ...}")
        )
        if not self.joints:
            raise InvalidCommandError("joints must name at least one actuated joint, got {}")
        object.__setattr__(
            self, "tool", _values(self.tool, "tool", "{tool actuator name: deg, ...}")
        )
        if not isinstance(self.gripper_closed, bool):
            raise InvalidCommandError(
                f"gripper_closed must be True or False, got {self.gripper_closed!r}"
            )

    def __hash__(self) -> int:
        return hash(
            (frozenset(self.joints.items()), frozenset(self.tool.items()), self.gripper_closed)
        )

    def __str__(self) -> str:
        return _describe(self.joints, self.tool, closed=self.gripper_closed)


@dataclass(frozen=True, eq=True)
class ArmCommand(_ArmValues):
    """One atomic command to the whole arm.

    Equal commands have equal values by name (order does not matter); the mappings are
    read-only copies, kept in the order given.

    Attributes:
        joints: Actuated joint name → value [deg, or cm for a prismatic joint]; passive
            joints follow from their couplings and are never commanded.
        tool: Tool actuator name → angle [deg] (the paper's ``gripper_arm``).
        gripper_closed: Close (True) or open (False) the gripper.

    Raises:
        InvalidCommandError: a value that is not a finite number, a name that is not a
            string, no joints, or ``gripper_closed`` not a bool. Whether the names are the
            arm's is checked by :meth:`ServoMap.check` before anything is sent.
    """

    __hash__ = _ArmValues.__hash__

    @classmethod
    def home(cls, arm: ArmDescription) -> ArmCommand:
        """Every actuated joint and tool actuator at its home value, the gripper open."""
        return cls(arm.home(), {a.name: a.home for a in arm.tool.actuators}, gripper_closed=False)


@dataclass(frozen=True, eq=True)
class ArmState(_ArmValues):
    """The last command a backend confirmed (acknowledged by the board).

    Attributes:
        joints: Actuated joint name → value [deg or cm].
        tool: Tool actuator name → angle [deg].
        gripper_closed: Whether the gripper was told to close.
    """

    __hash__ = _ArmValues.__hash__

    @classmethod
    def from_command(cls, command: ArmCommand) -> ArmState:
        """The state a confirmed command leaves."""
        return cls(command.joints, command.tool, command.gripper_closed)

    def to_command(self) -> ArmCommand:
        """The command that would reproduce this state."""
        return ArmCommand(self.joints, self.tool, self.gripper_closed)


__all__ = ["ArmCommand", "ArmState"]
