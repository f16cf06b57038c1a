"""The jaws come down into a bin and leave it straight up, not on the transit's swing.

A place releases as low as the jaws clear the bin's walls by the clearance. Planned as
one transit from the lift to the release, and from there to the next pick, the route
came down into the bin and left it on a swing; streamed at the servos' speed limits, the
twin's arm strays from such a path (a lagging shoulder, a kit servo's calibration error),
and a pad was pushed onto the bin's wall and the servo stalled: the paper's arm with a
kit of servos, ``--random 21 --seed 48633``, after the blue bin's ninth place (planned
0.53 cm from the wall ``ny``, measured 0.16 cm before the route out began).
"""

from __future__ import annotations

import pytest

from mearm.config import load_config
from mearm.task.rig import run_sort
from mearm.task.scene import random_scene

CONFIG = "configs/sim_mujoco_kits_paper.yaml"


@pytest.mark.slow
def test_a_kit_arm_sorts_a_random_table_without_pressing_on_a_bin_wall() -> None:
    config = load_config(CONFIG)
    report = run_sort(config, scene=random_scene(config, 21, seed=48633), echo=None)
    assert "fault" not in report.outcome.left, report.outcome.line(simulated=True)
    places = [r for r in report.routes if r.step == "place"]
    assert len(places) > 10  # (it ran its course: every class's bin was placed in)
