"""Every file or folder a command writes is named on stdout by a ``wrote`` line, backups too.

A command that replaces a file keeps the old one as ``PATH.bak`` (``check-camera
--refine`` a displaced marker fit as ``PATH.markers.bak`` too) and names it before the
file that replaced it, in the same words everywhere: ``wrote PATH.bak (the old PATH)``.
None did. ``mearm flash`` did not name the build folder it writes; the sort named its
``--save-mjcf`` and ``--save-calibration`` files as ``MJCF: PATH`` and ``calibration
written: PATH``, the second not at all with ``--quiet``. Each command runs here in this
process on real files; ``flash`` uploads to a stand-in avrdude (the board's side).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import ROOT, run_in_process
from charuco_render import TrueCamera, board_poses, render_view
from conftest import firmware_build
from test_output_streams_wrote import calibration_points

from mearm.task.armcheck import ArmCheck, CheckPoint
from mearm.vision.pinhole import Extrinsics, load_calibration

CALIB = ROOT / "configs" / "calibration"
TWIN = ROOT / "configs" / "sim_mujoco_perspective.yaml"
INTRINSICS = CALIB / "twin_intrinsics.yaml"


def _kept(path: Path) -> str:
    """The line that names the backup of ``path`` (as the command was given ``path``)."""
    return f"wrote {path}.bak (the old {path})"


def test_init_config_names_the_config_it_kept(tmp_path: Path) -> None:
    """--force over an edited config: the .bak named first, then the new config."""
    out = tmp_path / "my.yaml"
    out.write_text("# edited by hand\n")
    done = run_in_process(["init-config", "--arm", "mearm_v1", "--rig", "sim", "--force", out])
    assert done.code == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[:2] == [_kept(out), f"wrote {out}: the mearm_v1 arm on the sim rig. Next:"]
    assert Path(f"{out}.bak").read_text() == "# edited by hand\n"
    again = run_in_process(
        ["init-config", "--arm", "mearm_v1", "--rig", "sim", tmp_path / "new.yaml"]
    )
    assert again.code == 0 and ".bak" not in again.stdout  # nothing replaced, nothing kept


def test_calibrate_servos_names_the_calibration_it_kept(tmp_path: Path) -> None:
    """A second --force write: ``wrote F.bak (the old F)`` before the file's own line."""
    out = tmp_path / "kit.servos.yaml"
    argv = ["calibrate-servos", "--config", "sim_mujoco_kits", "--simulate", "--truth",
            "--output", out]  # fmt: skip
    first = run_in_process(argv, within_s=30)
    assert first.code == 0 and ".bak" not in first.stdout, first.stdout + first.stderr
    with out.open("a") as f:  # (the same second's fit is the same bytes, which need no backup)
        f.write("# fitted on another day\n")
    old = out.read_bytes()
    done = run_in_process([*argv, "--force"], within_s=30)
    assert done.code == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[:2] == [_kept(out), f"wrote {out} (4 actuators)"]
    assert Path(f"{out}.bak").read_bytes() == old


def test_calibrate_camera_names_the_config_it_kept(tmp_path: Path) -> None:
    """An existing --output replaced (--force): its .bak named before the calibration's line."""
    config, out = tmp_path / "lab.yaml", tmp_path / "mine.yaml"
    shutil.copy(ROOT / "configs" / "lab.yaml", config)
    out.write_text("# mine\n")
    done = run_in_process(
        ["calibrate-camera", "--config", config, *calibration_points(), "--output", out, "--force"]
    )
    assert done.code == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[-2:] == [_kept(out), f"wrote the calibration into {out}"]
    assert Path(f"{out}.bak").read_text() == "# mine\n"


@pytest.mark.heavy
def test_calibrate_camera_pose_names_the_pose_and_the_config_it_kept(tmp_path: Path) -> None:
    """The pose mode replaces a pose file (kept by the calibration file's rule) and an
    --output config: each .bak named before the line of the file that replaced it."""
    from mearm.config import load_config  # noqa: PLC0415  (MuJoCo: this case)
    from mearm.sim.twin.calibration_scenes import (  # noqa: PLC0415
        SHEET_SIDE_CM,
        default_sheet_layout,
        render_sheet,
    )

    config = load_config(TWIN)
    layout = default_sheet_layout(config)
    sheet, pose, twin = tmp_path / "sheet.png", tmp_path / "pose.yaml", tmp_path / "my_twin.yaml"
    cv2.imwrite(str(sheet), render_sheet(config, layout, noise_std=2, seed=0))
    shutil.copy(CALIB / "twin_pose.yaml", pose)
    twin.write_text("# mine\n")
    markers = [a for i, (x, y) in layout.items() for a in ("--marker", f"{i}:{x:g},{y:g}")]
    done = run_in_process(
        ["calibrate-camera", "--intrinsics", INTRINSICS, "--out", pose, "--image", sheet,
         "--marker-side-cm", f"{SHEET_SIDE_CM:g}", *markers, "--config", TWIN,
         "--output", twin, "--force"],
        within_s=60,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[-4:] == [
        _kept(pose),
        f"wrote the camera pose to {pose}",
        _kept(twin),
        f"pointed {twin} at {INTRINSICS} and {pose}",
    ]
    assert Path(f"{pose}.bak").read_bytes() == (CALIB / "twin_pose.yaml").read_bytes()


@pytest.mark.heavy
def test_calibrate_intrinsics_names_the_file_it_kept(tmp_path: Path) -> None:
    """--force over an existing file: ``wrote OUT.bak (the old OUT)``, then ``wrote OUT``."""
    cam, views = TrueCamera(), tmp_path / "views"
    views.mkdir()
    for k, board in enumerate(board_poses(cam, 8, seed=1)):
        cv2.imwrite(str(views / f"v{k}.png"), render_view(cam, board, seed=k))
    out = tmp_path / "intrinsics.yaml"
    out.write_text("# an older file\n")
    done = run_in_process(
        ["calibrate-intrinsics", "--images", views, "--out", out, "--force"], within_s=30
    )
    assert done.code == 0, done.stderr
    assert done.stdout.splitlines()[-2:] == [_kept(out), f"wrote {out}"]
    assert Path(f"{out}.bak").read_text() == "# an older file\n"


def _pose(path: Path) -> Extrinsics:
    cal = load_calibration(path, "extrinsics")
    assert isinstance(cal, Extrinsics)
    return cal


def _refined(checked: Extrinsics, refined_px: float, checked_px: float) -> ArmCheck:
    """A finished check of ``checked`` whose refined pose (moved 1 mm) has ``refined_px``."""
    points = (CheckPoint(np.zeros(2), np.zeros(2)), CheckPoint(np.ones(2), np.ones(2)))
    refined = Extrinsics(
        checked.rotation, checked.position_cm + (0.1, 0.0, 0.0), refined_px, checked.markers,
        checked.camera_id, checked.size_px, refined_by_arm=True,
    )  # fmt: skip
    return ArmCheck("red", np.zeros(2), points, refined=refined, checked_rms_px=checked_px,
                    returned=True)  # fmt: skip


def test_a_refine_names_each_backup_it_writes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Refining a marker fit in place twice: the first keeps it as .bak, the second keeps
    the first refined pose beside it as .bak.1 (no backup replaces another); each named
    (the command names OUT after them)."""
    from mearm.tools.check_camera import write_refined  # noqa: PLC0415

    pose = tmp_path / "pose.yaml"
    shutil.copy(CALIB / "twin_pose.yaml", pose)
    checked = _pose(pose)
    write_refined(pose, _refined(checked, 2.6, 2.8), checked, force=False)
    assert capsys.readouterr().out.splitlines() == [_kept(pose)]
    first = pose.read_bytes()
    checked = _pose(pose)  # the config now reads the refined pose
    write_refined(pose, _refined(checked, 2.5, 2.6), checked, force=False)
    assert capsys.readouterr().out.splitlines() == [f"wrote {pose}.bak.1 (the old {pose})"]
    assert Path(f"{pose}.bak").read_bytes() == (CALIB / "twin_pose.yaml").read_bytes()
    assert Path(f"{pose}.bak.1").read_bytes() == first


@pytest.mark.heavy
def test_check_camera_refine_names_the_pose_it_kept_then_the_pose(tmp_path: Path) -> None:
    """The whole command, refining the config's own pose file: the last two lines."""
    for name in ("twin_intrinsics.yaml", "twin_pose.yaml"):
        shutil.copy(CALIB / name, tmp_path / name)
    pose = tmp_path / "twin_pose.yaml"
    done = run_in_process(
        ["check-camera", "--config", TWIN, "--points", "2", "--refine", pose,
         "--set", f"calibration.intrinsics_file={tmp_path / 'twin_intrinsics.yaml'}",
         "--set", f"calibration.extrinsics_file={pose}"],
        within_s=60,
    )  # fmt: skip
    assert done.code == 0, done.stdout + done.stderr
    assert done.stdout.splitlines()[-2:] == [_kept(pose), f"wrote {pose}"]


@pytest.mark.heavy
def test_flash_names_the_build_folder_before_the_upload(
    tmp_path_factory: pytest.TempPathFactory, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The firmware built (the shared build, up to date), uploaded by a stand-in avrdude:
    the build folder is named before the upload runs; the outcome stays the last line."""
    build = firmware_build(tmp_path_factory)
    tools = tmp_path / "bin"
    tools.mkdir()
    (tools / "avrdude").write_text("#!/bin/sh\nexit 0\n")
    (tools / "avrdude").chmod(0o755)
    monkeypatch.setenv("PATH", f"{tools}:{os.environ['PATH']}")
    port = tmp_path / "ttyACM9"  # the port must exist; the stand-in avrdude never opens it
    port.touch()
    done = run_in_process(
        ["flash", "--port", port, "--build-dir", build, "--no-check"], within_s=60
    )
    assert done.code == 0, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    named = f"wrote {build.resolve()}/ (the firmware's build: mearm_servo.hex and its objects)"
    assert named in lines, done.stdout
    assert lines.index(named) < next(i for i, ln in enumerate(lines) if ln.startswith("$ avrdude"))
    assert lines[-1] == f"uploaded {build.resolve() / 'mearm_servo.hex'} to {port}"


@pytest.mark.heavy
def test_the_sort_names_its_mjcf_and_calibration_also_when_quiet(tmp_path: Path) -> None:
    """--save-mjcf and --save-calibration over an existing calibration, with --quiet: each
    file named by a ``wrote`` line (the replaced calibration's .bak too), the outcome last."""
    servos, mjcf = tmp_path / "kit.servos.yaml", tmp_path / "scene.xml"
    made = run_in_process(["calibrate-servos", "--config", "sim_mujoco_kits", "--simulate",
                           "--truth", "--output", servos], within_s=30)  # fmt: skip
    assert made.code == 0, made.stderr
    old = servos.read_bytes()
    done = run_in_process(
        ["sort", "--config", "sim_mujoco_kits", "--quiet", "--random", "1", "--seed", "1",
         "--save-calibration", servos, "--save-mjcf", mjcf],
        within_s=60,
    )  # fmt: skip
    assert done.code == 0, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    assert lines[:3] == [f"wrote {mjcf}", _kept(servos), f"wrote {servos}"], done.stdout
    assert lines[-1] == "sorted 1 of 1 objects (simulated)"
    assert Path(f"{servos}.bak").read_bytes() == old and mjcf.is_file()
