"""What a new user met running the docs' commands literally, pinned.

A ``--set`` file path is relative to the folder the command runs in (the docs' recipes
write a file there, then name it); the pages' quoted messages and API are the code's; a
camera that is not there is bad input (exit 2, one line on stderr) for check-camera as
for sort, and a sort on uncalibrated servos says nothing else when it cannot start.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest
from conftest import mearm_cli, mearm_here

from mearm.config import load_config
from mearm.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"
DOCS = ROOT / "docs"
#: A camera index no machine here has, and a short wait for it.
NO_CAMERA = ["--set", "camera.device_index=99", "--set", "camera.open_timeout_s=0.5"]


def one_line(proc: subprocess.CompletedProcess[str], code: int = 2) -> str:
    """The one line on stderr of a run that exited ``code``."""
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == code and len(lines) == 1, (proc.returncode, proc.stderr)
    return lines[0]


# ------------------------------------------------------------------ a --set path's folder


@pytest.mark.heavy
def test_a_file_written_here_is_named_by_set_from_here(tmp_path):
    """docs/servos.md: calibrate-servos --output F, then --set servo.calibration_file=F,
    the config in another folder: F is the file just written, not one beside the config."""
    config = CONFIGS / "sim_mujoco.yaml"
    made = mearm_here("calibrate-servos", "--simulate", "--config", config,
                 "--output", "cam.servos.yaml", cwd=tmp_path)  # fmt: skip
    assert made.returncode == 0 and (tmp_path / "cam.servos.yaml").is_file(), made.stderr
    used = mearm_here("fk", "--config", config, "--set", "servo.calibration_file=cam.servos.yaml",
                 "--joints", "90,90,-90", cwd=tmp_path)  # fmt: skip
    assert used.returncode == 0, used.stderr


def test_camera_files_named_by_set_are_found_from_here(tmp_path):
    """The camera's calibration files given by --set: relative to the current folder."""
    for name in ("twin_intrinsics.yaml", "twin_pose.yaml"):
        shutil.copy(CONFIGS / "calibration" / name, tmp_path / name)
    proc = mearm_here("fk", "--config", CONFIGS / "sim_mujoco_perspective.yaml",
                 "--set", "calibration.intrinsics_file=twin_intrinsics.yaml",
                 "--set", "calibration.extrinsics_file=twin_pose.yaml",
                 "--joints", "90,90,-90", cwd=tmp_path)  # fmt: skip
    assert proc.returncode == 0, proc.stderr


def test_a_missing_set_file_names_where_it_looked_and_the_rule(tmp_path):
    proc = mearm_here("fk", "--config", CONFIGS / "sim.yaml", "--joints", "90,90,-90",
                 "--set", "servo.calibration_file=gone.yaml", cwd=tmp_path)  # fmt: skip
    line = one_line(proc)
    assert line.startswith(
        f"mearm fk: error: --set: servo.calibration_file: '{tmp_path / 'gone.yaml'}' is not a file"
    )
    assert "one given by --set to the current folder" in line


def test_a_config_files_path_stays_relative_to_its_folder(tmp_path, monkeypatch):
    """In a config file, a relative path is the file's folder's, wherever the command runs."""
    folder = tmp_path / "rig"
    folder.mkdir()
    for name in ("twin_intrinsics.yaml", "twin_pose.yaml"):
        shutil.copy(CONFIGS / "calibration" / name, folder / name)
    (folder / "mine.yaml").write_text(
        "extends: sim_mujoco_perspective\ncalibration:\n  model: perspective\n"
        "  intrinsics_file: twin_intrinsics.yaml\n  extrinsics_file: twin_pose.yaml\n"
    )
    monkeypatch.chdir(tmp_path)
    config = load_config(folder / "mine.yaml")
    assert config.calibration.intrinsics_file == str(folder / "twin_intrinsics.yaml")


def test_a_set_file_without_a_config_is_checked(tmp_path, monkeypatch):
    """No --config: a --set servo calibration file was ignored unseen; now found (or not)."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match=r"servo\.calibration_file: .*gone\.yaml' is not a file"):
        load_config(None, ["servo.calibration_file=gone.yaml"])


# ------------------------------------------------------------------ the pages' own words


def test_your_arm_names_the_kinematics_api_that_exists():
    """docs/your-arm.md's ArmModel paragraph: every name it gives is there."""
    import mearm.kinematics as kinematics
    import mearm.kinematics.errors as errors

    text = (DOCS / "your-arm.md").read_text(encoding="utf-8")
    start = text.index("`mearm.kinematics.ArmModel")
    paragraph = text[start : text.index("\n\n", start)]
    assert "`mearm.kinematics.errors`" in paragraph  # the errors are not in mearm.kinematics
    names = {m.group(1) for m in re.finditer(r"`([A-Za-z_]\w*)(?:\(|`)", paragraph)}
    names -= {"planar_wrist", "None"}  # a closed form's name in a config; a value
    homes = (kinematics, kinematics.ArmModel, kinematics.PlanarWrist, errors)
    missing = sorted(n for n in names if not any(hasattr(home, n) for home in homes))
    assert {"dh_fk", "check_target", "closed_form_for", "TargetOutsideBoxError"} <= names
    assert missing == []
    for name in ("dh_fk", "dh_jacobian", "check_target", "closed_form_for"):
        assert callable(getattr(kinematics, name)) and not hasattr(kinematics.ArmModel, name)


@pytest.mark.heavy
def test_troubleshootings_approach_height_message_is_the_sorts():
    proc = mearm_here("sort", "--set", "task.approach_height_cm=50", cwd=ROOT)  # refused at load
    line = one_line(proc)
    assert f"```\n{line}\n```" in (DOCS / "troubleshooting.md").read_text(encoding="utf-8")


@pytest.mark.heavy
def test_troubleshootings_skipped_object_is_the_sorts():
    """The page's MeArm v1 object too close to the base: its skip line is the sort's own
    (the quoted one had gone stale: the solve now refuses it on the levelled wrist)."""
    text = (DOCS / "troubleshooting.md").read_text(encoding="utf-8")
    scene = re.search(r'--set\s+"(task\.scene=\[\{color: red, x: 0, y: 13\}\])"', text)
    assert scene is not None
    proc = mearm_here("sort", "--config", "sim_mearm_v1", "--set", scene.group(1), cwd=ROOT)
    assert proc.returncode == 1, proc.stderr
    skip = next(line for line in proc.stdout.splitlines() if line.startswith("skip "))
    assert f"```\n{skip}\n```" in text


@pytest.mark.heavy
def test_the_concept_table_names_files_from_the_right_root():
    """docs/development.md's table: paths from mearm/, or from the repo written in full
    (``tools/x.py`` alone would be the repo's own tools/, which has another set)."""
    text = (DOCS / "development.md").read_text(encoding="utf-8")
    table = text[text.index("### Where each concept lives") :].split("\n\n")[1]
    paths = [p for p in re.findall(r"`([\w./*-]+\.py)`", table) if "/" in p]
    assert paths
    for path in paths:
        where = ROOT / path if path.startswith(("mearm/", "tools/")) else ROOT / "mearm" / path
        assert where.is_file(), path


# ------------------------------------------------------------------ no camera there


@pytest.mark.heavy
def test_check_camera_without_its_camera_is_bad_input():
    """As sort and detect: exit 2, one line naming the camera (was: exit 1, "check stopped")."""
    # a process of its own: its stderr holds OpenCV's own lines too, were any said
    line = one_line(mearm_cli("check-camera", "--config", "lab", *NO_CAMERA, cwd=ROOT))
    assert line.startswith("mearm check-camera: error: camera (device 99): cannot open")


@pytest.mark.heavy
def test_a_sort_on_uncalibrated_servos_without_its_camera_says_one_line(tmp_path):
    """A real rig never calibrated: the note is for a sort that starts; without the camera
    only the error is said (exit 2), and the log still says why it never started."""
    log = tmp_path / "run.jsonl"
    proc = mearm_here("sort", "--config", "lab", *NO_CAMERA, "--log", log, cwd=ROOT)
    line = one_line(proc)
    assert line.startswith("mearm sort: error: camera (device 99): cannot open"), line
    assert "before the sort started: camera (device 99)" in log.read_text(encoding="utf-8")
