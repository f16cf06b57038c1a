"""The one record a route passes through plan → execute → report."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from mearm.ik import FailureKind, IKResult, IKTarget

Step = Literal["pick", "place", "lift", "approach", "home"]


@dataclass
class Route:
    """One motion of the arm: planned in full, then (if the plan holds) executed.

    Attributes:
        object_id: The object it serves (``""`` for a move of the arm alone).
        class_name: The object's class.
        step: ``pick`` (to the object), ``place`` (to its class's bin), ``lift`` (back off
            after a missed grip, or up with the object), ``approach`` (to above the object,
            ``task.approach_height_cm``) or ``home``.
        attempt: 1 for the first attempt at this object's pick (or place).
        target: Where the TCP goes (position [cm], optional approach direction).
        plan: The IK solve from the start pose, every row a pose the arm may take.
        failure: Why the plan cannot be executed, one line for people, or ``None``.
        failure_kind: The reason's kind (:data:`~mearm.ik.FAILURE_KINDS`):
            ``unreachable``, ``limit``, ``stalled``, ``singular`` or ``outside_box``;
            ``None`` with ``failure``.
        executed: Whether its poses were sent to the servos.
        success: Pick: gripped; place: in its bin; lift/home: reached.
        confirmed: Whether :attr:`success` was found out: a fault before the check (a pick
            is checked once the arm is over the bin) leaves it unconfirmed, not failed.
        why_failed: Why a route that ran and was checked did not do its job, one line for
            people (a pick: the object still where the grip was; a place: what the jaws
            brought to the bin, or where the object landed); ``None`` when it did, or was
            not checked.
        note: What a route that did its job did out of the ordinary, one line for people
            after ``ok`` (a place whose object slipped out on the way into its own bin:
            :data:`~mearm.task.pick_place.LOST_INTO_ITS_BIN`); ``None`` otherwise.
        ee_cm: Where the TCP really ended [cm], (3,) (the simulated arm knows; a real
            arm reports its commands).
        grip_ee_cm: A pick's TCP when the jaws start to close, after the tool's settling
            [cm], (3,); ``None`` on a place or before the grip. :attr:`ee_cm` is taken on
            arrival (within a degree of each servo's command), as the paper's Table 8.
        elapsed_s: Wall time from planning to the end of the step [s].
        motion_s: Commanded motion time: one command per pose at the servo rate [s].
        detour_cm: The TCP height its path travels at, when the direct path would have
            come too close to something and the planner went up, over and down instead
            [cm]; ``None`` for the direct path.
    """

    object_id: str
    class_name: str
    step: Step
    attempt: int
    target: IKTarget
    plan: IKResult | None = None
    failure: str | None = None
    failure_kind: FailureKind | None = None
    executed: bool = False
    success: bool = False
    confirmed: bool = True
    why_failed: str | None = None
    note: str | None = None
    ee_cm: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))
    grip_ee_cm: np.ndarray | None = None
    elapsed_s: float = 0.0
    motion_s: float = 0.0
    detour_cm: float | None = None

    @property
    def planned(self) -> bool:
        """Whether the plan exists and converged: only then is it sent."""
        return self.failure is None and self.plan is not None and self.plan.converged

    @property
    def error_cm(self) -> np.ndarray:
        """Where the TCP ended minus the target [cm], (3,)."""
        return self.ee_cm - self.target.position_cm
