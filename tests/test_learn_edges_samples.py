"""``mearm learn-colours --sample``: a refused sample is quoted as it was typed.

The messages named a sample by its class and pixel re-formatted (``red=1,2``), so the
``@I`` of ``CLASS=U,V@I`` and the spelling of the numbers were lost.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import run_guarded as call

from mearm.maker.learn_colours import main as learn_main
from mearm.vision.teaching import Sample


@pytest.fixture(scope="module")
def frames(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """Two grey 640x480 frames with a red disc at (320, 240)."""
    folder = tmp_path_factory.mktemp("frames")
    out = []
    for i in range(2):
        frame = np.full((480, 640, 3), 128, np.uint8)
        cv2.circle(frame, (320, 240), 16, (40, 40, 200), -1)
        path = folder / f"f{i}.png"
        cv2.imwrite(str(path), frame)
        out.append(path)
    return out


@pytest.mark.parametrize(
    ("sample", "n_images", "reason"),
    [
        ("red=1,2@3", 2, "there is no image 3"),
        ("red=700,100@1", 2, "is outside the image (640x480 px)"),
        ("red=5,5@1", 2, "is on a grey or black pixel"),
        ("red=5.0,0.5e1", 1, "is on a grey or black pixel"),
    ],
)
def test_a_refused_sample_is_quoted_as_typed(
    sample: str,
    n_images: int,
    reason: str,
    frames: list[Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Exit 2, one line quoting the ``--sample`` as typed, ``@I`` and all."""
    out = tmp_path / "x.yaml"
    argv = [*map(str, frames[:n_images]), "--sample", sample, "--config", "sim", "--out", str(out)]
    code, _, err = call(learn_main, argv, capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert f"error: sample {sample}: {reason}" in err, err
    assert not out.exists()


def test_a_sample_without_its_text_names_its_image() -> None:
    """A sample made in code (a click) says which image it is on when not the first."""
    assert str(Sample("red", 12.0, 3.5)) == "red=12,3.5"
    assert str(Sample("red", 12.0, 3.5, 1)) == "red=12,3.5@1"
