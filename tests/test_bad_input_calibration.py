"""Bad-input corpus: ``calibrate-camera`` — the config it rewrites, its points and markers.

The config file is read as every config is (mearm.yamlio) before anything is fitted, so
a non-UTF-8 or tagged file is one line, not a traceback (issue 12). Points and markers
that cannot anchor a homography, a fit whose horizon crosses the frame or whose frame
lands off the table, and outputs that are not files are refused. In every case the
config is left byte for byte as it was and no temporary file is left beside it.
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import ROOT, check_bad_input, run_in_process

bad_input = pytest.mark.bad_input

LAB = ROOT / "configs" / "lab.yaml"
CORNERS = ["0,0:-20.5,59", "640,0:19.5,59", "640,480:19.5,29", "0,480:-20.5,29"]


def points(*pairs: str) -> list[str]:
    return [a for p in pairs for a in ("--point", p)]


@pytest.fixture(scope="module", autouse=True)
def _imported() -> None:
    run_in_process(["calibrate-camera", "--help"], within_s=60)


@pytest.fixture
def lab(tmp_path: Path) -> Path:
    """A copy of configs/lab.yaml to (not) rewrite, alone in its folder."""
    path = tmp_path / "lab.yaml"
    path.write_bytes(LAB.read_bytes())
    return path


def check(argv: list[object], folder: Path, words: str) -> None:
    out = check_bad_input(["calibrate-camera", *argv], within_s=3, keep=[folder])
    assert words in out.line
    assert not [p for p in folder.iterdir() if p.name.endswith(".tmp")]


#: name → (config file contents, words).
BAD_CONFIGS: dict[str, tuple[bytes, str]] = {
    "latin1": ("camera:\n  path: /tmp/caf\xe9.png\n".encode("latin-1"), "not UTF-8 text"),
    "utf16": ("camera: {}\n".encode("utf-16"), "not UTF-8 text"),
    "python_tag": (b"camera: !!python/object/apply:os.system [true]\n", "is not allowed"),
    "local_tag": (b"calibration: !cal {reprojection_error_cm: 1}\n", "tag !cal is not allowed"),
    "binary_tag": (b"camera: {path: !!binary aGk=}\n", "tag !!binary is not allowed"),
    "duplicate": (b"calibration: {}\ncalibration: {}\n", "duplicate key 'calibration'"),
    "alias_bomb": (
        b'a: &a ["x","x","x","x","x","x","x","x","x","x"]\n'
        + b"".join(
            f"a{i}: &a{i} [{', '.join(['*a' if i == 0 else f'*a{i - 1}'] * 10)}]\n".encode()
            for i in range(6)
        ),
        b"aliases counted expanded".decode(),
    ),  # fmt: skip
    "deep": (b"a: " + b"[" * 10_000 + b"]" * 10_000, "nested deeper than"),
    "empty": (b"", "empty config"),
    "comments": (b"# to be filled in\n", "empty config"),
    "top_list": (b"- calibration\n", "top level must be a mapping"),
    "malformed": (b"calibration: {homography: [[1, 0, 0]\n", "malformed YAML"),
    "nul": (b"calibration: {}\n\x00", "control characters are not allowed"),
    "bad_elsewhere": (b"camera: {kind: webcam}\n", "camera.kind"),
    "too_large": (b"# x\n" * 300_000, "too large"),
}


@bad_input
@pytest.mark.parametrize("name", list(BAD_CONFIGS))
def test_a_config_that_cannot_be_read_is_left_alone(name: str, tmp_path: Path) -> None:
    """The issue's non-UTF-8 and tagged files, and their kin: one line, file untouched."""
    content, words = BAD_CONFIGS[name]
    path = tmp_path / "rig.yaml"
    path.write_bytes(content)
    check(["--config", path, *points(*CORNERS)], tmp_path, words)
    assert path.read_bytes() == content


@bad_input
@pytest.mark.parametrize(
    ("target", "words"),
    [("folder", "is a directory"), ("fifo", "not a regular file"), ("missing", "not found"),
     ("/dev/zero", "not a regular file"), ("/dev/null", "not a regular file")],
)  # fmt: skip
def test_a_config_that_is_not_a_file_is_refused(target: str, words: str, tmp_path: Path):
    (tmp_path / "folder").mkdir()
    os.mkfifo(tmp_path / "fifo")
    path = target if target.startswith("/") else tmp_path / target
    check(["--config", path, *points(*CORNERS)], tmp_path, words)


@bad_input
@pytest.mark.parametrize("output", [False, True])
def test_a_config_whose_extends_names_no_file_is_named_itself(output: bool, tmp_path: Path) -> None:
    """``extends:`` naming no file: the config itself is named, and the path it was looked
    for from its own folder, with or without --output elsewhere (which was named until
    2026-12-06, with its own folder's path, after the fit)."""
    path = tmp_path / "rig.yaml"
    path.write_text("extends: ../nowhere/base.yaml\n")
    more = ["--output", tmp_path / "sub" / "out.yaml"] if output else []
    out = check_bad_input(
        ["calibrate-camera", "--config", path, *more, *points(*CORNERS)],
        within_s=3, keep=[tmp_path],
    )  # fmt: skip
    assert out.line.startswith(f"mearm calibrate-camera: error: {path}: extends: ")
    assert f"looked for {tmp_path / '../nowhere/base.yaml'}" in out.line
    assert out.stdout == ""  # refused before any fitting
    assert not (tmp_path / "sub").exists()


@bad_input
@pytest.mark.parametrize(
    ("output", "words"),
    [("{dir}/folder", "not a regular file"), ("{dir}/fifo", "not a regular file"),
     ("/dev/null", "not a regular file"), ("/dev/full", "not a regular file"),
     ("{dir}/lab.yaml/inside.yaml", "cannot write"),
     ("/proc/mearm-no-such-folder/x.yaml", "cannot write")],
)  # fmt: skip
def test_an_output_that_is_not_a_file_is_refused(output: str, words: str, lab: Path) -> None:
    """--output a folder, FIFO, device or impossible path: nothing written anywhere."""
    (lab.parent / "folder").mkdir()
    os.mkfifo(lab.parent / "fifo")
    target = output.format(dir=lab.parent)
    check(["--config", lab, "--output", target, *points(*CORNERS)], lab.parent, words)


#: (arguments after --config, words).
BAD_ARGS: list[tuple[list[str], str]] = [
    ([], "give either --image with --marker, or --point"),
    (points(*CORNERS) + ["--image", "x.png", "--marker", "0:1,2"], "not both"),
    (["--marker", "0:1,2"], "--marker needs --image"),
    (["--image", "x.png"], "--image needs --marker"),
    (points("0,0-20,59"), "--point wants U,V:X,Y"),
    (points("0,0:1:2,3"), "--point wants U,V:X,Y"),
    (points("0,0,0:1,2"), "--point pixel U,V needs 2 numbers"),
    (points("0,0:1"), "--point table X,Y needs 2 numbers"),
    (points("a,b:1,2"), "--point pixel U,V must be numbers"),
    (points("nan,0:1,2"), "needs 2 numbers within"),
    (points("0,inf:1,2"), "needs 2 numbers within"),
    (points("0,0:1e999,2"), "needs 2 numbers within"),
    (points("1e6,0:1,2"), "needs 2 numbers within ±65535"),
    (points("0,0:5000,2"), "needs 2 numbers within ±1000"),
    (points(*CORNERS[:3]), "a homography needs at least 4 point pairs, got 3"),
    (points(*CORNERS[:3], CORNERS[0]), "are the same point"),
    (points("0,0:0,40", "100,0:10,40", "200,0:20,40", "300,0:30,40"), "lie on one line"),
    (points("0,0:-20,59", "640,0:20,59", "320,1:0,58.9", "0,480:-20,29"), "lie on one line"),
    (points("0,0:-20.5,59", "640,0:19.5,59", "640,480:-20.5,29", "0,480:19.5,29"),
     "horizon"),
    (points("0,0:-1000,1000", "1,0:1000,1000", "1,1:1000,-1000", "0,1:-1000,-1000"),
     "beyond ±1000 cm"),
    (points("0,0:-20.5,59", "6,0:19.5,59", "6,4:19.5,29", "0,4:-20.5,29"),
     "beyond ±1000 cm"),
    (["--image", "x.png", "--marker", "0-1,2"], "--marker wants ID:X,Y"),
    (["--image", "x.png", "--marker", "a:1,2"], "--marker id must be an integer"),
    (["--image", "x.png", "--marker", "-1:1,2"], "--marker id must be an integer"),
    (["--image", "x.png", "--marker", "9999999999:1,2"], "--marker id must be an integer"),
    (["--image", "x.png", "--marker", "٣:1,2"], "--marker id must be an integer"),
    (["--image", "x.png", "--marker", "0:1,nan"], "needs 2 numbers within"),
    (["--image", "x.png", "--marker", "0:1,2", "--marker", "0:3,4"],
     "each --marker id may be given once"),
    (["--image", "x.png", "--marker", "0:1,2", "--marker-side-cm", "0"], "--marker-side-cm"),
    (["--image", "x.png", "--marker", "0:1,2", "--marker-side-cm", "-4"], "--marker-side-cm"),
    (["--image", "x.png", "--marker", "0:1,2", "--marker-side-cm", "nan"], "--marker-side-cm"),
    (["--image", "x.png", "--marker", "0:1,2", "--marker-side-cm", "inf"], "--marker-side-cm"),
    (["--image", "x.png", "--marker", "0:1,2", "--marker-side-cm", "1e9"], "--marker-side-cm"),
    (["--image", "x.png", "--marker", "0:1,2", "--marker-side-cm", "four"], "plain decimal number"),
    (["--image", "{image}", "--marker", "0:1,2", "--dictionary", "DICT_NOPE"],
     "unknown ArUco dictionary 'DICT_NOPE'"),
    (["--image", "{image}", "--marker", "0:-17,56", "--marker", "1:16,56", "--marker", "2:16,32",
      "--marker", "3:-17,32"], "markers [0, 1, 2, 3] not found in the image"),
    (["--image", "{image}", "--marker", "70000:1,2"], "not found in the image"),
    (["--dry-run", "--bogus"] + points(*CORNERS), "unrecognized arguments: --bogus"),
]  # fmt: skip


@bad_input
@pytest.mark.parametrize(
    ("args", "words"), [pytest.param(a, w, id=" ".join(a)[:70] or "(none)") for a, w in BAD_ARGS]
)
def test_bad_points_and_markers_are_refused(args: list[str], words: str, lab: Path) -> None:
    """Each bad fit request: exit 2, one line, the config byte for byte as it was."""
    image = lab.parent / "table.png"
    cv2.imwrite(str(image), np.full((480, 640, 3), 200, np.uint8))  # a table, no markers
    check(["--config", lab, *(a.format(image=image) for a in args)], lab.parent, words)


@bad_input
def test_dry_run_checks_the_fit_too(lab: Path) -> None:
    """--dry-run writes nothing, but refuses a fit the config could not hold."""
    bad = points("0,0:-20.5,59", "640,0:19.5,59", "640,480:-20.5,29", "0,480:19.5,29")
    out = check_bad_input(
        ["calibrate-camera", "--config", lab, "--dry-run", *bad], within_s=3, keep=[lab.parent]
    )
    assert "horizon" in out.line and out.stdout == ""


CALIBRATION = ROOT / "configs" / "calibration"

#: name → (file, line replaced, the new line, words). ``int(.inf)`` raised OverflowError
#: (exit 1 with a traceback in the crash log) before each was named.
BAD_CALIBRATION_NUMBERS: dict[str, tuple[str, str, str, str]] = {
    "views .inf": ("twin_intrinsics.yaml", "views:", "views: .inf",
                   "views must be a whole number in 0 … 1000000, got inf"),
    "views 1.5": ("twin_intrinsics.yaml", "views:", "views: 1.5",
                  "views must be a whole number in 0 … 1000000, got 1.5"),
    "views -1": ("twin_intrinsics.yaml", "views:", "views: -1",
                 "views must be a whole number in 0 … 1000000, got -1"),
    "rms .nan": ("twin_intrinsics.yaml", "rms_px:", "rms_px: .nan",
                 "rms_px must be in 0 … 1000 px, got nan"),
    "resolution .inf": ("twin_intrinsics.yaml", "resolution:", "resolution: [.inf, 480]",
                        "resolution must be a whole number in 1 … 65535, got inf"),
    "markers .inf": ("twin_pose.yaml", "markers:", "markers: .inf",
                     "markers must be a whole number in 0 … 1000000, got inf"),
    "resolution true": ("twin_pose.yaml", "resolution:", "resolution: [true, 480]",
                        "resolution must be a whole number"),
}  # fmt: skip


def bad_calibration(name: str, folder: Path) -> Path:
    file, start, line, _ = BAD_CALIBRATION_NUMBERS[name]
    text = (CALIBRATION / file).read_text()
    lines = [line if x.startswith(start) else x for x in text.splitlines()]
    assert lines != text.splitlines()
    path = folder / file
    path.write_text("\n".join(lines) + "\n")
    return path


@bad_input
@pytest.mark.parametrize("name", BAD_CALIBRATION_NUMBERS)
def test_detect_names_a_number_out_of_range_in_a_calibration_file(
    name: str, tmp_path: Path
) -> None:
    """A calibration file's every number is finite and in range, or named (exit 2)."""
    path = bad_calibration(name, tmp_path)
    key = "intrinsics_file" if "intrinsics" in path.name else "extrinsics_file"
    argv = ["detect", "--config", "sim_mujoco_perspective", "--set", f"calibration.{key}={path}",
            "--camera"]  # fmt: skip
    out = check_bad_input(argv, within_s=5, keep=[tmp_path])
    assert f"{path}: {BAD_CALIBRATION_NUMBERS[name][3]}" in out.line


@bad_input
@pytest.mark.parametrize("name", [n for n, v in BAD_CALIBRATION_NUMBERS.items() if "intr" in v[0]])
def test_calibrate_camera_names_a_number_out_of_range_in_the_intrinsics(
    name: str, tmp_path: Path
) -> None:
    path = bad_calibration(name, tmp_path)
    argv = ["--config", "sim_mujoco_perspective", "--intrinsics", path, "--out",
            tmp_path / "pose.yaml", "--image", tmp_path / "none.png", "--marker", "0:1,2",
            "--marker-side-cm", "4"]  # fmt: skip
    check(argv, tmp_path, f"{path}: {BAD_CALIBRATION_NUMBERS[name][3]}")
    assert not (tmp_path / "pose.yaml").exists()
