"""The environments' action and ``agent_pos``: the datasets' ``action`` and state vector.

One vector of the arm's names (:func:`mearm.dataset.recorder.state_names`): each actuated
joint [deg or cm], each tool actuator [deg], then ``gripper_closed`` (0 or 1; above 0.5
is closed): the units of a recording's ``action`` column, so a recorded episode replays
as it is and a policy trained on one acts in the environment.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mearm.config import Config
from mearm.dataset.recorder import state_names
from mearm.hardware.bus import MeasuresWorld, ServoBus
from mearm.hardware.command import ArmCommand

#: ``agent_pos`` may read this far outside a joint's limits [deg or cm]: the measured
#: joints lag, play and bend under load around what the servos were told.
MEASURED_MARGIN = 10.0


@dataclass(frozen=True)
class Clipped:
    """An action after its limits: the vector sent and the names it clipped."""

    vector: np.ndarray  # (n,) float64
    names: tuple[str, ...]


@dataclass(frozen=True)
class ActionSpec:
    """The names and limits of the action vector of one config's arm.

    Attributes:
        names: Joints, tool actuators, then ``gripper_closed``.
        low: Each one's lower limit [deg, cm or -], (n,).
        high: Each one's upper limit, (n,).
        joints: How many of the names are actuated joints.
        tool: The tool actuators' names.
    """

    names: tuple[str, ...]
    low: np.ndarray
    high: np.ndarray
    joints: int
    tool: tuple[str, ...]

    @classmethod
    def of(cls, config: Config) -> ActionSpec:
        """The action vector of ``config``'s arm."""
        arm = config.arm
        limits = {j.name: j.limits for j in arm.joints if j.limits is not None}
        joint_names = list(arm.home())
        tool = [a for a in arm.tool.actuators]
        names = tuple(state_names(config))
        low = [limits[n].min for n in joint_names] + [a.limits.min for a in tool] + [0.0]
        high = [limits[n].max for n in joint_names] + [a.limits.max for a in tool] + [1.0]
        return cls(
            names,
            np.array(low, dtype=float),
            np.array(high, dtype=float),
            len(joint_names),
            tuple(a.name for a in tool),
        )

    def clip(self, action: npt.ArrayLike) -> Clipped:
        """``action`` within the limits, and the names that were outside them.

        Raises:
            ValueError: not ``(n,)`` numbers, or one is not finite.
        """
        a = np.asarray(action, dtype=float)
        if a.shape != self.low.shape:
            raise ValueError(
                f"an action is {len(self.names)} numbers ({', '.join(self.names)}), "
                f"got shape {a.shape}"
            )
        if not np.all(np.isfinite(a)):
            bad = [n for n, v in zip(self.names, a, strict=True) if not np.isfinite(v)]
            raise ValueError(f"an action must be finite; not finite: {', '.join(bad)}")
        out = np.clip(a, self.low, self.high)
        names = tuple(n for n, v, c in zip(self.names, a, out, strict=True) if v != c)
        return Clipped(out, names)

    def command(self, vector: npt.ArrayLike) -> ArmCommand:
        """The bus command of a vector within the limits."""
        v = np.asarray(vector, dtype=float)
        k = self.joints
        joints = dict(zip(self.names[:k], v[:k].tolist(), strict=True))
        tool = dict(zip(self.tool, v[k : k + len(self.tool)].tolist(), strict=True))
        return ArmCommand(joints, tool, bool(v[-1] > 0.5))

    def vector(self, command: ArmCommand) -> np.ndarray:
        """A command as the action vector, (n,) float32."""
        values = {**command.joints, **command.tool, "gripper_closed": float(command.gripper_closed)}
        return np.array([values[n] for n in self.names], dtype=np.float32)

    def agent_pos(self, bus: ServoBus) -> np.ndarray:
        """The arm's state as a recording's ``observation.state`` has it, (n,) float32.

        The measured joints (a bus that measures them: the twin), the confirmed tool
        settings and gripper.
        """
        state = bus.state
        assert state is not None, "the bus has confirmed no command yet"
        values = {**state.joints, **state.tool, "gripper_closed": float(state.gripper_closed)}
        if isinstance(bus, MeasuresWorld):
            values.update(bus.actual_joints)
        return np.array([values[n] for n in self.names], dtype=np.float32)

    def agent_pos_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The bounds of ``agent_pos``: the limits and :data:`MEASURED_MARGIN` [deg or cm]."""
        margin = np.zeros_like(self.low)
        margin[: self.joints] = MEASURED_MARGIN
        return (self.low - margin).astype(np.float32), (self.high + margin).astype(np.float32)
