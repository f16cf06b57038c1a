"""A work area drawn on frames of another size than those it is used on.

``learn-colours`` writes ``vision.work_area_px`` in the pixels of the frame it was taught
on; taught on a photo and used on the camera (the simulated rig's 640x480), the polygon
kept a corner of the frame or nothing, the objects were never seen and nothing named
``vision.work_area_px``. Now ``learn-colours`` warns when the frame taught on is not the
camera's size, and ``detect`` refuses a polygon with no pixel in a frame (exit 2, before
any output) and warns when one leaves out most of a frame while lying mostly outside it.
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import pytest
from badinput import run_guarded as call

from mearm.config import Config
from mearm.detect import main as detect_main
from mearm.maker.learn_colours import main as learn_main
from mearm.sim import TableRenderer, class_discs
from mearm.vision import Calibration

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
LAYOUT = [(o.color, o.x, o.y) for o in CONFIG.task.scene]
#: A table's outline on a 2560x1920 photo: outside a 640x480 frame entirely.
PHOTO_AREA = "[[700, 500], [2400, 500], [2400, 1800], [700, 1800]]"


def render(scale: int) -> cv2.typing.MatLike:
    small = TableRenderer(CAL, 640, 480, table="grey").render(
        class_discs(CONFIG.task.classes, LAYOUT)
    )
    return cv2.resize(small, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)


@pytest.fixture(scope="module")
def frame_png(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("frames") / "frame.png"
    cv2.imwrite(str(path), render(1))
    return path


def with_area(tmp_path: Path, area: str) -> Path:
    config = tmp_path / "area.yaml"
    config.write_text(f"extends: sim\nvision:\n  work_area_px: {area}\n")
    return config


def test_a_work_area_outside_the_frame_is_refused(
    frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """No pixel of the frame in the work area: exit 2, one line naming it and the frame's
    size, nothing on stdout (it printed "0 object(s)" and exited 0)."""
    config = with_area(tmp_path, PHOTO_AREA)
    code, text, err = call(detect_main, ["--config", str(config), str(frame_png)], capsys)
    assert code == 2 and text == "", (text, err)
    assert len(err.strip().splitlines()) == 1, err
    assert "vision.work_area_px (u 700 to 2400, v 500 to 1800 px) has no pixel in" in err, err
    assert "640x480 px frame" in err, err


def test_on_the_simulated_camera_too(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``detect --camera`` on the simulated rig, with a photo's work area: refused."""
    config = with_area(tmp_path, PHOTO_AREA)
    code, text, err = call(detect_main, ["--config", str(config), "--camera"], capsys)
    assert code == 2 and text == "", (text, err)
    assert "vision.work_area_px" in err and "has no pixel in camera's 640x480 px frame" in err


@pytest.mark.parametrize(
    ("area", "warned", "found"),
    [
        # a photo's table reaching into the frame's corner: 14 % of it, 1 % of the polygon
        ("[[400, 300], [2400, 300], [2400, 1800], [400, 1800]]", True, 0),
        # past the frame to take in its edges: all of the frame
        ("[[-50, -50], [700, -50], [700, 600], [-50, 600]]", False, 12),
        # a small table inside the frame: 16 % of it, all of the polygon
        ("[[200, 60], [450, 60], [450, 300], [200, 300]]", False, 6),
        ("whole_frame", False, 12),
    ],
)
def test_a_work_area_drawn_on_another_frame_is_named(
    area: str,
    warned: bool,
    found: int,
    frame_png: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """A work area that leaves out most of the frame and lies mostly outside it: one
    warning line naming it; one past the frame's edges or inside it: none. The run goes
    on either way."""
    config = with_area(tmp_path, area)
    argv = ["--config", str(config), str(frame_png), "--json"]
    code, text, err = call(detect_main, argv, capsys)
    assert code == 0, err
    assert len(json.loads(text)) == found
    assert ("warning: vision.work_area_px" in err) == warned, err
    if warned:
        assert "covers 14% of" in err and "640x480 px frame" in err, err


@pytest.mark.heavy
@pytest.mark.parametrize(
    ("area", "warned"),
    [(["--work-area", "100,100", "1200,100", "1200,900", "100,900"], True), ([], False)],
)
def test_taught_on_a_frame_of_another_size(
    area: list[str], warned: bool, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Taught on a 1280x960 frame under sim's 640x480 camera: a work area that keeps
    part of the camera's frame is named in a warning; the table found, the whole photo,
    covers all of the camera's frame: no warning."""
    photo = tmp_path / "photo.png"
    cv2.imwrite(str(photo), render(2))
    samples = ["--sample", "red=304,298", "--sample", "green=390,166", "--sample", "blue=334,480"]
    out = tmp_path / "new.yaml"
    argv = [str(photo), *samples, *area, "--config", "sim", "--out", str(out)]
    code, _, err = call(learn_main, argv, capsys)
    assert code == 0, err
    said = "warning: vision.work_area_px is in the pixels of"
    assert (said in err) == warned, err
    if warned:
        assert "(1280x960 px), but the config's camera gives 640x480 px frames" in err, err
        assert "of which it covers 67%" in err, err
    assert f"# mearm learn-colours: {photo} (1280x960 px); samples" in out.read_text()
