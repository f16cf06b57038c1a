"""Values worked out once per arm description object: asked again, the same answer.

Config sections are frozen: an arm description never changes once loaded, and one run asks
the same object for its URDF, its Pinocchio model and its jaws' frame many times (the
start-up check, the rig and the simulated servos each build an :class:`ArmModel`; the
planner, the collision model and the URDF each want the jaws' axes). A value is kept
while its description lives, keyed by the object itself (a description is not hashable:
its fields hold lists).
"""

from __future__ import annotations

import weakref
from collections.abc import Callable
from typing import Generic, TypeVar

from mearm.config import ArmDescription

_T = TypeVar("_T")


class PerArm(Generic[_T]):
    """``make(arm)``, worked out once per arm description object.

    Args:
        make: The value of a description; it must not depend on anything else, and its
            callers must not change what it returns.
    """

    def __init__(self, make: Callable[[ArmDescription], _T]):
        self._make = make
        self._kept: dict[int, tuple[weakref.ref[ArmDescription], _T]] = {}

    def __call__(self, arm: ArmDescription) -> _T:
        """The value for ``arm``: kept, or made and kept while ``arm`` lives."""
        key = id(arm)
        hit = self._kept.get(key)
        if hit is not None and hit[0]() is arm:
            return hit[1]
        value = self._make(arm)

        def forget(_: weakref.ref[ArmDescription]) -> None:
            self._kept.pop(key, None)

        # the entry goes with its description (before its id can be another object's)
        self._kept[key] = (weakref.ref(arm, forget), value)
        return value
