"""camera-accuracy refuses, before any work, a height of which no scene can be drawn.

From a newcomer's walk: ``mearm camera-accuracy --scenes 1 --objects 1 --heights 0.5`` (also
0.2, 0.7, 0.8, 7, 8.5, 10) passed the argument check ("--heights must be in 0.2 … 10 cm")
and after 5–8 s of rendering and calibrating failed with "could not place 1 objects 1.5 cm
apart in the reachable camera field", blaming spacing where one object has none. The
scenes are drawn of objects the arm could pick: under sim_mujoco the open jaws' pads reach
0.40 cm below where they close, half a 0.8 cm object's height: onto the table; and the hand
comes within task.clearance_cm + 0.3 cm of a 6 cm object's top.
"""

from __future__ import annotations

import pytest
from badinput import run_in_process

from mearm.config import load_config
from mearm.task.scene import random_scene

PROG = "mearm camera-accuracy: error: "


@pytest.mark.parametrize(
    ("height", "why"),
    [
        ("0.5", "close 0.25 cm above the table, but their gripper_jaw_left_pad reaches 0.40 cm "
         "below that: onto the table"),
        ("0.8", "close 0.4 cm above the table, but their gripper_jaw_left_pad reaches 0.40 cm "
         "below that: onto the table"),
        ("7", "close 3.5 cm above the table, and the gripper_mount comes within 0.6 cm of the "
         "object's top (task.clearance_cm 0.3 + the scene's margin 0.3)"),
    ],
)  # fmt: skip
def test_an_unusable_height_is_refused_before_any_work(height: str, why: str) -> None:
    argv = ["camera-accuracy", "--scenes", "1", "--objects", "1", "--heights", f"1,{height}"]
    done = run_in_process(argv, within_s=15)
    assert done.code == 2, done.stdout + done.stderr
    assert done.stdout == ""  # nothing rendered, nothing calibrated
    assert len(done.stderr.splitlines()) == 1, done.stderr
    assert done.line == (
        f"{PROG}--heights {height}: no object {height} cm tall can stand in the scenes "
        f"(drawn pickable): at its pick the open jaws {why}; with sim_mujoco heights "
        "0.81 … 5.98 cm fit"
    ), done.line


def test_the_range_is_the_configs() -> None:
    """More clearance, less room: the range comes from the config, not a table of figures."""
    argv = ["camera-accuracy", "--heights", "5.9", "--set", "task.clearance_cm=0.4"]
    done = run_in_process(argv, within_s=15)
    assert done.code == 2, done.stdout + done.stderr
    assert "within 0.7 cm of the object's top (task.clearance_cm 0.4 + " in done.line, done.line
    assert done.line.endswith("; with sim_mujoco heights 0.81 … 5.78 cm fit"), done.line


def test_the_edges_of_the_range_are_drawn_and_the_help_says_them() -> None:
    from mearm.tools.camera_accuracy import _allowed_heights, _scene_config

    config = load_config("sim_mujoco")
    lo, hi = _allowed_heights(config, 12) or (None, None)
    assert (lo, hi) == (0.81, 5.98)
    for height in (lo, hi):
        assert len(random_scene(_scene_config(config, height, 1), 1, seed=0)) == 1
    done = run_in_process(["camera-accuracy", "--help"])
    assert f"(sim_mujoco: {lo:g} … {hi:g})" in " ".join(done.stdout.split())
