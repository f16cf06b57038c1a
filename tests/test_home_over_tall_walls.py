"""The sort parks beside bin walls grown tall for many objects: straight down from over home.

The paper arm's jaws hang at home beside the red bin's wall. Walls grow to hold their
class's objects stacked (15 reds: 16 cm), and the way home the sort had (up to the safe
height, over home, then a straight line in joint space down) swung the jaws into that
wall: every such table ended "stopped: not parked" with the arm where it was, exit 1, and
a sort that went home to look for an object it had lost sight of never got there
(``mearm sort --config sim --random 40 --seed 9110``, seeds 9110–9114). From over home
the TCP now comes straight down, as a planned route, where that line is not clear.
"""

from __future__ import annotations

import contextlib

import pytest
import yaml
from badinput import run_in_process
from conftest import ROOT

from mearm.config import load_config
from mearm.task.scene import random_scene


@pytest.mark.heavy
def test_fifteen_reds_are_sorted_and_the_arm_parks(tmp_path) -> None:
    config = load_config("sim")
    scene = random_scene(config, {"red": 15, "blue": 2}, 9120)
    path = tmp_path / "rb15.yaml"
    path.write_text(yaml.safe_dump([o.model_dump(mode="json") for o in scene]))
    with contextlib.chdir(ROOT):
        out = run_in_process(["sort", "--config", "sim", "--scene", str(path), "--quiet"])
    assert out.code == 0, out.stderr
    assert "not parked" not in out.stderr
    assert out.stdout.strip().splitlines()[-1] == "sorted 17 of 17 objects (simulated)"
