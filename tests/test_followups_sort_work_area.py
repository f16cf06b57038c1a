"""``mearm sort`` checks ``vision.work_area_px`` against its camera's frames before it moves.

A polygon taught on a photo of another size may keep none of the camera's 640x480 px
frame (refused: exit 2, one line, before the run log opens) or only a corner of it (one
warning line on stderr; the sort goes on, and the objects elsewhere are never seen), as
``mearm detect`` says it (mearm.vision.work_area.check_work_area).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import ROOT, check_bad_input, run_in_process

SIM = ["sort", "--config", str(ROOT / "configs" / "sim.yaml")]


@pytest.mark.bad_input
def test_a_work_area_with_no_pixel_in_the_frame_is_refused(tmp_path: Path) -> None:
    """Drawn on a larger photo: exit 2, one line naming the polygon and the frame; no log."""
    log = tmp_path / "run.jsonl"
    out = check_bad_input(
        [*SIM, "--set", "vision.work_area_px=[[700,500],[900,500],[900,700]]", "--log", log],
        within_s=5, keep=[tmp_path],
    )  # fmt: skip
    assert out.line.startswith(
        "mearm sort: error: vision.work_area_px (u 700 to 900, v 500 to 700 px) has no pixel "
        "in the camera's 640x480 px frame"
    ), out.line
    assert out.stdout == ""
    assert not log.exists()


def test_a_work_area_keeping_a_corner_is_warned_about_and_the_sort_goes_on() -> None:
    """One warning line first; the sort runs and leaves the objects outside it unseen."""
    polygon = "[[-1000,-1000],[400,-1000],[400,300],[-1000,300]]"
    out = run_in_process([*SIM, "--quiet", "--set", f"vision.work_area_px={polygon}"],
                         within_s=10)  # fmt: skip
    lines = out.stderr.strip().splitlines()
    assert lines[0] == (
        "mearm sort: warning: vision.work_area_px (u -1000 to 400, v -1000 to 300 px) covers "
        "39% of the camera's 640x480 px frame and lies mostly outside it (drawn on frames of "
        "another size?): objects elsewhere in the frame are never detected"
    ), lines
    assert len(lines) == 2 and "never seen by the camera" in lines[1], lines
    assert out.code == 1
    assert "never seen by the camera" in out.stdout.splitlines()[-1]


def test_a_work_area_past_the_frame_edges_is_not_warned_about() -> None:
    """A polygon taking in the whole frame: no warning, every object sorted."""
    polygon = "[[-20,-20],[660,-20],[660,500],[-20,500]]"
    out = run_in_process([*SIM, "--quiet", "--set", f"vision.work_area_px={polygon}"],
                         within_s=10)  # fmt: skip
    assert out.code == 0, out.stderr
    assert out.stderr == ""
