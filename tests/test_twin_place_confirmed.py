"""A place the twin confirmed is not taken for one that may have dropped on the way.

The twin counts a place only when an object its jaws closed on rests in its class's bin
(:func:`~mearm.task.pick_place.place_failure`). The 5-DOF twin, ``--random 13 --seed
49730``: at home the arm hides a red 12.8 cm from the first red's way to its bin (the bins
lie outside the camera's view, so it never sees them). Seen once the arm had moved, it was
taken for the first red, dropped on the way, and picked and placed under that one's name:
``red4`` twice, no ``red5``.
"""

from __future__ import annotations

import pytest

from mearm.config import load_config
from mearm.task.rig import run_sort
from mearm.task.scene import SceneObject

CONFIG = "configs/sim_5dof_mujoco.yaml"


@pytest.mark.heavy
def test_a_red_the_arm_hid_is_a_new_object_not_the_one_placed() -> None:
    config = load_config(CONFIG)
    # the second red lies where the arm at home hides it from the first look
    scene = [SceneObject(color="red", x=-4.45, y=11.03), SceneObject(color="red", x=8.08, y=10.19)]
    report = run_sort(config, scene=scene, echo=None)
    places = [r.object_id for r in report.routes if r.step == "place" and r.success]
    picks = [r.object_id for r in report.routes if r.step == "pick" and r.success]
    assert report.outcome.in_bins["red"] == 2  # the twin's own count
    assert sorted(places) == ["red1", "red2"]  # each named once, under its own name
    assert sorted(picks) == ["red1", "red2"]
    assert report.outcome.seen["red"] == 2
    assert report.outcome.sorted["red"] == 2
