"""``mearm learn-colours --radius`` wider than the object is not refused as a tight work area.

The check that the work area's median colour (the table's reference) is not a clicked
object's read "the object's colour" as the median of a square 2 x radius wide round the
click: with ``--radius 30`` (allowed: 0.5 to 50) round a 32 px cube, mostly table, so the
table was found to be "this object's" colour and the teaching refused, blaming the work
area. It now reads the colour the click teaches. A work area drawn tight round the
object is still refused.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import run_guarded as call

from mearm.config import load_config
from mearm.detect import main as detect_main
from mearm.maker.learn_colours import main


@pytest.fixture
def frame_png(tmp_path: Path) -> Path:
    """A wooden table with two red and two blue 32 px cubes (the sim camera's size)."""
    frame = np.full((480, 640, 3), (90, 140, 185), np.uint8)
    for u, v, bgr in [(200, 200, (40, 40, 200)), (420, 300, (40, 40, 200))]:
        frame[v - 16 : v + 16, u - 16 : u + 16] = bgr
    for u, v in [(300, 120), (480, 160)]:
        frame[v - 16 : v + 16, u - 16 : u + 16] = (200, 60, 30)
    path = tmp_path / "frame.png"
    cv2.imwrite(str(path), frame)
    return path


def test_a_radius_wider_than_the_object_teaches(
    frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "taught.yaml"
    argv = [str(frame_png), "--sample", "red=200,200", "--sample", "blue=300,120"]
    code, stdout, err = call(
        main, [*argv, "--radius", "30", "--config", "sim", "--out", str(out)], capsys
    )
    assert code == 0 and f"wrote {out}" in stdout, err
    assert load_config(out).task.classes[0].learned_colour is not None
    code, stdout, err = call(detect_main, ["--config", str(out), str(frame_png)], capsys)
    assert code == 0 and "4 object(s)" in stdout, (stdout, err)


def test_a_work_area_tight_round_the_object_is_still_refused(
    frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "taught.yaml"
    argv = [str(frame_png), "--sample", "red=200,200", "--radius", "30", "--config", "sim"]
    tight = ["--work-area", "186,186", "214,186", "214,214", "186,214"]
    code, _, err = call(main, [*argv, *tight, "--out", str(out)], capsys)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "the work area's median colour" in lines[0], err
    assert not out.exists()
