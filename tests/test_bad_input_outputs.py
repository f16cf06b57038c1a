"""Bad-input corpus: outputs checked before the work, and no good file replaced by a refused run.

A command that will write a file refuses a path it could not write (a folder, a path
under a regular file) before it measures or sorts: within the case's short time bound,
not after minutes of measurement with a traceback. A run that is refused leaves every
file it was pointed at byte for byte as it was.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import check_bad_input, check_bad_input_subprocess, run_in_process

bad_input = pytest.mark.bad_input


@pytest.fixture
def spots(tmp_path: Path) -> dict[str, Path]:
    """A folder, a regular file, and a path under that file."""
    (tmp_path / "folder").mkdir()
    (tmp_path / "file.txt").write_text("keep me\n")
    return {
        "folder": tmp_path / "folder",
        "file": tmp_path / "file.txt",
        "under": tmp_path / "file.txt" / "out.json",
    }


#: (command line with {folder}, {file} or {under}, words). Each was refused only after its
#: whole measurement (a traceback, exit 1), or not at all, before.
CASES: list[tuple[list[str], str]] = [
    (["virtual-uno-pulses", "--json", "{folder}"],
     "--json {folder}: exists and is not a regular file (a folder)"),
    (["virtual-uno-pulses", "--json", "{under}"], "--json {under}: cannot write: {file} is a "
                                                  "file, not a folder"),
    (["camera-accuracy", "--config", "sim_mujoco", "--json", "{under}"],
     "--json {under}: cannot write: {file} is a file, not a folder"),
    (["camera-accuracy", "--config", "sim_mujoco", "--json", "{folder}"],
     "not a regular file (a folder)"),
    (["camera-accuracy", "--config", "sim_mujoco", "--work", "{file}"],
     "--work {file}: exists and is not a folder"),
    (["camera-accuracy", "--config", "sim_mujoco", "--work", "{under}"], "is a file, not a folder"),
    (["camera-accuracy", "--config", "sim_mujoco", "--max-mean-cm", "nan"], "--max-mean-cm"),
    (["sort", "--quiet", "--save-mjcf", "{folder}"],
     "--save-mjcf {folder}: exists and is not a regular file (a folder)"),
    (["sort", "--quiet", "--save-mjcf", "{under}"], "{file} is a file, not a folder"),
    (["check-camera", "--config", "sim_mujoco_perspective", "--refine", "{under}"],
     "--refine {under}: cannot write: {file} is a file, not a folder"),
    (["check-camera", "--config", "sim_mujoco_perspective", "--refine", "{folder}"],
     "not a regular file (a folder)"),
    (["calibrate-intrinsics", "--images", "{folder}", "--out", "{under}"],
     "--out {under}: cannot write: {file} is a file, not a folder"),
    (["calibrate-camera", "--config", "sim", "--point", "0,0:-20.5,59", "--output", "{under}"],
     "--output {under}: cannot write: {file} is a file, not a folder"),
    (["detect", "--camera", "--annotate", "{under}.png"],
     "--annotate {under}.png: cannot write: {file} is a file, not a folder"),
    (["flash", "--port", "/dev/null", "--build-dir", "{file}"],
     "--build-dir {file}: exists and is not a folder"),
    (["config-docs", "--output", "{under}"],
     "--output {under}: cannot write: {file} is a file, not a folder"),
    # (the run log said "exists (exclusive=True refuses to append)" of a file not there)
    (["sort", "--quiet", "--log", "{under}"], "{under}: cannot write: {file} is a file, not a"),
    (["experiment", "--trials", "1", "--log", "{under}"],
     "{under}: cannot write: {file} is a file, not a folder"),
    # (it said "[Errno 2] No such file or directory: '/proc/x'")
    (["experiment", "--trials", "1", "--log", "/proc/x/y.jsonl"],
     "/proc/x/y.jsonl: cannot open for writing (No such file or directory)"),
]  # fmt: skip


@bad_input
@pytest.mark.parametrize(("argv", "words"), CASES, ids=[" ".join(a)[:60] for a, _ in CASES])
def test_an_output_that_cannot_be_written_is_refused_first(
    argv: list[str], words: str, spots: dict[str, Path], tmp_path: Path
) -> None:
    """Exit 2 and one line naming the flag and the path, before any measurement."""
    names = {k: str(v) for k, v in spots.items()}
    out = check_bad_input([a.format(**names) for a in argv], within_s=3, keep=[tmp_path])
    assert words.format(**names) in out.line


@bad_input
@pytest.mark.parametrize(
    ("more", "words"),
    [
        (["--set", "task.classes.red.bin_cm=[0, 80, 20]"], "task.classes.red.bin_cm"),
        (["--set", "task.scene=[{color: red, x: 0, y: -20}]"], "task.scene[0]"),
        (["--log", "{folder}"], "not a regular file"),
    ],
)
def test_sort_keeps_an_old_mjcf_when_it_refuses_the_run(
    more: list[str], words: str, spots: dict[str, Path], tmp_path: Path
) -> None:
    """--save-mjcf old.xml was written before the config's check, then the run refused."""
    old = tmp_path / "old.xml"
    old.write_text("<mujoco/>\n")
    more = [m.replace("{folder}", str(spots["folder"])) for m in more]
    out = check_bad_input(["sort", "--quiet", "--save-mjcf", old, *more], keep=[tmp_path])
    assert words in out.line
    assert old.read_text() == "<mujoco/>\n"


@bad_input
def test_check_camera_says_why_it_did_not_run_on_stderr(tmp_path: Path) -> None:
    """No object to check with: exit 1, the reason as one line on stderr; --refine's file
    not written. (One that is there and no pose is refused first, exit 2: before the arm
    moves, ``tests/test_check_camera_refine.py``.)"""
    pose = tmp_path / "pose.yaml"
    argv = ["check-camera", "--config", "sim_mujoco_perspective", "--set", "task.scene=[]",
            "--refine", pose]  # fmt: skip
    out = check_bad_input(argv, code=1, within_s=10, keep=[tmp_path])
    assert out.line == (
        "mearm check-camera: check not run: no object seen on the table: put one in the "
        "camera's view"
    )
    assert not pose.exists()


def test_sort_writes_the_mjcf_of_an_accepted_run(tmp_path: Path) -> None:
    """Accepted, the run replaces the old file with the scene's MJCF."""
    old = tmp_path / "old.xml"
    old.write_text("<mujoco/>\n")
    scene = tmp_path / "scene.yaml"
    scene.write_text("- {color: red, x: -10.99, y: 49.70}\n")
    out = run_in_process(["sort", "--quiet", "--scene", scene, "--save-mjcf", old], within_s=30)
    assert out.code == 0, out.stderr
    assert old.read_text().startswith("<mujoco") and 'name="obj_red1"' in old.read_text()


def test_an_output_in_a_folder_not_made_yet_is_written(tmp_path: Path) -> None:
    """``--annotate shots/a.png`` with no ``shots/``: the folder is made, as ``sort --log`` does.

    ``check_output_file`` accepts such a path; the writer used to fail on it after the work
    (``calibrate-camera --out calib/pose.yaml`` after the fit, an "unexpected error").
    """
    out = run_in_process(
        ["detect", "--camera", "--annotate", tmp_path / "shots" / "new" / "a.png"], within_s=30
    )
    assert out.code == 0, out.stderr
    assert (tmp_path / "shots" / "new" / "a.png").read_bytes().startswith(b"\x89PNG")


@bad_input
@pytest.mark.parametrize(
    "argv",
    [
        ["check-camera", "--config", "sim_mujoco_perspective", "--refine", "/proc/mearm/r.yaml"],
        ["detect", "--camera", "--annotate", "/proc/mearm/a.png"],
    ],
    ids=["check-camera", "detect"],
)
def test_a_folder_that_refuses_a_new_file_is_refused_before_the_work(argv: list[str]) -> None:
    """``/proc`` passes the permission check for root (CI runs as root) but takes no file:
    found by a file made there and removed, before the arm's check (whose refined pose
    was lost to the failed write after it)."""
    out = check_bad_input(argv)
    assert "cannot write: the folder /proc is not writable" in out.line, out.line


#: A file name whose bytes are not UTF-8 (Linux allows any): Python holds it as surrogates.
NOT_UTF8 = "o\udcff"


@pytest.mark.parametrize(
    "argv",
    [
        ["urdf", "--config", "sim", "--output", "{dir}/" + NOT_UTF8 + ".urdf"],
        ["aruco-sheet", "--output", "{dir}/" + NOT_UTF8 + ".png"],
        ["config-docs", "--output", "{dir}/" + NOT_UTF8 + ".md"],
    ],
    ids=["urdf", "aruco-sheet", "config-docs"],
)
def test_an_output_whose_name_is_not_utf8_is_written(argv: list[str], tmp_path: Path) -> None:
    """The atomic write's temporary name cut the target's name as UTF-8 text: a name of
    other bytes was an unexpected error (a traceback, exit 1) instead of a file."""
    out = run_in_process([a.format(dir=tmp_path) for a in argv])
    assert out.code == 0, out.stderr
    assert os.listdir(tmp_path) == [argv[-1].removeprefix("{dir}/")]


@bad_input
@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["detect", "--annotate", "{dir}/o." + NOT_UTF8, "{image}"], "unknown image type"),
        (["find-camera", "--camera", "{dir}/" + NOT_UTF8 + ".mp4", "--out", "{dir}/snaps"],
         "the name is not UTF-8 text"),
    ],
    ids=["detect", "find-camera"],
)  # fmt: skip
def test_a_name_opencv_cannot_take_is_refused(argv: list[str], words: str, tmp_path: Path) -> None:
    """OpenCV's path-taking calls crashed the process on such a name (SIGSEGV, exit 139):
    a process of its own, so the old crash does not take the test runner with it."""
    image = tmp_path / "table.png"
    cv2.imwrite(str(image), np.zeros((48, 64, 3), np.uint8))
    (tmp_path / (NOT_UTF8 + ".mp4")).write_bytes(b"\x00" * 64)
    filled = [a.format(dir=tmp_path, image=image) for a in argv]
    out = check_bad_input_subprocess(filled, keep=[tmp_path])
    assert words in out.line


def test_a_report_that_names_a_log_not_utf8_is_written(tmp_path: Path) -> None:
    """The report quotes the log's name: its bytes that are not UTF-8 could not be
    written (UnicodeEncodeError, exit 1, an empty --out left behind); they are escaped."""
    log = tmp_path / (NOT_UTF8 + ".jsonl")
    assert run_in_process(["sort", "--quiet", "--log", tmp_path / "run.jsonl"]).code == 0
    (tmp_path / "run.jsonl").rename(log)
    out = run_in_process(["analyze", log, "--out", tmp_path / ("an" + NOT_UTF8)], within_s=20)
    assert out.code == 0, out.stderr
    report = (tmp_path / ("an" + NOT_UTF8) / "report.md").read_text(encoding="utf-8")
    assert "# Analysis of `o\\udcff.jsonl`" in report


def test_a_run_log_whose_name_is_not_utf8_is_written_and_read(tmp_path: Path) -> None:
    """The header records the command line, the log's name in it: its bytes that are not
    UTF-8 made the line invalid JSON (exit 2, "lone leading surrogate", an empty log left
    behind); the name is recorded escaped, and the log reads back."""
    log = tmp_path / ("L" + NOT_UTF8) / "x.jsonl"
    out = run_in_process(["sort", "--quiet", "--log", log])
    assert out.code == 0, out.stderr
    lines = log.read_text(encoding="utf-8").splitlines()
    header = json.loads(lines[0])
    assert header["argv"][-1] == str(tmp_path / "Lo\\udcff" / "x.jsonl")
    assert all(json.loads(line) for line in lines)
    read = run_in_process(["analyze", log, "--out", tmp_path / "an"], within_s=20)
    assert read.code == 0, read.stderr


@pytest.mark.parametrize("source", [["--arm", "paper"], ["--of", "sim"]], ids=["arm", "twin"])
def test_a_config_whose_name_is_not_utf8_is_written(source: list[str], tmp_path: Path) -> None:
    """The starter config's comments name it ("mearm sort --config NAME"): its bytes
    that are not UTF-8 were refused as the YAML's ("malformed YAML … U+DCFF", exit 2);
    they are written escaped, and the config loads."""
    from mearm.config import load_config

    path = tmp_path / (NOT_UTF8 + ".yaml")
    out = run_in_process(["init-config", path, *source, "--rig", "sim"], within_s=10)
    assert out.code == 0, out.stderr
    assert "--config 'o\\udcff.yaml'" in path.read_text(encoding="utf-8").replace(
        str(tmp_path) + "/", ""
    )
    load_config(path)
