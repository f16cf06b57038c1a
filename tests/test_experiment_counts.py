"""A random trial lays as many objects of each class as the config's own table holds.

Every trial laid the paper's 4 of each class: on the MeArm v1's smaller table 12 objects
do not fit, and ``mearm experiment --config sim_mearm_v1`` exited 2 on every seed, its
advice ("ask for fewer") one the command had no option for.
"""

from __future__ import annotations

from collections import Counter

import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.experiment.trials import plan_trial
from mearm.task import random_scene


@pytest.mark.parametrize("seed", [0, 910003])
def test_the_mearm_v1_trials_lay_its_own_tables_count(seed: int) -> None:
    config = load_config(ROOT / "configs" / "sim_mearm_v1.yaml")
    layout = plan_trial(config, seed, 0).layout
    assert layout is not None
    assert Counter(o.color for o in layout) == {"red": 2, "green": 2, "blue": 2}


def test_the_paper_arms_trials_are_the_tables_they_were() -> None:
    """4 of each class, as the paper's: the same draw as before, seed for seed."""
    config = load_config(ROOT / "configs" / "sim.yaml")
    plan = plan_trial(config, 7, 3)
    counts = dict.fromkeys(config.task.class_names, 4)
    assert plan.layout == random_scene(plan.config, counts, plan.seed)
