"""A route refused for a collision names what stopped the way over the top too.

A walk sorted seven objects on the MeArm v1 (three of one class) and was told each place
was refused because the jaws came near a neighbour on the table, though the planner had
also tried over the top and failed for another reason: three of a class raise its bin's
walls to 6 cm, which the claw's servo cannot clear at the release height, and the height
that clears them was beyond the arm's reach over the far bin. The line now names both.
(The blue bin, off the red bin's way, is now reached over its own walls alone, as
``tests/test_detour_under_the_way.py`` tells: the way over the top out of reach is
named where the blue bin's own walls are raised.)

That table is now refused before anything moves (its red bin cannot be reached even from
home: tests/test_scene_walls_shut_bin.py); the start's check is turned off here to reach
the sorter's own lines for each place, the words this file is about.
"""

from __future__ import annotations

import re

import pytest
from badinput import run_in_process

from mearm.task import scene

pytestmark = pytest.mark.heavy

#: The MeArm v1's six objects and a third red one between them.
SCENE = (
    "task.scene=[{color: red, x: 8.7, y: 15.07}, {color: red, x: -5.75, y: 17.69}, "
    "{color: red, x: 0.0, y: 18.6}, {color: green, x: 1.8, y: 17.11}, "
    "{color: green, x: -8.7, y: 15.07}, {color: blue, x: 5.75, y: 17.69}, "
    "{color: blue, x: -1.8, y: 17.11}]"
)


def test_a_refused_place_names_the_straight_way_and_the_way_over_the_top(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(scene, "_walls_shut_bin", lambda config, colors: None)
    r = run_in_process(["sort", "--config", "sim_mearm_v1", "--set", SCENE], within_s=120)
    assert r.code == 1, r.stderr
    refused = [ln for ln in r.stdout.splitlines() if ln.startswith("not sorted:")]
    assert refused, r.stdout
    walls = re.compile(
        r"not sorted: red\d \(red\): bin unreachable: collision: \S+ comes within 0\.30 cm "
        r"of \S+ at \(base [^)]*\); over the top at \d+\.\d cm: gripper_servo comes within "
        r"0\.30 cm of bin_red_wall_\w+ at \(base [^)]*\) \(task\.clearance_cm\)$"
    )
    assert any(walls.match(ln) for ln in refused), "\n".join(refused)
    for line in refused:  # every collision refusal says what the way over the top met
        if ": collision: " in line:
            assert "; over the top at " in line, line
    # a way over the top out of reach is named too: the blue bin's walls raised to 5 cm,
    # the height over them is past the MeArm's reach over the blue bin, and nothing
    # lower clears them
    r = run_in_process(
        ["sort", "--config", "sim_mearm_v1", "--set", "task.classes.2.bin_height_cm=5"],
        within_s=120,
    )
    assert r.code == 1, r.stderr
    refused = [ln for ln in r.stdout.splitlines() if ln.startswith("not sorted:")]
    reach = re.compile(
        r"^not sorted: blue\d \(blue\): bin unreachable: collision: (held )?\S+ comes within "
        r"0\.30 cm of bin_blue_wall_\w+ at \(base [^)]*\); over the top at \d+\.\d cm: "
        r"needs \w+ = [-\d.]+ deg, outside its limits"
    )
    assert len(refused) == 2 and all(reach.search(ln) for ln in refused), "\n".join(refused)
