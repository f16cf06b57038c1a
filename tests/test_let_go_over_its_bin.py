"""An object the jaws held and let go over its bin counts sorted, whatever a look took for it.

``sim_5dof_mujoco --random 18 --seed 48598``: at home the arm hides a red 4 cm from another.
The jaws take the other; over the bin the camera, no longer blocked, sees the hidden red
near the spot the taken one left, and takes it for that one pushed aside. The jaws open
over the bin to look again (the held red falls in), the hidden red is still there, and the
sort follows it as the one it went for, picks it and places it. The twin had every red in
its bin, yet the sort said ``sorted 17 of 18 objects (simulated; 1 never seen by the
camera)`` and exited 1. The two reds alone do the same; with no retry the hidden red is
left as the one whose pick failed, and the sort said ``sorted 0 of 2`` with one in its bin.
"""

from __future__ import annotations

import pytest

from mearm.config import SceneObject, load_config
from mearm.task.rig import run_sort

CONFIG = "configs/sim_5dof_mujoco.yaml"
#: The red the jaws take first, and the one the arm at home hides 4 cm from it.
REDS = ((6.64, 14.08), (6.22, 10.11))


@pytest.mark.heavy
def test_a_red_let_go_over_its_bin_while_a_hidden_one_is_followed_counts_sorted() -> None:
    config = load_config(CONFIG)
    scene = [SceneObject(color="red", x=x, y=y) for x, y in REDS]
    sort = run_sort(config, scene=scene, echo=None)
    out = sort.outcome
    assert out.in_bins["red"] == 2  # the twin's own count: both reds in their bin
    # the first pick was taken for one that pushed its red aside (the hidden red, seen)
    first = sort.routes[0]
    assert first.step == "pick" and not first.success
    assert first.why_failed is not None and first.why_failed.endswith("pushed it aside")
    assert out.seen["red"] == out.sorted["red"] == 2
    assert out.unseen == {}
    assert out.left == {}
    assert sort.complete


@pytest.mark.heavy
def test_the_held_red_counts_sorted_when_the_hidden_one_is_left_for_failed_picks() -> None:
    config = load_config(CONFIG, overrides=["task.pick_retries=0"])
    scene = [SceneObject(color="red", x=x, y=y) for x, y in REDS]
    out = run_sort(config, scene=scene, echo=None).outcome
    assert out.in_bins["red"] == 1  # the twin's own count: the held red in its bin
    assert (out.seen["red"], out.sorted["red"]) == (2, 1)
    assert out.left == {"pick_failed": 1}  # the hidden red, followed as the one pushed
    assert out.unseen == {}
