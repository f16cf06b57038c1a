"""A pick whose jaws closed on nothing does not read ``ok``, wherever its object went.

The grip check is the camera's: over the bin, the object must be gone from its spot. One
the closing jaws pushed where the camera does not see it is gone from it too, and the
pick read ``ok``, its place ``FAILED`` (over the bin the jaws held nothing: they had
closed on nothing at the pick). The paper's arm with a kit of servos, ``--random 21
--seed 49921``: blue5's first pick. The twin knows what its jaws closed on, and the pick
now says they took nothing. The run is the one traced before the config kept the arm's
position error from the walls (``task.position_error_cm``), which sends the kit elsewhere.
"""

from __future__ import annotations

import pytest

from mearm.config import load_config
from mearm.task.pick_place import PICK_EMPTY
from mearm.task.rig import run_sort
from mearm.task.scene import random_scene

CONFIG = "configs/sim_mujoco_kits_paper.yaml"


@pytest.mark.slow
def test_a_pick_that_took_nothing_is_failed_not_ok() -> None:
    config = load_config(CONFIG, overrides=["task.position_error_cm=0"])
    report = run_sort(config, scene=random_scene(config, 21, seed=49921), echo=None)
    routes = report.routes
    # every pick that read ok brought something: no place found the jaws closed on nothing
    empty = [r for r in routes if r.step == "place" and "closed on nothing" in (r.why_failed or "")]
    assert empty == []
    # the pick that pushed its object out of view said so
    failed = [r.object_id for r in routes if r.step == "pick" and r.why_failed == PICK_EMPTY]
    assert failed == ["blue5"]
