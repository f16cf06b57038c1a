"""The actuators to calibrate, their two references, and the pose the others take."""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from mearm.config import Config
from mearm.hardware import ActuatorMap, ServoMap

#: Reference values lie this fraction of the limit range in from each end [-].
REFERENCE_INSET = 0.2
#: Reference values are rounded to this grid, per unit.
REFERENCE_GRID = {"deg": 5.0, "cm": 0.5}
#: At a joint's references every joint stays this share of its range inside its limits:
#: a joint on its stop no longer follows its servo (the MeArm's elbow servo, its joint
#: stopped, turns the shoulder instead).
POSE_INSET = 0.05
#: Values tried across each other joint servo's span for a pose that keeps the joints
#: inside their limits, when where it is, its home and its references do not.
POSE_GRID = 9
#: Between a joint's references the tool keeps this far above the table [cm]: the
#: paper arm's jaws hang 11 cm below its TCP, and its shoulder at 50° with the elbow at
#: home put them into the table.
TABLE_ROOM_CM = 1.0
#: Values of the joint's own servo checked between (and at) its references.
SWEEP_POINTS = 7

#: The tool's lowest point above the table [cm] with the joint servos at these values.
Lowest = Callable[[Mapping[str, float]], float]


def reference_values(lower: float, upper: float, unit: str) -> tuple[float, float]:
    """Two reference values inside ``[lower, upper]``, a fifth of the range in from each end.

    Rounded to :data:`REFERENCE_GRID` when the rounded values stay inside the limits and
    apart; otherwise exact.
    """
    span = upper - lower
    a, b = lower + REFERENCE_INSET * span, upper - REFERENCE_INSET * span
    grid = REFERENCE_GRID.get(unit, 1.0)
    ra, rb = round(a / grid) * grid, round(b / grid) * grid
    if lower <= ra < rb <= upper:
        return (float(ra), float(rb))
    return (float(a), float(b))


@dataclasses.dataclass(frozen=True)
class Actuator:
    """One actuator to calibrate: its map (with the present calibration) and references.

    Attributes:
        name: The actuator's name.
        kind: ``joint``, ``tool`` or ``gripper``.
        amap: Its map under the present calibration.
        references: The two servo values to jog it to.
        lower: The lowest value its servo takes (its limits, or its combination's range).
        upper: The highest.
    """

    name: str
    kind: str  # joint, tool or gripper
    amap: ActuatorMap
    references: tuple[float, float]
    lower: float = -math.inf
    upper: float = math.inf

    @property
    def what(self) -> str:
        """What the references are values of: the name, or the combination its servo turns."""
        return self.amap.combination_text


def servo_span(smap: ServoMap, amap: ActuatorMap) -> tuple[float, float]:
    """The values an actuator's servo is calibrated over [unit].

    Its limits; for a servo that turns a combination, the range the combination takes over
    the joints' limits, cut to what the present calibration's pulse range reaches (where
    the two overlap).
    """
    if not amap.combined:
        return (amap.lower, amap.upper)
    lo, hi = smap.servo_range(amap.name)
    plo, phi = amap.pulse_limits
    if max(lo, plo) < min(hi, phi):
        lo, hi = max(lo, plo), min(hi, phi)
    return (lo, hi)


def actuators_of(config: Config) -> list[Actuator]:
    """Every actuator of the arm, in calibration order: joints, tool actuators, gripper."""
    return actuators_of_map(ServoMap.from_arm(config.arm))


def actuators_of_map(smap: ServoMap) -> list[Actuator]:
    """:func:`actuators_of` an arm's servos."""
    out = []
    for kind, maps in (("joint", smap.joints), ("tool", smap.tool), ("gripper", (smap.gripper,))):
        for a in maps:
            lo, hi = servo_span(smap, a)
            out.append(Actuator(a.name, kind, a, reference_values(lo, hi, a.unit), lo, hi))
    return out


def joints_overrun(smap: ServoMap, values: Mapping[str, float]) -> float:
    """How far the joints these joint-servo values set lie outside their limits.

    Each limit taken :data:`POSE_INSET` of the range in; the worst joint's distance past
    it, as a share of its range (0 or less: every joint inside).
    """
    q = smap.joints_of(values)
    worst = -math.inf
    for j in smap.joints:
        span = j.upper - j.lower
        lo, hi = j.lower + POSE_INSET * span, j.upper - POSE_INSET * span
        worst = max(worst, (lo - q[j.name]) / span, (q[j.name] - hi) / span)
    return worst


def pose_overrun(smap: ServoMap, act: Actuator, others: Mapping[str, float]) -> float:
    """:func:`joints_overrun` at the worse of ``act``'s references, the others at ``others``."""
    return max(joints_overrun(smap, {**others, act.name: r}) for r in act.references)


def _moved_with(smap: ServoMap, name: str) -> list[str]:
    """The other joint servos that set a joint which ``name``'s servo moves too."""
    m = smap.combination
    if m is None:  # every servo turns its own joint: no other shares one
        return []
    turns = np.abs(np.linalg.inv(m[0])) > 1e-9  # joint r ← servo c
    names = smap.joint_names
    k = names.index(name)
    moved = [r for r in range(len(names)) if turns[r, k]]
    return [n for c, n in enumerate(names) if c != k and any(turns[r, c] for r in moved)]


def pose_settings(
    choices: Mapping[str, Sequence[float]], fixed: Mapping[str, float] | None = None
) -> list[dict[str, float]]:
    """Every setting of the other joint servos: each of ``choices``, the rest ``fixed``.

    In ``itertools.product`` order: the first choice of each servo first.
    """
    rest = dict(fixed or {})
    return [
        {**rest, **dict(zip(choices, s, strict=True))} for s in itertools.product(*choices.values())
    ]


def poses_inside(
    smap: ServoMap,
    act: Actuator,
    choices: Mapping[str, Sequence[float]],
    fixed: Mapping[str, float] | None = None,
) -> list[dict[str, float]]:
    """The settings of the other joint servos that keep the joints inside at both references.

    Args:
        smap: The arm's servos (the present calibration).
        act: The joint actuator to be calibrated.
        choices: Other joint servos → their candidate values, preferred first.
        fixed: The other joint servos not in ``choices`` → their values.

    Returns:
        Every setting (:func:`pose_settings`) whose :func:`pose_overrun` is not
        positive, the preferred first; maybe none.
    """
    return [s for s in pose_settings(choices, fixed) if pose_overrun(smap, act, s) <= 0]


def sweep_lowest(act: Actuator, others: Mapping[str, float], lowest: Lowest) -> float:
    """The tool's lowest height [cm] as ``act`` goes between its references.

    The other joint servos at ``others``; :data:`SWEEP_POINTS` values, the references
    included.
    """
    a, b = act.references
    return min(lowest({**others, act.name: v}) for v in np.linspace(a, b, SWEEP_POINTS))


def reference_pose(
    smap: ServoMap,
    act: Actuator,
    present: Mapping[str, float],
    home: Mapping[str, float],
    lowest: Lowest | None = None,
) -> dict[str, float]:
    """Where the other joint servos go before a joint's references are taken.

    Where they are, if that keeps every joint inside its limits at both references
    (:func:`pose_overrun`) and, with ``lowest``, the tool :data:`TABLE_ROOM_CM` above the
    table between them (:func:`sweep_lowest`); else the first setting that does, trying
    for each servo that shares a joint with this one (with ``lowest``: every other joint
    servo) its present value, its home, its references and :data:`POSE_GRID` values
    across its span (the rest stay); else, of the settings inside the limits, the one
    that keeps the tool highest; else the setting that overruns least.

    Args:
        smap: The arm's servos (the present calibration).
        act: The joint actuator to be calibrated.
        present: Every other joint servo's present value.
        home: Every joint servo's value at home.
        lowest: The tool's lowest point above the table for joint servo values [cm];
            ``None``: the table is not checked.
    """
    now = dict(present)

    def clear(setting: Mapping[str, float]) -> bool:
        return lowest is None or sweep_lowest(act, setting, lowest) >= TABLE_ROOM_CM

    if pose_overrun(smap, act, now) <= 0 and clear(now):
        return now
    movable = set(_moved_with(smap, act.name)) if lowest is None else set(now)
    choices = {
        o.name: list(
            dict.fromkeys(
                [now[o.name], home[o.name], *o.references]
                + np.linspace(o.lower, o.upper, POSE_GRID).tolist()
            )
        )
        for o in actuators_of_map(smap)
        if o.name in movable and o.name != act.name and o.kind == "joint"
    }
    inside = poses_inside(smap, act, choices, now)
    for setting in inside:
        if clear(setting):
            return setting
    if inside:
        assert lowest is not None  # (without it every setting inside is clear)
        return max(inside, key=lambda s: sweep_lowest(act, s, lowest))
    return min(pose_settings(choices, now), key=lambda s: pose_overrun(smap, act, s))


class TableHeight:
    """The tool's height over a cleared table (calibration clears it) for ``config``'s arm.

    The tool's shapes as the planner's collision checks hold them (the jaws open, hanging
    along the tool's approach axis). Built once a session: its model is Pinocchio's.
    """

    def __init__(self, config: Config):
        from mearm.kinematics import ArmModel  # noqa: PLC0415  (Pinocchio: a session's start)
        from mearm.kinematics.bodies import TableContents  # noqa: PLC0415
        from mearm.sim.table_collision import collision_model  # noqa: PLC0415

        model = ArmModel(config.arm)
        table = TableContents.of(config.with_scene([]).task)
        self._collision = collision_model(config, model, bins=(), table=table)
        self._chain = model.chain

    def lowest(self, smap: ServoMap) -> Lowest:
        """:data:`Lowest` at the joints the servo values give under ``smap``.

        The session's map as it is now: a fit just made moves where a servo value puts its
        joint.
        """
        collision, chain = self._collision, self._chain

        def at(values: Mapping[str, float]) -> float:
            return collision.tool_lowest_cm(chain.from_named(smap.joints_of(values)))[0]

        return at


def table_lowest(config: Config, smap: ServoMap) -> Lowest:
    """:meth:`TableHeight.lowest` of a table built for this call."""
    return TableHeight(config).lowest(smap)
