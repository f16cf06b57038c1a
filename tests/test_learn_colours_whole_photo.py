"""A table found over a whole large photo covers the camera's whole frame; a share short of
it never reads as 100 %.

From a newcomer's walk: ``mearm learn-colours img/big.png --sample red=... --config sim`` on
a 4000x3000 photo warned that the work area "covers 100%" of the camera's 640x480 frame,
though docs/vision.md says the warning comes only when it does not cover the whole frame.
The table was found on the photo shrunk for the search, and its edge pixels were mapped
back to the centres of the blocks they stood for: the polygon started 1.1 px in, leaving
out the camera frame's first row and column (99.6 %, printed rounded as 100 %).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import pytest
from badinput import run_in_process

from mearm.backends import grab_frame
from mearm.config import load_config
from mearm.yamlio import load_yaml_file

SCALE = 6.25  # 640x480 -> 4000x3000


@pytest.fixture(scope="module")
def big_photo(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The sim camera's frame as a 4000x3000 photo."""
    frame = grab_frame(load_config("sim"))
    path = tmp_path_factory.mktemp("photo") / "big.png"
    cv2.imwrite(str(path), cv2.resize(frame, (4000, 3000), interpolation=cv2.INTER_LINEAR))
    return path


def _sample() -> str:
    u, v = 316.0, 84.5  # a red object of sim's table in the camera's frame
    return f"red={round((u + 0.5) * SCALE - 0.5)},{round((v + 0.5) * SCALE - 0.5)}"


def test_the_table_over_the_whole_photo_is_the_whole_frame(big_photo: Path, tmp_path) -> None:
    out = tmp_path / "z2.yaml"
    argv = ["learn-colours", big_photo, "--sample", _sample(), "--config", "sim", "--out", out]
    done = run_in_process(argv, within_s=30)
    assert done.code == 0, done.stderr
    assert "work_area_px" not in done.stderr, done.stderr
    area = load_yaml_file(out)["vision"]["work_area_px"]
    assert sorted({u for u, _ in area}) == [0.0, 3999.0], area
    assert sorted({v for _, v in area}) == [0.0, 2999.0], area


def test_a_share_short_of_the_whole_frame_does_not_read_100(big_photo: Path, tmp_path) -> None:
    out = tmp_path / "z3.yaml"
    argv = ["learn-colours", big_photo, "--sample", _sample(), "--config", "sim", "--out", out,
            "--work-area", "1,1", "3998,1", "3998,2998", "1,2998"]  # fmt: skip
    done = run_in_process(argv, within_s=30)
    assert done.code == 0, done.stderr
    assert done.stderr.splitlines() == [
        "mearm learn-colours: warning: "
        f"vision.work_area_px is in the pixels of {big_photo} (4000x3000 px), but the "
        "config's camera gives 640x480 px frames (camera.width_px, camera.height_px), of "
        "which it covers 99.6%: to detect on the camera, teach on its frames (--camera) or "
        "give --whole-frame"
    ], done.stderr
