"""What an IK solve aims at: a TCP position and, optionally, an approach direction."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mearm.kinematics.closed_form import scalar_target_cm
from mearm.kinematics.errors import InvalidTargetError


@dataclass(frozen=True)
class IKTarget:
    """A TCP target in the base frame.

    Attributes:
        position_cm: Where the TCP must go, (x, y, z) [cm].
        approach: The direction (base frame) the tool's approach axis must point along,
            normalised on construction; ``None``: position only (the orientation is free).

    Raises:
        InvalidTargetError: the position is not three finite numbers, or the approach is
            not a finite non-zero 3-vector.
    """

    position_cm: tuple[float, float, float]
    approach: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "position_cm", scalar_target_cm(self.position_cm))
        if self.approach is not None:
            try:
                a = np.asarray(self.approach, dtype=float)
            except (TypeError, ValueError):
                a = np.array([np.nan])
            # math.hypot scales: (1e308, 1e308, 1e308) has a finite norm, no overflow
            norm = math.hypot(*a) if a.shape == (3,) and np.isfinite(a).all() else math.nan
            if not (math.isfinite(norm) and norm > 1e-9):
                raise InvalidTargetError(
                    f"an approach is a finite non-zero 3-vector (base frame), got {self.approach!r}"
                )
            object.__setattr__(self, "approach", tuple(float(v) for v in a / norm))

    @classmethod
    def of(cls, target: IKTarget | npt.ArrayLike) -> IKTarget:
        """``target`` itself, or a position-only target from (x, y, z) [cm]."""
        return target if isinstance(target, IKTarget) else cls(target)  # type: ignore[arg-type]

    @property
    def position(self) -> np.ndarray:
        """The position as an array [cm], (3,)."""
        return np.array(self.position_cm)


def approach_error_deg(approach: npt.ArrayLike, desired: npt.ArrayLike) -> float:
    """Angle between two unit vectors [deg]."""
    c = float(np.dot(approach, desired))
    return math.degrees(math.acos(min(1.0, max(-1.0, c))))
