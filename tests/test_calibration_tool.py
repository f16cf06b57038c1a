"""tools/calibrate_camera.py and tools/aruco_sheet.py: fit, write in place, fail safely."""

from __future__ import annotations

import importlib
import os
import re
import struct
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from mearm.config import Config, load_config
from mearm.exceptions import CalibrationError
from mearm.sim import TableRenderer
from mearm.vision import Calibration
from mearm.vision.aruco import (
    calibration_from_markers,
    detect_markers,
    diagonal_center,
    draw_marker_on_table,
    get_dictionary,
    marker_image,
)

ROOT = Path(__file__).resolve().parent.parent
LAB = Calibration.from_config(Config().calibration)
TILTED = Calibration(LAB.H @ np.array([[1.0, 0.02, 0.0], [0.01, 1.0, 0.0], [1e-5, 2e-5, 1.0]]))
MARKERS = {0: (-17.0, 56.0), 1: (16.0, 56.0), 2: (16.0, 32.0), 3: (-17.0, 32.0)}
#: A config that writes out its calibration block, comments and all (lab.yaml takes
#: sim.yaml's through extends).
FULL_CONFIG = ROOT / "configs" / "sim.yaml"


def load_tool(name: str):
    """The command module behind ``tools/<name>.py`` (``mearm.tools.<name>``)."""
    return importlib.import_module(f"mearm.tools.{name}")


calibrate = load_tool("calibrate_camera")


def marker_scene(cal: Calibration, ids=MARKERS, table: str = "wood") -> np.ndarray:
    frame = TableRenderer(cal, table=table).render([])
    for marker_id, center in ids.items():
        draw_marker_on_table(frame, cal, marker_id, center, 4.0)
    return frame


def field_error_cm(fit: Calibration, truth: Calibration) -> float:
    u, v = np.meshgrid(np.linspace(0, 639, 33), np.linspace(0, 479, 25))
    px = np.stack([u.ravel(), v.ravel()], axis=1)
    return float(np.linalg.norm(fit.pixel_to_table(px) - truth.pixel_to_table(px), axis=1).max())


@pytest.mark.parametrize("table", ["wood", "grey"])
def test_markers_recover_a_tilted_camera(table: str) -> None:
    """4 rendered markers on a tilted view: the field is recovered within 0.03 cm."""
    frame = marker_scene(TILTED, table=table)
    assert field_error_cm(calibration_from_markers(frame, MARKERS), TILTED) < 0.03
    with_corners = calibration_from_markers(frame, MARKERS, side_cm=4.0)
    assert field_error_cm(with_corners, TILTED) < 0.02
    assert 0 < with_corners.reprojection_error_cm < 0.05


def test_diagonal_centre_is_the_projected_centre() -> None:
    """Under a projective map the diagonals meet at the image of the centre (not the mean)."""
    corners = TILTED.table_to_pixel([[-3, 47], [1, 47], [1, 43], [-3, 43]])
    np.testing.assert_allclose(diagonal_center(corners), TILTED.table_to_pixel([-1, 45]))


def test_missing_and_duplicate_markers_are_errors() -> None:
    frame = marker_scene(LAB, {0: (-17.0, 56.0), 1: (16.0, 56.0), 2: (16.0, 32.0)})
    with pytest.raises(CalibrationError, match=r"markers \[3\] not found.*found \[0, 1, 2\]"):
        calibration_from_markers(frame, MARKERS)
    twice = marker_scene(LAB, {0: (-17.0, 56.0), 1: (16.0, 56.0)})
    draw_marker_on_table(twice, LAB, 0, (0.0, 40.0), 4.0)
    with pytest.raises(CalibrationError, match="marker 0 appears twice"):
        detect_markers(twice)


def test_dictionary_and_id_errors() -> None:
    with pytest.raises(CalibrationError, match="unknown ArUco dictionary 'DICT_9X9'"):
        get_dictionary("DICT_9X9")
    with pytest.raises(CalibrationError, match=r"marker id 50 is not in DICT_4X4_50 \(ids 0..49\)"):
        marker_image(50, 100)


CORNER_POINTS = ["0,0:-20.5,59", "640,0:19.5,59", "640,480:19.5,29", "0,480:-20.5,29"]


def point_args(points=CORNER_POINTS) -> list[str]:
    return [a for p in points for a in ("--point", p)]


def outside_calibration(text: str) -> list[str]:
    """The file's lines except the calibration block's homography rows and error line."""
    lines = text.splitlines()
    start = lines.index("calibration:")
    end = next(i for i in range(start + 1, len(lines)) if lines[i] and not lines[i][0].isspace())
    block = [
        ln for ln in lines[start:end] if not re.match(r"\s+(- \[|homography:|reprojection)", ln)
    ]
    return lines[:start] + block + lines[end:]


def test_points_rewrite_only_the_calibration(tmp_path: Path, capsys) -> None:
    """The file keeps every other line and comment; the new block loads and is right."""
    path = tmp_path / "lab.yaml"
    original = FULL_CONFIG.read_text()
    path.write_text(original)
    truth = Calibration(LAB.H @ np.array([[1.0, 0.0, 2.0], [0.0, 1.0, -1.0], [0.0, 0.0, 1.0]]))
    pts = [f"{u},{v}:{float(x)!r},{float(y)!r}" for (u, v), (x, y) in zip(
        [[0, 0], [640, 0], [640, 480], [0, 480], [320, 240]],
        truth.pixel_to_table([[0, 0], [640, 0], [640, 480], [0, 480], [320, 240]]),
        strict=True,
    )]  # fmt: skip
    assert calibrate.main(["--config", str(path), *point_args(pts)]) == 0
    out = capsys.readouterr().out
    assert "fitted from 5 point pairs" in out and "reprojection error: rms" in out
    new = path.read_text()
    assert outside_calibration(new) == outside_calibration(original)
    assert "fitted " in new and "by mearm calibrate-camera from 5 point pairs" in new
    fitted = Calibration.from_config(load_config(path).calibration)
    assert field_error_cm(fitted, truth) < 1e-6
    assert load_config(path).calibration.reprojection_error_cm < 1e-6


def test_markers_rewrite_the_calibration(tmp_path: Path) -> None:
    """From an image with 4 markers to a config that maps the field right."""
    image = tmp_path / "table.png"
    cv2.imwrite(str(image), marker_scene(TILTED))
    path = tmp_path / "lab.yaml"
    path.write_text((ROOT / "configs" / "lab.yaml").read_text())
    args = ["--config", str(path), "--image", str(image), "--marker-side-cm", "4"]
    for marker_id, (x, y) in MARKERS.items():
        args += ["--marker", f"{marker_id}:{x},{y}"]
    assert calibrate.main(args) == 0
    fitted = Calibration.from_config(load_config(path).calibration)
    assert field_error_cm(fitted, TILTED) < 0.02


def test_output_and_dry_run(tmp_path: Path, capsys) -> None:
    """--output leaves --config alone; --dry-run writes nothing, and says so."""
    src = tmp_path / "sim.yaml"
    text = (ROOT / "configs" / "sim.yaml").read_text()
    src.write_text(text)
    out = tmp_path / "new.yaml"
    assert calibrate.main(["--config", str(src), "--output", str(out), *point_args()]) == 0
    assert src.read_text() == text and out.exists()
    capsys.readouterr()
    assert calibrate.main(["--config", str(src), "--dry-run", *point_args()]) == 0
    assert src.read_text() == text
    said = capsys.readouterr().out.splitlines()
    assert said[-1] == f"--dry-run: nothing written ({src} is as it was)", said


def run_tool(capsys, *args: str) -> tuple[int, str]:
    """Run the tool as its __main__ does (mearm.cli.run): exit code and stderr."""
    with pytest.raises(SystemExit) as info:
        calibrate.run(calibrate.main, list(args))
    return int(info.value.code), capsys.readouterr().err


@pytest.mark.heavy
def test_the_script_runs(tmp_path: Path) -> None:
    """End to end as a script: exit 2 and one line for a degenerate set."""
    result = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "calibrate_camera.py"), "--config",
         str(ROOT / "configs" / "lab.yaml"), "--dry-run", *point_args(CORNER_POINTS[:3])],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert result.returncode == 2
    assert result.stderr.strip() == (
        "calibrate_camera.py: error: a homography needs at least 4 point pairs, got 3: add points "
        "spread over the field (e.g. its four corners)"
    )


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (point_args(CORNER_POINTS[:3]), "at least 4 point pairs, got 3"),
        (point_args([*CORNER_POINTS[:3], "320,0:0,59"]), "lie on one line"),
        (["--point", "1,2,3:4,5"], "--point pixel U,V needs 2 numbers within ±65535"),
        (["--point", "1,2"], "--point wants U,V:X,Y"),
        (["--image", "nope.png", "--marker", "0:1,2"], "nope.png: image file not found"),
        (["--marker", "0:1,2"], "--marker needs --image"),
        ([], "give either --image with --marker, or --point"),
    ],
)
def test_failures_exit_2_and_keep_the_file(
    tmp_path: Path, capsys, args: list[str], words: str
) -> None:
    """Bad input: exit 2, one line on stderr naming the problem, the config untouched."""
    path = tmp_path / "lab.yaml"
    text = (ROOT / "configs" / "lab.yaml").read_text()
    path.write_text(text)
    code, err = run_tool(capsys, "--config", str(path), *args)
    assert code == 2
    assert words in err and len(err.strip().splitlines()) == 1
    assert path.read_text() == text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lab.yaml"]  # no temp files left


def test_missing_markers_in_the_image_keep_the_file(tmp_path: Path, capsys) -> None:
    image = tmp_path / "table.png"
    cv2.imwrite(str(image), marker_scene(LAB, {0: (-17.0, 56.0)}))
    path = tmp_path / "lab.yaml"
    path.write_text("# my rig\ncalibration: {reprojection_error_cm: null}\n")
    args = ["--image", str(image)] + [a for i in range(4) for a in ("--marker", f"{i}:{i},40")]
    code, err = run_tool(capsys, "--config", str(path), *args)
    assert code == 2 and "markers [1, 2, 3] not found" in err
    assert path.read_text() == "# my rig\ncalibration: {reprojection_error_cm: null}\n"


def test_a_failed_write_keeps_the_old_file(tmp_path: Path, monkeypatch) -> None:
    """If replacing the file fails, the old one stays and no temporary file is left."""
    path = tmp_path / "lab.yaml"
    text = (ROOT / "configs" / "lab.yaml").read_text()
    path.write_text(text)

    def refuse(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", refuse)
    with pytest.raises(Exception, match="No space left"):
        calibrate.main(["--config", str(path), *point_args()])
    assert path.read_text() == text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lab.yaml"]


def test_a_config_that_would_not_load_is_not_written(tmp_path: Path, capsys) -> None:
    """The result is validated first: a file with a bad key elsewhere is left as it was."""
    path = tmp_path / "bad.yaml"
    path.write_text("camera: {kind: webcam}\n")
    code, err = run_tool(capsys, "--config", str(path), *point_args())
    assert code == 2 and "camera.kind" in err
    assert path.read_text() == "camera: {kind: webcam}\n"


def test_a_file_without_a_calibration_gets_one(tmp_path: Path) -> None:
    path = tmp_path / "small.yaml"
    path.write_text("# only a comment\nvision: {saturation_min: 0.1}  # keep me\n")
    assert calibrate.main(["--config", str(path), *point_args()]) == 0
    text = path.read_text()
    assert text.startswith("# only a comment\nvision: {saturation_min: 0.1}  # keep me\n")
    np.testing.assert_allclose(load_config(path).calibration.homography, LAB.H, atol=1e-9)


@pytest.mark.heavy
def test_marker_sheet_prints_at_size(tmp_path: Path) -> None:
    """The sheet holds detectable markers of the asked size and records its DPI."""
    out = tmp_path / "sheet.png"
    result = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "aruco_sheet.py"), "--output", str(out),
         "--side-cm", "5", "--dpi", "150"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    data = out.read_bytes()
    i = data.index(b"pHYs")
    ppm_x, ppm_y, unit = struct.unpack(">IIB", data[i + 4 : i + 13])
    assert unit == 1 and ppm_x == ppm_y == round(150 / 0.0254)
    page = cv2.imread(str(out))
    assert page.shape[:2] == (round(29.7 / 2.54 * 150), round(21.0 / 2.54 * 150))
    found = detect_markers(page)
    assert sorted(found) == [0, 1, 2, 3]
    side_px = np.linalg.norm(found[0][1] - found[0][0])
    assert side_px == pytest.approx(5.0 / 2.54 * 150, abs=1.5)


def test_marker_sheet_rejects_what_does_not_fit(tmp_path: Path, capsys) -> None:
    sheet = load_tool("aruco_sheet")
    args = ["--output", str(tmp_path / "s.png"), "--side-cm", "12", "--ids", "0,1,2,3,4,5"]
    with pytest.raises(SystemExit) as info:
        sheet.run(sheet.main, args)
    assert info.value.code == 2 and "do not fit on one A4 page" in capsys.readouterr().err
    assert not (tmp_path / "s.png").exists()


@pytest.mark.heavy
def test_a_worse_homography_does_not_replace_a_better_one_without_force(
    tmp_path: Path, capsys
) -> None:
    """The config records a 0.01 cm fit; a noisier one is refused (exit 2), --force takes it."""
    path = tmp_path / "lab.yaml"
    original = FULL_CONFIG.read_text()
    path.write_text(original.replace("reprojection_error_cm: null", "reprojection_error_cm: 0.01"))
    before = path.read_bytes()
    corners = [[0, 0], [640, 0], [640, 480], [0, 480], [320, 240]]
    xy = LAB.pixel_to_table(corners) + [[0.3, 0], [0, 0], [0, 0], [0, 0], [0, 0]]
    pts = [f"{u},{v}:{x!r},{y!r}" for (u, v), (x, y) in zip(corners, xy.tolist(), strict=True)]
    # in this process (test_the_script_runs runs the script; 0.4 s of CPU a process)
    code, err = run_tool(capsys, "--config", str(path), *point_args(pts))
    assert code == 2
    assert len(err.strip().splitlines()) == 1
    assert "holds a better calibration" in err and "--force" in err
    assert path.read_bytes() == before
    assert calibrate.main(["--config", str(path), *point_args(pts), "--force"]) == 0
    assert load_config(path).calibration.reprojection_error_cm > 0.01
