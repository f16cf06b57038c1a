"""``python -m mearm.detect``: JSON, text, annotation, and one-line errors (exit 2)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import run_main

from mearm import detect
from mearm.backends import open_camera
from mearm.config import Config, load_config
from mearm.sim import TableRenderer, class_discs
from mearm.vision import Calibration

ROOT = Path(__file__).resolve().parent.parent
CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
LAB_YAML, SIM_YAML = str(ROOT / "configs" / "lab.yaml"), str(ROOT / "configs" / "sim.yaml")


@pytest.fixture(scope="module")
def images(tmp_path_factory) -> list[Path]:
    d = tmp_path_factory.mktemp("frames")
    renderer = TableRenderer(CAL)
    layout = renderer.render(
        class_discs(CONFIG.task.classes, [(o.color, o.x, o.y) for o in CONFIG.task.scene])
    )
    empty = renderer.render([], frame_index=1)
    paths = [d / "layout.png", d / "empty.png"]
    cv2.imwrite(str(paths[0]), layout)
    cv2.imwrite(str(paths[1]), empty)
    return paths


def run_cli(capsys, *args: str) -> tuple[int, str, str]:
    return run_main(capsys, detect.main, *args)


def test_json_one_list_per_image(capsys, images: list[Path]) -> None:
    """Each image gives one JSON line; the layout's 12 objects at their cm positions."""
    code, out, err = run_cli(capsys, "--config", LAB_YAML, "--json", *map(str, images))
    assert code == 0 and err == ""
    layout, empty = (json.loads(line) for line in out.splitlines())
    assert empty == []
    assert [r["color"] for r in layout] == ["red"] * 4 + ["green"] * 4 + ["blue"] * 4
    truth = {(o.color, o.x, o.y) for o in CONFIG.task.scene}
    for r in layout:
        assert set(r) == {"color", "px", "cm", "area_px", "merged", "cut", "shape", "yaw_deg"}
        assert (r["cut"], r["shape"], r["yaw_deg"]) == (False, "cylinder", None)
        assert (
            min(np.hypot(r["cm"][0] - x, r["cm"][1] - y) for c, x, y in truth if c == r["color"])
            < 0.1
        )
        np.testing.assert_allclose(CAL.pixel_to_table(r["px"]), r["cm"], atol=2e-3)
        assert 700 < r["area_px"] < 900 and r["merged"] is False


def test_objects_cut_by_the_border_are_flagged(capsys, tmp_path: Path) -> None:
    """An object half out of the frame is reported ``cut`` (JSON, text), its shape untold."""
    frame = TableRenderer(CAL).render(
        class_discs(CONFIG.task.classes, [("red", -20.5, 45.0), ("green", 0.0, 45.0)])
    )
    path = tmp_path / "edge.png"
    cv2.imwrite(str(path), frame)
    code, out, _ = run_cli(capsys, "--json", str(path))
    assert code == 0
    red, green = json.loads(out)
    assert (red["color"], red["cut"], red["shape"]) == ("red", True, None)
    assert (green["color"], green["cut"], green["shape"]) == ("green", False, "cylinder")
    code, out, _ = run_cli(capsys, str(path))
    lines = out.splitlines()
    assert lines[1].split()[0] == "red" and "  ?  " in lines[1] and lines[1].endswith("  cut")
    assert lines[2].split()[0] == "green" and lines[2].endswith("  cylinder")


def test_text_output(capsys, images: list[Path]) -> None:
    code, out, _ = run_cli(capsys, str(images[0]))
    assert code == 0
    lines = out.splitlines()
    assert lines[0].endswith("layout.png: 12 object(s)") and len(lines) == 13
    assert lines[1].split()[0] == "red" and "cm (" in lines[1] and "area" in lines[1]


def test_annotate_one_image(capsys, images: list[Path], tmp_path: Path) -> None:
    """--annotate OUT.png writes OUT.png: the frame with drawings on it."""
    out = tmp_path / "ann.png"
    code, _, _ = run_cli(capsys, str(images[0]), "--annotate", str(out))
    assert code == 0
    drawn, frame = cv2.imread(str(out)), cv2.imread(str(images[0]))
    assert drawn.shape == frame.shape
    changed = np.any(drawn != frame, axis=2).mean()
    assert 0.005 < changed < 0.2  # contours, crosses, labels; not a new picture


def test_annotate_several_images_gets_an_index(capsys, images: list[Path], tmp_path: Path) -> None:
    """With several images, OUT.png becomes OUT-0.png, OUT-1.png in argument order."""
    out = tmp_path / "ann.png"
    code, _, _ = run_cli(capsys, "--json", *map(str, images), "--annotate", str(out))
    assert code == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ann-0.png", "ann-1.png"]
    empty = cv2.imread(str(images[1]))
    assert np.array_equal(cv2.imread(str(tmp_path / "ann-1.png")), empty)  # nothing to draw


def test_camera_frame_from_the_sim(capsys) -> None:
    """--camera grabs one frame of the configured camera: the sim table."""
    code, out, _ = run_cli(capsys, "--config", SIM_YAML, "--camera", "--json")
    assert code == 0 and len(json.loads(out)) == 12


FOUR_CLASSES_YAML = """
camera: {table: grey}
task:
  classes:
    - {name: red, hue_bands_deg: [{lo_deg: 330, hi_deg: 15}], draw_rgb: [200, 30, 35],
       bin_cm: [-20, 35, 20]}
    - {name: green, hue_bands_deg: [{lo_deg: 75, hi_deg: 165}], draw_rgb: [30, 160, 60],
       bin_cm: [-20, 45, 20]}
    - {name: blue, hue_bands_deg: [{lo_deg: 190, hi_deg: 255}], draw_rgb: [35, 60, 200],
       bin_cm: [-20, 55, 20]}
    - {name: yellow, hue_bands_deg: [{lo_deg: 45, hi_deg: 65}], draw_rgb: [230, 200, 30],
       bin_cm: [-20, 25, 20]}
  scene:
    - {color: yellow, x: 0.0, y: 35.0}
    - {color: red, x: -5.0, y: 45.0}
    - {color: yellow, x: 10.0, y: 50.0}
"""


def test_classes_come_from_the_config(capsys, tmp_path: Path) -> None:
    """A fourth class is found in class order; --annotate draws each in its draw_rgb."""
    path = tmp_path / "four.yaml"
    path.write_text(FOUR_CLASSES_YAML)
    out = tmp_path / "ann.png"
    code, text, _ = run_cli(capsys, "--config", str(path), "--camera", "--json", "--annotate",
                            str(out))  # fmt: skip
    assert code == 0
    assert [r["color"] for r in json.loads(text)] == ["red", "yellow", "yellow"]
    with open_camera(load_config(path)) as camera:
        frame = camera.read()  # the same seeded frame the CLI grabbed
    drawn = cv2.imread(str(out))
    changed = drawn[np.any(drawn != frame, axis=2)].astype(int)  # (N, 3) BGR
    for c in load_config(path).task.classes:
        near = np.abs(changed - c.draw_rgb[::-1]).max(axis=1) <= 10
        found = c.name in ("red", "yellow")  # no green or blue object in the scene
        assert (near.sum() > 20) if found else not near.any(), c.name


def test_size_mismatch_warns(capsys, tmp_path: Path) -> None:
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), np.full((240, 320, 3), 128, np.uint8))
    code, out, err = run_cli(capsys, "--json", str(small))
    assert code == 0 and json.loads(out) == []
    assert "small.png is 320x240 px; the calibration is for 640x480" in err


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["{missing}"], "missing.png: image file not found"),
        (["{garbage}"], "garbage.png: not an image of a known format (PNG, JPEG"),
        (["{layout}", "{missing}"], "missing.png: image file not found"),
        (["{folder}"], "is a directory, not an image file"),
        ([], "give IMAGE paths or --camera"),
        (["{layout}", "--camera"], "give IMAGE paths or --camera"),
        (["{layout}", "--annotate", "out.xyz"], "unknown image type"),
        (["--config", LAB_YAML, "--camera"], "camera (device 0): cannot open"),
    ],
)
def test_bad_input_exits_2_with_one_line(capsys, images, tmp_path: Path, args, words) -> None:
    """Missing/unreadable images and bad options: exit 2, one line, nothing on stdout."""
    garbage = tmp_path / "garbage.png"
    garbage.write_bytes(b"definitely not a png")
    names = {
        "missing": str(tmp_path / "missing.png"),
        "garbage": str(garbage),
        "layout": str(images[0]),
        "folder": str(tmp_path),
    }
    code, out, err = run_cli(capsys, *[a.format(**names) for a in args])
    assert code == 2 and out == ""
    assert words in err and len(err.strip().splitlines()) == 1


def test_module_runs_as_a_script(images: list[Path]) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "mearm.detect", "--json", str(images[1]), str(images[1]) + "x"],
        capture_output=True, text=True, timeout=60, cwd=ROOT,
    )  # fmt: skip
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr.strip().endswith("empty.pngx: image file not found")
