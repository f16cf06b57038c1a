"""Picks beside a bin's wall keep the arm's position error from it (``task.position_error_cm``).

The collision check keeps ``task.clearance_cm`` from the walls at the planned pose. An arm
whose servos were never calibrated lands up to a centimetre off it: the paper's arm with
a kit of servos (``sim_mujoco_kits_paper --random 21 --seed 50031``, simulated) came down
with a pad on the blue bin's wall, planned 0.41 cm from it, and the shoulder stalled. The
rig's measured error, given as ``task.position_error_cm``, is kept from the walls where the
jaws come down, on top of the clearance: the pick is moved off the wall
(:meth:`PickAndPlace._off_the_wall`), and refused where no move in the jaws' room clears it.
The red bin of ``sim`` stands at (-20, 35) cm, its wall at x = -17 cm.
"""

from __future__ import annotations

import re
from pathlib import Path

from conftest import mearm_here


def _sort_one(tmp_path: Path, x_cm: float, *settings: str) -> tuple[int, str]:
    """Sort one red object standing at (x, 35) cm on the kinematic rig: exit code, stdout."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"- {{color: red, x: {x_cm}, y: 35.0}}\n", encoding="utf-8")
    sets = [a for s in settings for a in ("--set", s)]
    proc = mearm_here("sort", "--config", "sim", "--scene", scene, *sets, cwd=tmp_path)
    return proc.returncode, proc.stdout


def _pick_x_cm(out: str) -> float:
    """The x of the one pick's target the sort printed [cm]."""
    found = re.search(r"^pick  red1 +target \( *(-?[\d.]+),", out, re.MULTILINE)
    assert found is not None, out
    return float(found.group(1))


def test_a_pick_within_the_error_of_a_wall_is_moved_off_it(tmp_path: Path) -> None:
    """With a 1 cm error the pick beside the red bin goes farther from its wall: sorted.

    It keeps the clearance at the planned pose, so without the error it goes where the
    camera sees the object (-13.99 cm), a pad 1.06 cm from the wall, which an arm 1 cm off
    lands on.
    """
    code, out = _sort_one(tmp_path, -14.0, "task.position_error_cm=1")
    assert _pick_x_cm(out) > -13.7, out
    assert "sorted 1 of 1 objects" in out, out
    assert code == 0, out


def test_without_an_error_the_pick_goes_where_the_object_is_seen(tmp_path: Path) -> None:
    """The default (no error) leaves the pick where it was: at the object."""
    code, out = _sort_one(tmp_path, -14.0)
    assert _pick_x_cm(out) < -13.9, out
    assert code == 0, out


def test_a_pick_no_move_clears_is_refused_naming_the_error(tmp_path: Path) -> None:
    """Where no move within the jaws' room keeps the error from the wall, the pick is refused."""
    code, out = _sort_one(tmp_path, -14.6, "task.position_error_cm=1")
    assert "from the red bin's wall, less than task.clearance_cm and" in out, out
    assert "task.position_error_cm (0.3 + 1 cm)" in out, out
    assert "sorted 0 of 1 objects" in out, out
    assert code == 1, out
