"""calibrate-intrinsics: an image it reads is never its --out, even with --force.

Found walking docs/calibration.md: ``--out boards/board_00.png --force`` with ``--images
boards`` wrote the intrinsics' YAML over the first board view (a folder rerun then
refused it as "not an image"). calibrate-camera and check-camera already refuse their own
inputs so.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import check_bad_input

bad_input = pytest.mark.bad_input


def _blank(path: Path) -> Path:
    """A grey 640×480 picture without a board."""
    cv2.imwrite(str(path), np.full((480, 640), 200, np.uint8))
    return path


@bad_input
@pytest.mark.parametrize("given", ["folder", "file"])
def test_out_naming_an_image_read_is_refused_even_with_force(tmp_path: Path, given: str) -> None:
    """Exit 2, one line naming --out as an input; the image is left as it was."""
    views = tmp_path / "views"
    views.mkdir()
    image = _blank(views / "board_00.png")
    _blank(views / "board_01.png")
    source = views if given == "folder" else image
    out = check_bad_input(
        ["calibrate-intrinsics", "--images", source, "--out", image, "--force"],
        keep=[views],
    )
    assert "one of this run's inputs" in out.line, out.line
    assert not (views / "board_00.png.bak").exists()
