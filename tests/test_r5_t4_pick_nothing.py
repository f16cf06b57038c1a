"""``mearm learn-colours --pick`` with every class skipped (Esc) teaches nothing: refused.

It wrote a config with no colour taught, printed ``wrote ...`` and exited 0: a command
that did not do its job. Only the display is stood in for (a window that answers Esc).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import run_guarded as call

from mearm.maker.learn_colours import main


@pytest.fixture
def esc_window(monkeypatch: pytest.MonkeyPatch) -> None:
    """An OpenCV window on which each class is skipped with Esc."""
    monkeypatch.setattr(cv2, "namedWindow", lambda *a, **k: None)
    monkeypatch.setattr(cv2, "setMouseCallback", lambda *a, **k: None)
    monkeypatch.setattr(cv2, "imshow", lambda *a, **k: None)
    monkeypatch.setattr(cv2, "waitKey", lambda *a, **k: 27)
    monkeypatch.setattr(cv2, "destroyWindow", lambda *a, **k: None)


def test_pick_with_every_class_skipped_writes_nothing(
    esc_window: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    frame = np.full((480, 640, 3), 128, np.uint8)
    frame[200:230, 300:330] = (0, 0, 220)
    image = tmp_path / "frame.png"
    cv2.imwrite(str(image), frame)
    out = tmp_path / "taught.yaml"
    code, stdout, err = call(
        main, [str(image), "--pick", "--config", "sim", "--out", str(out)], capsys
    )
    assert code == 2, (stdout, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].endswith(
        "error: --pick: no class was clicked (Esc skipped each), so nothing was taught"
    ), err
    assert "wrote" not in stdout and not out.exists()
