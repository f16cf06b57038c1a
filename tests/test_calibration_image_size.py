"""A homography holds at the frame size it was fitted at: a camera of another size is refused.

A maker who switched the webcam from 640x480 to 1280x960 without recalibrating had every
pixel mapped to the wrong table point: ``mearm sort`` ran, noted most of the view out of
reach, and sorted 0 of 12 ("pick failed 3 times"). ``calibration.image_size_px`` records
the size (``mearm calibrate-camera`` writes it; the shipped configs give 640x480), and a
config whose camera differs is refused when it loads: exit 2, one line naming both sizes
and what to do. A homography of unknown size (``null``, or given without it) is not
checked. The real loader and the real commands.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import pytest
from badinput import (
    ROOT,
    check_bad_input,
    check_bad_input_subprocess,
    refused_line,
    run_in_process,
)

from mearm.config import Config, load_config
from mearm.sim import TableRenderer
from mearm.vision import Calibration
from mearm.vision.aruco import draw_marker_on_table

SIM = ROOT / "configs" / "sim.yaml"
#: The paper's calibrated field's corners at 1280x960 (the same field, twice the pixels).
POINTS_1280 = ["0,0:-20.5,59", "1280,0:19.5,59", "1280,960:19.5,29", "0,960:-20.5,29"]
MARKERS = {0: (-17.0, 56.0), 1: (16.0, 56.0), 2: (16.0, 32.0), 3: (-17.0, 32.0)}


def _said(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


@pytest.mark.bad_input
@pytest.mark.parametrize(
    ("sets", "size"),
    [
        (["camera.width_px=1280", "camera.height_px=960"], "1280x960"),
        (["camera.width_px=320", "camera.height_px=240"], "320x240"),
        (["camera.width_px=4096"], "4096x480"),
        (["camera.height_px=960"], "640x960"),
    ],
)
def test_the_twin_at_another_frame_size_is_refused(sets: list[str], size: str) -> None:
    argv = ["sort", "--config", "sim_mujoco"]
    for s in sets:
        argv += ["--set", s]
    line = _said(check_bad_input_subprocess(argv, within_s=20.0).stderr)
    assert f"the camera gives {size} px frames" in line
    assert "fitted to 640x480 px" in line
    assert "mearm calibrate-camera" in line
    assert "camera.width_px=640 and camera.height_px=480 back" in line


@pytest.mark.bad_input
def test_a_config_file_that_changes_only_the_camera_is_refused(tmp_path: Path) -> None:
    config = tmp_path / "mine.yaml"
    config.write_text(f"extends: {SIM}\ncamera:\n  width_px: 1280\n  height_px: 960\n")
    line = _said(check_bad_input(["sort", "--config", config], keep=[config]).stderr)
    assert f"{config}: camera.width_px: the camera gives 1280x960 px frames" in line
    assert "fitted to 640x480 px" in line


def test_the_built_in_homography_is_the_papers_640_by_480() -> None:
    assert Config().calibration.image_size_px == (640, 480)
    with pytest.raises(Exception, match="fitted to 640x480 px"):
        load_config(None, overrides=["camera.width_px=1280", "camera.height_px=960"])


def test_a_homography_of_unknown_size_is_not_checked(tmp_path: Path) -> None:
    """``null``, a homography a file gives without its size, or one --set gives."""
    half = "[[0.03125, 0.0, -20.5], [0.0, -0.03125, 59.0], [0.0, 0.0, 1.0]]"
    camera = ["camera.width_px=1280", "camera.height_px=960"]
    cal = load_config(SIM, overrides=[*camera, "calibration.image_size_px=null"]).calibration
    assert cal.image_size_px is None
    own = tmp_path / "own.yaml"
    own.write_text(
        f"extends: {SIM}\ncamera: {{width_px: 1280, height_px: 960}}\n"
        f"calibration:\n  homography: {half}\n"
    )
    assert load_config(own).calibration.image_size_px is None
    cal = load_config(SIM, overrides=[*camera, f"calibration.homography={half}"]).calibration
    assert cal.image_size_px is None
    # ... but a size given with it is checked
    with pytest.raises(Exception, match="fitted to 640x480 px"):
        load_config(
            SIM,
            overrides=[
                *camera, f"calibration.homography={half}", "calibration.image_size_px=[640, 480]"
            ],
        )  # fmt: skip


def test_calibrate_camera_points_write_the_cameras_size_and_the_sort_loads(
    tmp_path: Path,
) -> None:
    """The recalibration the refusal points at: the config then loads at the new size."""
    config = tmp_path / "mine.yaml"
    config.write_text(f"extends: {SIM}\ncamera:\n  width_px: 1280\n  height_px: 960\n")
    points = [a for p in [*POINTS_1280, "640,480:-0.5,44"] for a in ("--point", p)]
    out = run_in_process(["calibrate-camera", "--config", config, *points])
    assert out.code == 0, out.stderr
    assert "image_size_px: [1280, 960]" in config.read_text()
    loaded = load_config(config)
    assert loaded.calibration.image_size_px == (1280, 960)
    assert loaded.calibration.homography[0][0] == pytest.approx(0.03125)


def test_calibrate_camera_dry_run_prints_the_size_it_would_record(tmp_path: Path) -> None:
    """--dry-run shows every value it would write, the frame size among them."""
    config = tmp_path / "mine.yaml"
    config.write_text(f"extends: {SIM}\ncamera:\n  width_px: 1280\n  height_px: 960\n")
    before = config.read_bytes()
    points = [a for p in [*POINTS_1280, "640,480:-0.5,44"] for a in ("--point", p)]
    out = run_in_process(["calibrate-camera", "--config", config, *points, "--dry-run"])
    assert out.code == 0, out.stderr
    assert "image size: 1280x960 px (calibration.image_size_px)" in out.stdout.splitlines()
    assert config.read_bytes() == before


@pytest.fixture(scope="module")
def picture(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The paper camera's 640x480 picture of four 4 cm markers."""
    lab = Calibration.from_config(Config().calibration)
    frame = TableRenderer(lab, table="wood").render([])
    for marker_id, center in MARKERS.items():
        draw_marker_on_table(frame, lab, marker_id, center, 4.0)
    path = tmp_path_factory.mktemp("markers") / "table.png"
    cv2.imwrite(str(path), frame)
    return path


def _markers() -> list[str]:
    return [a for i, (x, y) in MARKERS.items() for a in ("--marker", f"{i}:{x:g},{y:g}")]


def test_calibrate_camera_writes_the_pictures_size(tmp_path: Path, picture: Path) -> None:
    config = tmp_path / "mine.yaml"
    config.write_text(f"extends: {SIM}\ncalibration:\n  image_size_px: null\n")
    argv = ["calibrate-camera", "--config", config, "--image", picture, "--marker-side-cm", "4"]
    out = run_in_process([*argv, *_markers()])
    assert out.code == 0, out.stderr
    assert load_config(config).calibration.image_size_px == (640, 480)


@pytest.mark.bad_input
def test_calibrate_camera_refuses_a_picture_of_another_size(tmp_path: Path, picture: Path) -> None:
    config = tmp_path / "mine.yaml"
    config.write_text(f"extends: {SIM}\ncamera:\n  width_px: 1280\n  height_px: 960\n")
    argv = ["calibrate-camera", "--config", config, "--image", picture, *_markers()]
    line = _said(check_bad_input(argv, keep=[config]).stderr)
    assert "is 640x480 px but the camera gives 1280x960 px frames" in line
    assert "nothing written" in line


@pytest.mark.bad_input
def test_the_refusal_names_the_config_to_recalibrate(tmp_path: Path) -> None:
    """The recalibration it suggests names the config given, not a placeholder ``FILE``."""
    config = tmp_path / "my arm.yaml"  # a name the shell must quote
    config.write_text(f"extends: {SIM}\ncamera:\n  width_px: 1280\n  height_px: 960\n")
    line = refused_line(["sort", "--config", "my arm.yaml"], cwd=tmp_path)
    assert "mearm calibrate-camera --config 'my arm.yaml' --image PICTURE" in line
    assert "FILE" not in line
    line = refused_line(["sort", "--config", "sim_mujoco", "--set", "camera.width_px=4096"])
    assert "as sim_mujoco is one mearm ships" in line
    assert "mearm calibrate-camera --config MINE.yaml" in line
    assert "FILE" not in line
