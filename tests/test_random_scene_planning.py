"""The random layout on an arm without a closed form plans only what it has to.

Each draw's reach is planned (the 5-DOF's PD-PIJ with its multi-start recovery, 8-20 ms
of CPU a refused point), so a point the links' lengths and the shoulder's limits put
beyond reach is refused unplanned. The tests count what is planned.
"""

from __future__ import annotations

import numpy as np
import pytest

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
