"""``mearm calibrate-camera`` fitting a homography into a perspective config says so.

Such a config places what the camera sees with its intrinsics and pose files; the
homography written only outlines the camera's view. The tool wrote it with ``wrote the
calibration`` and nothing else, and the next sort placed objects as before.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from mearm.config import load_config
from mearm.tools import calibrate_camera

ROOT = Path(__file__).resolve().parent.parent
CORNER_POINTS = ["0,0:-20.5,59", "640,0:19.5,59", "640,480:19.5,29", "0,480:-20.5,29"]
POINTS = [a for p in [*CORNER_POINTS, "320,240:-0.5,44"] for a in ("--point", p)]


@pytest.mark.parametrize(
    ("base", "noted"), [("sim_mujoco_perspective.yaml", True), ("sim.yaml", False)]
)
def test_a_homography_a_perspective_config_does_not_place_by_is_said(
    base: str, noted: bool, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "mine.yaml"
    config.write_text(f"extends: {ROOT / 'configs' / base}\n")
    assert calibrate_camera.main(["--config", str(config), *POINTS]) == 0
    out, err = capsys.readouterr()
    assert f"wrote the calibration into {config}" in out
    assert load_config(config).calibration.homography is not None
    said = [line for line in err.splitlines() if "calibration.model: perspective" in line]
    if noted:
        assert len(said) == 1, err
        assert "not this homography" in said[0] and "--intrinsics" in said[0]
    else:
        assert not said, err
