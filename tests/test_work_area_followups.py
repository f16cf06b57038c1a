"""Work areas that can find nothing: refused alike by learn-colours, detect and sort.

- Points on one line enclose no area: ``mearm detect`` took such a ``vision.work_area_px``
  and said "0 object(s)" (exit 0) while ``learn-colours --work-area`` refused it; now one
  check (``mearm.vision.work_area.flat_work_area``) refuses it in every command, in the
  same words.
- A ``--work-area`` wholly off the frame was refused as "no sample inside": now the
  message says the polygon lies off the frame and gives the frame's size.
- A ``--work-area`` drawn tightly around the clicked object made its colour the table's
  (``vision.reference_bgr``); the config written found nothing, even on the frame taught
  on, and learn-colours exited 0. Now it is refused (exit 2), as is a work area that
  keeps too little of a clicked object for the detector to take it for one.
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import ROOT, check_bad_input
from badinput import run_guarded as call

from mearm.config import Config, load_config
from mearm.detect import main as detect_main
from mearm.errors import ConfigError
from mearm.maker.learn_colours import main as learn_main
from mearm.vision import Calibration

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
LAYOUT = [(o.color, o.x, o.y) for o in CONFIG.task.scene]
SIM = str(ROOT / "configs" / "sim.yaml")


def _red_click() -> tuple[int, int]:
    """The pixel at the first red object's centre."""
    _, x, y = next(o for o in LAYOUT if o[0] == "red")
    ((u, v),) = CAL.table_to_pixel(np.array([[x, y]]))
    return round(float(u)), round(float(v))


def _red_box(frame_png: Path) -> tuple[int, int, int, int]:
    """The red object's bounding box (x0, y0, x1, y1) [px], both ends in it: the red
    pixels (R over G and B by 60: the frame is noisy) connected to the click."""
    frame = cv2.imread(str(frame_png)).astype(int)
    u, v = _red_click()
    red = (frame[..., 2] - frame[..., :2].max(axis=2) > 60).astype(np.uint8)
    _, labels = cv2.connectedComponents(red, connectivity=8)
    ys, xs = np.nonzero(labels == labels[v, u])
    return int(xs.min()), int(ys.min()), int(xs.max()), int(ys.max())


def _corners(x0: float, y0: float, x1: float, y1: float) -> list[str]:
    return [f"{x0:g},{y0:g}", f"{x1:g},{y0:g}", f"{x1:g},{y1:g}", f"{x0:g},{y1:g}"]


@pytest.mark.bad_input
@pytest.mark.parametrize(
    "points",
    [[(100, 100), (200, 200), (300, 300)], [(50, 80), (50, 80), (50, 80)]],
    ids=["diagonal", "one-point"],
)
def test_a_polygon_on_one_line_is_refused_alike_by_every_command(
    points: list[tuple[int, int]], frame_png: Path, tmp_path: Path
) -> None:
    """learn-colours, detect and sort: exit 2, one line, the same words after the name
    the polygon was given by (detect said "0 object(s)" and exited 0)."""
    out = tmp_path / "x.yaml"
    typed = [f"{u},{v}" for u, v in points]
    setting = "vision.work_area_px=" + json.dumps([list(p) for p in points])
    u, v = _red_click()
    learn = check_bad_input(
        ["learn-colours", frame_png, "--sample", f"red={u},{v}", "--config", SIM,
         "--out", out, "--work-area", *typed],
        keep=[frame_png],
    )  # fmt: skip
    detect = check_bad_input(["detect", "--config", SIM, "--set", setting, frame_png])
    sort = check_bad_input(["sort", "--config", SIM, "--set", setting, "--log", out])
    assert not out.exists()
    said = "encloses 0 px² (its points, "
    assert learn.line.startswith(f"mearm learn-colours: error: --work-area {said}"), learn.line
    # the config refuses it as it loads (the --set names the setting)
    assert detect.line.startswith(f"mearm detect: error: --set: vision.work_area_px: {said}")
    assert sort.line.startswith(f"mearm sort: error: --set: vision.work_area_px: {said}")
    assert learn.line.split(said)[1] == detect.line.split(said)[1] == sort.line.split(said)[1]
    assert detect.stdout == ""


def test_a_config_file_with_a_flat_work_area_is_refused_as_it_loads(tmp_path: Path) -> None:
    """A file's ``vision.work_area_px`` on one line: refused at load, naming the file (it
    loaded, and only the commands that check it against a frame refused it)."""
    path = tmp_path / "flat.yaml"
    path.write_text(f"extends: {SIM}\nvision:\n  work_area_px: [[10, 20], [30, 40], [50, 60]]\n")
    with pytest.raises(ConfigError, match=r"flat\.yaml: vision\.work_area_px: encloses 0 px²"):
        load_config(path)
    assert load_config(SIM).vision.work_area_px is None  # (the file it extends: no polygon)


@pytest.mark.bad_input
def test_a_work_area_off_the_frame_says_so_and_gives_the_frames_size(
    frame_png: Path, tmp_path: Path
) -> None:
    """Wholly off the 640x480 frame (within the points' range): the line says the polygon
    keeps no pixel of the frame and its size, not that a class has no sample inside."""
    out = tmp_path / "x.yaml"
    u, v = _red_click()
    got = check_bad_input(
        ["learn-colours", frame_png, "--sample", f"red={u},{v}", "--config", SIM,
         "--out", out, "--work-area", *_corners(1000, 1000, 1100, 1100)],
        keep=[frame_png],
    )  # fmt: skip
    assert got.line == (
        "mearm learn-colours: error: --work-area (u 1000 to 1100, v 1000 to 1100 px) has no "
        f"pixel in {frame_png}'s 640x480 px frame, so nothing can be detected there: give "
        "its points in that frame's pixels (0 <= U < 640, 0 <= V < 480; a polygon past the "
        "frame is clipped to it)"
    ), got.line
    assert not out.exists()


@pytest.mark.bad_input
def test_a_work_area_drawn_on_the_object_is_refused(frame_png: Path, tmp_path: Path) -> None:
    """Drawn inside the red object: its median (the reference, taken for the table's) is
    the object's colour; the config written detected nothing and the exit was 0."""
    out = tmp_path / "x.yaml"
    u, v = _red_click()
    got = check_bad_input(
        ["learn-colours", frame_png, "--sample", f"red={u},{v}", "--config", SIM,
         "--out", out, "--work-area", *_corners(u - 6, v - 6, u + 6, v + 6)],
        keep=[frame_png],
    )  # fmt: skip
    assert got.line.startswith(
        f"mearm learn-colours: error: sample red={u},{v}: the work area's median colour, "
        "which stands for the table's (vision.reference_bgr), is this object's (ΔE "
    ), got.line
    assert "give a --work-area around the table, not around the object" in got.line
    assert not out.exists()


@pytest.mark.bad_input
def test_a_work_area_keeping_a_sliver_of_the_object_is_refused(
    frame_png: Path, tmp_path: Path
) -> None:
    """The work area's edge runs two pixels inside the clicked object: the reference is
    the table's, but the colours taught keep under ``vision.min_area_px`` of the object,
    so the config would find nothing there (the exit was 0)."""
    out = tmp_path / "x.yaml"
    x0, y0, x1, y1 = _red_box(frame_png)
    assert 2 * (y1 - y0 + 1) < CONFIG.vision.min_area_px  # two columns are no object
    click = f"red={x1},{(y0 + y1) // 2}"
    got = check_bad_input(
        ["learn-colours", frame_png, "--sample", click, "--config", SIM, "--out", out,
         "--work-area", *_corners(x1 - 1.5, 0, 639, 479)],
        keep=[frame_png],
    )  # fmt: skip
    assert got.line.startswith(
        f"mearm learn-colours: error: sample {click}: the colours taught keep "
    ), got.line
    assert f"(an object needs vision.min_area_px, {CONFIG.vision.min_area_px:g})" in got.line
    assert not out.exists()


def test_a_work_area_around_the_object_and_its_table_teaches(
    frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The guards refuse only what finds nothing: a small work area holding the object
    and some table around it teaches, and detect finds the object with it."""
    out = tmp_path / "x.yaml"
    x0, y0, x1, y1 = _red_box(frame_png)
    u, v = _red_click()
    area = _corners(x0 - 12, y0 - 12, x1 + 12, y1 + 12)
    argv = [str(frame_png), "--sample", f"red={u},{v}", "--config", SIM, "--out", str(out),
            "--work-area", *area]  # fmt: skip
    code, _, err = call(learn_main, argv, capsys)
    assert code == 0, err
    code, text, err = call(detect_main, ["--config", str(out), str(frame_png), "--json"], capsys)
    assert code == 0, err
    assert [d["color"] for d in json.loads(text)] == ["red"], text
