"""``vision.work_area_px: whole_frame``: what ``learn-colours --whole-frame`` writes.

``--whole-frame`` wrote no work area, so NEW.yaml kept the polygon of the config it
extends, and ``null`` is the table's outline under a perspective calibration: there was
no way to say "the whole frame".
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import run_guarded as call

from mearm.config import Config, config_from_dict, load_config
from mearm.detect import main as detect_main
from mearm.errors import ConfigError
from mearm.maker.learn_colours import main as learn_main
from mearm.vision import Calibration, ColorDetector
from mearm.vision.calibration import camera_geometry

ROOT = Path(__file__).resolve().parents[1]
CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
LAYOUT = [(o.color, o.x, o.y) for o in CONFIG.task.scene]
#: One object of each class, all left of u = 340 (the base config's work area).
SAMPLES = ["--sample", "red=152,149", "--sample", "green=195,83", "--sample", "blue=167,240"]
LEFT_HALF = "[[0, 0], [340, 0], [340, 480], [0, 480]]"


@pytest.fixture
def left_half(tmp_path: Path) -> Path:
    """A config whose work area is the frame's left half (6 of the 12 objects)."""
    base = tmp_path / "left.yaml"
    base.write_text(f"extends: sim\nvision:\n  work_area_px: {LEFT_HALF}\n")
    return base


def test_whole_frame_replaces_the_polygon_extended(
    frame_png: Path,  # conftest's: the rendered table
    left_half: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``--whole-frame`` over a config with a polygon: NEW.yaml says ``whole_frame`` and
    detect finds all 12 objects (it kept the left half: 6)."""
    out = tmp_path / "new.yaml"
    argv = [str(frame_png), *SAMPLES, "--whole-frame", "--config", str(left_half)]
    code, text, err = call(learn_main, [*argv, "--out", str(out)], capsys)
    assert code == 0, err
    assert "work area: whole frame\n" in text, text
    assert "work_area_px: whole_frame\n" in out.read_text()
    assert load_config(out).vision.model_dump(mode="json")["work_area_px"] == "whole_frame"
    code, text, err = call(detect_main, ["--config", str(out), str(frame_png), "--json"], capsys)
    assert code == 0, err
    assert sorted(d["color"] for d in json.loads(text)) == sorted(c for c, _, _ in LAYOUT)


def test_no_table_found_is_the_whole_frame_too(
    left_half: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """No table around the samples: the line says "whole frame" and the colours' reference
    is the whole frame's, so NEW.yaml says ``whole_frame`` (it kept the polygon extended)."""
    frame = np.full((480, 640, 3), (40, 160, 40), np.uint8)  # a green field
    cv2.circle(frame, (160, 240), 65, (128, 128, 128), -1)  # the table, 4.3 % of the frame
    cv2.circle(frame, (160, 240), 16, (40, 40, 200), -1)  # a red object on it
    path = tmp_path / "f.png"
    cv2.imwrite(str(path), frame)
    out = tmp_path / "new.yaml"
    argv = [str(path), "--sample", "red=160,240", "--config", str(left_half), "--out", str(out)]
    code, text, err = call(learn_main, argv, capsys)
    assert code == 0, err
    assert "work area: whole frame (no table found" in text, text
    assert load_config(out).vision.model_dump(mode="json")["work_area_px"] == "whole_frame"


def test_the_value_is_validated_and_written_back() -> None:
    """``whole_frame`` loads, is written back as it was spelled, and loads again; another
    word is refused naming the key and what it may be."""
    config = config_from_dict({"vision": {"work_area_px": "whole_frame"}})
    data = config.model_dump(mode="json")
    assert data["vision"]["work_area_px"] == "whole_frame"
    assert config_from_dict(data) == config
    with pytest.raises(ConfigError) as info:
        config_from_dict({"vision": {"work_area_px": "whole"}})
    assert "vision.work_area_px" in str(info.value) and "whole_frame" in str(info.value)


@pytest.mark.parametrize("area", [None, "whole_frame"])
def test_detection_keeps_every_pixel_under_a_perspective_calibration(area: str | None) -> None:
    """Under a perspective calibration ``null`` is the calibrated table's outline, which
    leaves out part of the frame; ``whole_frame`` keeps every pixel of it."""
    config = load_config(
        ROOT / "configs" / "sim_mujoco_perspective.yaml", [f"vision.work_area_px={area or 'null'}"]
    )
    geometry = camera_geometry(config.calibration, config.camera)
    detector = ColorDetector.from_config(
        config.vision, config.calibration, config.camera, config.task.classes, geometry=geometry
    )
    shape = (config.camera.height_px, config.camera.width_px)
    mask = detector.work_area(shape)
    assert mask is not None
    kept = cv2.countNonZero(mask) / (shape[0] * shape[1])
    assert (kept == 1.0) == (area == "whole_frame"), kept
