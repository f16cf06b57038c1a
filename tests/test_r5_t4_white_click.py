"""A click on a white pixel (a blown-out top) is refused with advice that fits it.

On the real photos a yellow cube's labelled centre is its top, blown out to white; the
refusal called it "a grey or black pixel" and said only "click on the object's colour".
It now says the pixel is white and to click the object's coloured side.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import run_guarded as call

from mearm.maker.learn_colours import main


def _frame(tmp_path: Path) -> Path:
    """A grey table with a yellow cube whose top is blown out to white."""
    frame = np.full((480, 640, 3), 128, np.uint8)
    frame[200:240, 300:340] = (0, 220, 230)  # yellow, BGR
    frame[208:232, 308:332] = 255  # the top, clipped
    path = tmp_path / "frame.png"
    cv2.imwrite(str(path), frame)
    return path


@pytest.mark.parametrize(
    ("click", "advice"),
    [
        ("320,220", "it is white, a highlight or a blown-out top: click on the object's coloured"),
        ("20,20", "): click on the object's colour"),  # the grey table: as before
    ],
)
def test_a_colourless_click_says_what_it_is_on(
    click: str, advice: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "x.yaml"
    argv = [str(_frame(tmp_path)), "--sample", f"yellow={click}", "--config", "sim_4colours"]
    code, _, err = call(main, [*argv, "--out", str(out)], capsys)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert "is on a grey or black pixel" in lines[0] and advice in lines[0], err
    assert not out.exists()
