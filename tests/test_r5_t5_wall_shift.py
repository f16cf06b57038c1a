"""Picks beside a bin's wall in the twin: moved off the wall, never into it.

The twin's overhead camera, calibrated on the table, sees a 1 cm object's top face about
0.3 cm outwards beside the bins (parallax), so a pick planned where it is seen may pass a
bin's wall within ``task.clearance_cm`` though the object stands clear of it. The pick is
tried again a little farther from the wall, within the open jaws' room beside the
object, every try checked for collisions (:meth:`PickAndPlace._off_the_wall`).
"""

from __future__ import annotations

from pathlib import Path

from conftest import mearm_here


def _sort_one(tmp_path: Path, x_cm: float, y_cm: float) -> tuple[int, str]:
    """Sort one green object standing at (x, y) [cm] in the twin: exit code, stdout (in this
    process: the picks are the point, not the process; an interpreter cost 0.3 s of CPU)."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"- {{color: green, x: {x_cm}, y: {y_cm}}}\n", encoding="utf-8")
    proc = mearm_here("sort", "--config", "sim_mujoco", "--scene", scene, cwd=tmp_path)
    return proc.returncode, proc.stdout


def test_an_object_clear_of_a_wall_but_seen_beside_it_is_sorted(tmp_path: Path) -> None:
    """Seen 0.3 cm nearer the red bin than it stands, the pick moves off the wall: sorted.

    Planned where it is seen, the left pad passes the red bin's wall within the
    clearance, and the object was skipped as a collision.
    """
    code, out = _sort_one(tmp_path, -14.6, 33.0)
    assert "sorted 1 of 1 objects" in out, out
    assert code == 0, out


def test_an_object_too_near_a_wall_is_still_skipped(tmp_path: Path) -> None:
    """Where no move within the jaws' room clears the wall, the collision check still refuses."""
    code, out = _sort_one(tmp_path, -15.4, 33.0)
    assert "collision: gripper_jaw_left_pad comes within 0.30 cm of bin_red_wall_px" in out, out
    assert "sorted 0 of 1 objects" in out, out
    assert code == 1, out
