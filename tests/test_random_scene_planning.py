"""The random layout on an arm without a closed form plans only what it has to.

Each draw's reach is planned (the 5-DOF's PD-PIJ with its multi-start recovery, 8-20 ms
of CPU a refused point), so the layout asks the cheap questions first: a point the links'
lengths and the shoulder's limits put beyond reach is refused unplanned, and a disc
refused by its footprint has no margin planned. The tests count what is planned; the
layouts are those of the plain order (every test first, the footprint last), drawn here
alongside.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mearm.task.scene as layout
from mearm.config import load_config
from mearm.ik import APPROACH_TOLERANCE_DEG
from mearm.ik.reach import ReachBound
from mearm.kinematics import ArmModel
from mearm.kinematics.model import CM_PER_M
from mearm.task.plan import Planner
from mearm.task.scene import SceneError, random_scene

#: Few enough draws to be quick, enough that the 5-DOF's table is refused full with
#: draws beyond its reach, refused by the bins and by objects among them.
DRAWS = 1500


def _plain_candidate(config, color, x, y, rng, placed, poses, **kw):
    """The draw's tests in their plain order: reach everywhere, then yaw, then footprint."""
    if any(np.hypot(o.x - x, o.y - y) < kw["min_dist"] for o in placed):
        return None
    gap = kw["diameter"] / 2 + layout.MIN_GAP_CM
    if any(layout._near_bin(c, x, y, gap) for c in config.task.classes):  # noqa: SLF001
        return None
    cls = config.task.class_named(color)
    reach = kw["reach"]
    q = reach(cls, x, y)
    if q is None or not all(
        reach(cls, x + float(dx), y + float(dy)) is not None for dx, dy in kw["margins"]
    ):
        return None
    new = layout.SceneObject(color=color, x=x, y=y)
    symmetry = cls.object_shape.symmetry_deg
    if symmetry:
        new = new.model_copy(update={"yaw_deg": round(rng.uniform(0, symmetry), 1)})
    hit = kw["footprint"](placed, poses, new, q)
    if hit is not None:
        if hit[1] == "table":
            kw["in_table"][color] = hit[0]
        return None
    return new, q


def _outcome(config, n, seed):
    try:
        return random_scene(config, n, seed, max_tries=DRAWS)
    except SceneError as exc:
        return str(exc)


def test_points_beyond_reach_are_not_planned(monkeypatch):
    """A full table on the 5-DOF: no target out of reach by the links' lengths, or by
    them and the shoulder's limits, is planned.

    Such a plan could only fail, at the cost of its whole solve and multi-start.
    """
    config = load_config("sim_5dof")
    bound = ReachBound(
        ArmModel(config.arm), config.controller.tolerance_cm2, APPROACH_TOLERANCE_DEG
    )
    planned, beyond = [], 0
    plan = Planner.plan

    def counted(self, route, q_start, **kw):
        planned.append(route.target)
        return plan(self, route, q_start, **kw)

    monkeypatch.setattr(Planner, "plan", counted)
    with pytest.raises(SceneError, match="could not place 60 objects"):
        random_scene(config, 60, 0, max_tries=DRAWS)
    for t in planned:
        metres = (np.asarray(t.position_cm, dtype=float) / CM_PER_M).tolist()
        beyond += bound.beyond_limits(metres, t.approach)
    assert planned, "nothing was planned"
    assert beyond == 0, f"{beyond} of {len(planned)} plans were of targets beyond reach"


def test_no_margin_planned_for_a_disc_its_footprint_refuses(monkeypatch):
    """A disc (no yaw drawn) refused by a bin or an object: no margin of it is planned."""
    config = load_config("sim_5dof")
    events: list[tuple] = []
    reach_check, footprint_check = layout._reach_check, layout._footprint_check  # noqa: SLF001

    def reach_of(cfg):
        reach = reach_check(cfg)

        def logged(cls, x, y):
            events.append(("reach", x, y))
            return reach(cls, x, y)

        return logged

    def footprint_of(cfg, table):
        clear = footprint_check(cfg, table)

        def logged(placed, poses, new, q):
            hit = clear(placed, poses, new, q)
            events.append(("footprint", new.x, new.y, hit))
            return hit

        return logged

    monkeypatch.setattr(layout, "_reach_check", reach_of)
    monkeypatch.setattr(layout, "_footprint_check", footprint_of)
    with pytest.raises(SceneError):
        random_scene(config, 60, 0, max_tries=DRAWS)
    margin = layout.FOOTPRINT_MARGIN_CM

    def of(event, x, y):  # a reach of a margin point of (x, y)
        return event[0] == "reach" and math.isclose(
            math.hypot(event[1] - x, event[2] - y), margin, abs_tol=1e-6
        )

    refused = 0
    for i, event in enumerate(events):
        if event[0] != "footprint" or event[3] is None or event[3][1] == "table":
            continue
        refused += 1
        _, x, y, hit = event
        centre = max(j for j in range(i) if events[j] == ("reach", x, y))
        around = [e for e in events[centre + 1 : i + 2] if of(e, x, y)]
        assert not around, f"({x}, {y}), refused by {hit}: {len(around)} margins planned"
    assert refused, "no draw's footprint was refused: the test checks nothing"


@pytest.mark.parametrize(
    ("name", "n", "seed"),
    [("sim_5dof", 60, 0), ("sim_5dof", 12, 7), ("sim_shapes", 40, 13001), ("sim", 60, 21977)],
)
def test_layout_is_the_plain_orders(monkeypatch, name, n, seed):
    """The same objects (positions, yaws, order) or the same refusal as the plain order."""
    config = load_config(name)
    ours = _outcome(config, n, seed)
    monkeypatch.setattr(layout, "_candidate", _plain_candidate)
    assert ours == _outcome(config, n, seed)
