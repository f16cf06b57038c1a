"""``mearm calibrate-camera --config NAME`` with the name of a shipped config: both modes
say the option takes a file's path (a shipped config is not edited), not only "not found"."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from mearm.cli import run
from mearm.tools.calibrate_camera import main

INTRINSICS = Path(__file__).resolve().parents[1] / "configs/calibration/twin_intrinsics.yaml"
#: Four markers 7 cm apart (3 cm markers closer than their side would overlap: refused).
MARKERS = [a for i in range(4) for a in ("--marker", f"{i}:{5 * i + 1},{5 * i + 1}")]


def calibrate(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """Exit status and stderr of ``mearm calibrate-camera ARGV`` in process."""
    with pytest.raises(SystemExit) as info:
        run(main, argv)
    return int(info.value.code or 0), capsys.readouterr().err


def test_the_pose_mode_says_a_shipped_name_is_not_a_file_to_edit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--intrinsics`` with ``--config sim_mujoco_perspective`` said only "config file not
    found"; nothing is written."""
    image = tmp_path / "table.png"
    cv2.imwrite(str(image), np.full((48, 64, 3), 200, np.uint8))
    out = tmp_path / "pose.yaml"
    argv = ["--intrinsics", str(INTRINSICS), "--config", "sim_mujoco_perspective"]
    argv += ["--image", str(image), *MARKERS, "--marker-side-cm", "3", "--out", str(out)]
    code, err = calibrate(argv, capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "names a config mearm ships" in err and "give its path" in err, err
    assert not out.exists()


def test_the_homography_mode_says_it_too(capsys: pytest.CaptureFixture[str]) -> None:
    points = [a for p in ("1,1:1,1", "2,1:2,1", "2,2:2,2", "1,2:1,2") for a in ("--point", p)]
    code, err = calibrate(["--config", "sim_mujoco_perspective", *points], capsys)
    assert code == 2 and "names a config mearm ships" in err, err
