"""A table laid out for a run (``--scene``, ``--random``) lies inside ``vision.work_area_px``.

The detector looks nowhere outside the polygon, so an object laid there was never seen:
``--scene`` ran the sort and ended "never seen by the camera" (exit 1), and ``--random``
drew over the camera's whole view (``--random 6 --seed 0`` with the frame's left half
as the work area laid all six in the right half: "sorted 0 of 6"). Now a scene file's
object outside it is refused as one outside the camera's view is (exit 2, one line,
before the run log), and random draws stand inside it.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import ROOT, check_bad_input, run_in_process

SIM = ["--config", str(ROOT / "configs" / "sim.yaml")]
#: The left half of the sim camera's 640x480 px frame (x below -0.5 cm on the table).
LEFT_HALF = "vision.work_area_px=[[0,0],[320,0],[320,480],[0,480]]"
OUTSIDE = (
    "(green at x 10, y 50 cm): outside the work area (vision.work_area_px: u 0 to 320, "
    "v 0 to 480 px), where nothing is detected: the whole object must lie inside it"
)


@pytest.mark.bad_input
@pytest.mark.parametrize("command", ["sort", "experiment"])
def test_a_scene_object_outside_the_work_area_is_refused(tmp_path: Path, command: str) -> None:
    scene = tmp_path / "scene.yaml"
    scene.write_text("- {color: red, x: -10, y: 50}\n- {color: green, x: 10, y: 50}\n")
    log = tmp_path / "run.jsonl"
    argv = [command, *SIM, "--set", LEFT_HALF, "--scene", scene, "--log", log]
    if command == "experiment":
        argv += ["--trials", "1"]
    out = check_bad_input(argv, keep=[tmp_path], within_s=15)
    assert out.line == f"mearm {command}: error: {scene}[1] {OUTSIDE}", out.line
    assert not log.exists()


def test_random_objects_are_drawn_inside_the_work_area() -> None:
    done = run_in_process(
        ["sort", *SIM, "--quiet", "--set", LEFT_HALF, "--random", "6", "--seed", "0"],
        within_s=30,
    )
    assert done.code == 0, done.stderr
    assert done.stdout.splitlines()[-1] == "sorted 6 of 6 objects (simulated)"


@pytest.mark.bad_input
def test_random_says_when_the_work_area_leaves_no_room() -> None:
    corner = "vision.work_area_px=[[600,0],[640,0],[640,40]]"
    out = check_bad_input(["sort", *SIM, "--set", corner, "--random", "3"], within_s=30)
    assert (
        "100 % lies outside the work area (vision.work_area_px: u 600 to 640, v 0 to 40 px), "
        "where nothing is detected" in out.line
    ), out.line
