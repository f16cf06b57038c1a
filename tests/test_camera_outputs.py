"""Camera calibration commands: the overhead camera's pose, and outputs that are inputs.

Most commands run in the test's own process (:func:`mearm_here`); one refusal each of
``calibrate-camera`` and ``camera-accuracy`` runs as a command of its own, as a shell
sees it.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import mearm_cli, mearm_here

from mearm.vision.pinhole import load_calibration

#: Each test runs a command or two (renders, fits): heavy.
pytestmark = pytest.mark.heavy

ROOT = Path(__file__).resolve().parents[1]


def refused(proc: subprocess.CompletedProcess[str], text: str) -> None:
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and text in lines[0], proc.stderr


@pytest.fixture(scope="module")
def overhead(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The twin's straight-down camera's sheet, markers and truth (sim_mujoco)."""
    out = tmp_path_factory.mktemp("overhead") / "rc"
    proc = mearm_here("render-calibration", "--config", "sim_mujoco", "--out", out, "--views", "1",
                      "--truth", cwd=out.parent)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return out


def markers(folder: Path) -> list[str]:
    return (folder / "sheet_markers.txt").read_text().split()


def test_a_camera_looking_straight_down_gets_its_pose(overhead: Path, tmp_path: Path) -> None:
    """OpenCV's IPPE garbles a half-turn; the pose was refused as 'below the table' (#8)."""
    proc = mearm_here("calibrate-camera", "--intrinsics", overhead / "truth_intrinsics.yaml",
                      "--out", "pose.yaml", "--image", overhead / "sheet.png", *markers(overhead),
                      cwd=tmp_path)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    pose = load_calibration(tmp_path / "pose.yaml", "extrinsics")
    truth = load_calibration(overhead / "truth_pose.yaml", "extrinsics")
    assert np.linalg.norm(pose.position_cm - truth.position_cm) < 0.2
    assert np.abs(pose.rotation - truth.rotation).max() < 0.005
    assert pose.rms_px < 0.5


def test_calibrate_camera_refuses_to_write_over_its_inputs(overhead: Path, tmp_path: Path) -> None:
    image = tmp_path / "photo.png"
    shutil.copy(overhead / "sheet.png", image)
    config = tmp_path / "h.yaml"
    assert mearm_here("init-config", config, "--arm", "paper", "--rig", "sim_mujoco",
                      cwd=tmp_path).returncode == 0  # fmt: skip
    before = image.read_bytes()
    args = ["--image", image, *markers(overhead)]
    proc = mearm_cli("calibrate-camera", "--config", config, *args, "--output", "./photo.png",
                 "--force", cwd=tmp_path)  # fmt: skip
    refused(proc, "is the --image file")
    intrinsics = overhead / "truth_intrinsics.yaml"
    kept = intrinsics.read_bytes()
    proc = mearm_here("calibrate-camera", "--intrinsics", intrinsics, "--out", intrinsics,
                      *args, "--force", cwd=tmp_path)  # fmt: skip
    refused(proc, "is the --intrinsics file")
    proc = mearm_here("calibrate-camera", "--intrinsics", intrinsics, "--out", "p.yaml", *args,
                      "--config", config, "--output", image, "--force", cwd=tmp_path)  # fmt: skip
    refused(proc, "is the --image file")
    assert image.read_bytes() == before and intrinsics.read_bytes() == kept
    assert not (tmp_path / "p.yaml").exists()


def test_calibrate_camera_output_needs_force_and_keeps_a_backup(tmp_path: Path) -> None:
    config = tmp_path / "h.yaml"
    assert mearm_here("init-config", config, "--arm", "paper", "--rig", "sim",
                      cwd=tmp_path).returncode == 0  # fmt: skip
    other = tmp_path / "other.yaml"
    other.write_text("keep: me\n")
    points = [a for p in ("1,1:0,30", "600,1:20,30", "600,400:20,50", "1,400:0,50",
                          "300,200:10,40") for a in ("--point", p)]  # fmt: skip
    proc = mearm_here(
        "calibrate-camera", "--config", config, *points, "--output", other, cwd=tmp_path
    )
    refused(proc, "pass --force")
    assert other.read_text() == "keep: me\n"
    proc = mearm_here("calibrate-camera", "--config", config, *points, "--output", other,
                      "--force", cwd=tmp_path)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "other.yaml.bak").read_text() == "keep: me\n"
    assert "homography" in other.read_text()
    # writing into --config itself (named either way) is the normal mode: no --force
    proc = mearm_here("calibrate-camera", "--config", config, *points, "--output", "./h.yaml",
                      cwd=tmp_path)  # fmt: skip
    assert proc.returncode == 0, proc.stderr


def test_check_camera_refine_refuses_its_config_and_intrinsics(tmp_path: Path) -> None:
    for name in ("twin_intrinsics.yaml", "twin_pose.yaml"):
        shutil.copy(ROOT / "configs" / "calibration" / name, tmp_path / name)
    config = tmp_path / "my.yaml"
    config.write_text(
        f"extends: {ROOT / 'configs' / 'sim_mujoco_perspective.yaml'}\n"
        f"calibration:\n  intrinsics_file: {tmp_path / 'twin_intrinsics.yaml'}\n"
        f"  extrinsics_file: {tmp_path / 'twin_pose.yaml'}\n"
    )
    texts = {p: p.read_bytes() for p in tmp_path.iterdir()}
    for out, what in (("twin_intrinsics.yaml", "intrinsics file"), ("my.yaml", "--config")):
        proc = mearm_here("check-camera", "--config", config, "--refine", out, "--force",
                          cwd=tmp_path)  # fmt: skip
        refused(proc, what)
    assert {p: p.read_bytes() for p in tmp_path.iterdir()} == texts


def test_render_calibration_replaces_an_earlier_run_only_with_force(tmp_path: Path) -> None:
    out = tmp_path / "calib"
    proc = mearm_here("render-calibration", "--config", "sim_mujoco", "--out", out, "--views",
                      "2", "--truth", "--raised-height-cm", "10", cwd=tmp_path)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    (out / "notes.txt").write_text("mine\n")
    again = ["render-calibration", "--config", "sim_mujoco", "--out", out, "--views", "1"]
    refused(mearm_here(*again, cwd=tmp_path), "not empty")
    assert (out / "board_01.png").exists()
    proc = mearm_here(*again, "--force", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    names = sorted(p.name for p in out.iterdir())
    assert names == ["board_00.png", "notes.txt", "sheet.png", "sheet_markers.txt"]


def test_camera_accuracy_json_may_not_be_an_input(tmp_path: Path) -> None:
    config = tmp_path / "c.yaml"
    config.write_text(f"extends: {ROOT / 'configs' / 'sim_mujoco_perspective.yaml'}\n")
    before = config.read_text()
    proc = mearm_cli("camera-accuracy", "--config", config, "--json", config, cwd=tmp_path)
    refused(proc, "is the --config file")
    work = tmp_path / "work"
    proc = mearm_here("camera-accuracy", "--config", config, "--work", work, "--json",
                      work / "pose.yaml", cwd=tmp_path)  # fmt: skip
    refused(proc, "write elsewhere")
    assert config.read_text() == before
