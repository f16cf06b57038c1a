"""``mearm check-camera --refine``: a refined pose replaces only a pose no better, and never
loses the marker-fitted one.

The refined pose kept the marker fit's ``rms_px`` (0.306 px on the twin's pose), so the
calibration file's rule (replace only by an ``rms_px`` no higher) let every refined pose
through, and a second refine of the same file wrote the first refined pose over
``.bak``, which held the only marker-fitted pose. The refined pose now records its own
residual over the check points, compared with the checked pose's over the same points;
the marker fit a refine displaces from ``.bak`` is kept as ``.markers.bak``.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from badinput import check_bad_input
from conftest import ROOT

from mearm.config.errors import CalibrationError
from mearm.task.armcheck import ArmCheck, CheckPoint
from mearm.vision.pinhole import Extrinsics, load_calibration, save_calibration

CALIB = ROOT / "configs" / "calibration"
NUMBER = r"[-+]?\d+\.\d+"


def _rig(tmp_path: Path) -> tuple[list[str], Path]:
    """``--config`` and ``--set`` of the twin's perspective rig reading its pose from
    ``tmp_path/pose.yaml`` (the walkthrough's marker fit, copied), and that file."""
    for name in ("twin_intrinsics.yaml", "twin_pose.yaml"):
        shutil.copy(CALIB / name, tmp_path / name)
    pose = tmp_path / "pose.yaml"
    (tmp_path / "twin_pose.yaml").rename(pose)
    argv = [
        "--config", str(ROOT / "configs" / "sim_mujoco_perspective.yaml"),
        "--set", f"calibration.intrinsics_file={tmp_path / 'twin_intrinsics.yaml'}",
        "--set", f"calibration.extrinsics_file={pose}",
    ]  # fmt: skip
    return argv, pose


def _pose(path: Path) -> Extrinsics:
    cal = load_calibration(path, "extrinsics")
    assert isinstance(cal, Extrinsics)
    return cal


def _moved(pose: Extrinsics, dx_cm: float, *, rms_px: float, by_arm: bool) -> Extrinsics:
    """``pose`` shifted along x, as another calibration of the same camera."""
    return Extrinsics(
        pose.rotation, pose.position_cm + (dx_cm, 0.0, 0.0), rms_px, pose.markers,
        pose.camera_id, pose.size_px, refined_by_arm=by_arm,
    )  # fmt: skip


@pytest.mark.heavy
def test_two_refines_in_place_keep_the_marker_fit(tmp_path: Path, capsys) -> None:
    """Refining the config's own pose file twice, 2 points each: after one, the file holds
    the refined pose (its rms_px its own residual over the points, as printed) and .bak
    the marker fit; after two, the second refined pose, .bak still the marker fit (no
    backup replaces another) and .bak.1 the first."""
    from mearm.tools.check_camera import main

    argv, pose = _rig(tmp_path)
    marker_fit = pose.read_bytes()
    bak, second = tmp_path / "pose.yaml.bak", tmp_path / "pose.yaml.bak.1"
    refine = [*argv, "--points", "2", "--refine", str(pose)]
    outs, files = [], []
    for _ in range(2):
        code = main(refine)
        out, err = capsys.readouterr()
        assert code == 0, err
        outs.append(out)
        files.append(pose.read_bytes())
        if len(files) == 1:  # after one refine
            assert bak.read_bytes() == marker_fit
            assert not second.exists()
    assert bak.read_bytes() == marker_fit  # after two: the marker fit kept
    assert second.read_bytes() == files[0]  # and the first refined pose beside it
    for out, text in zip(outs, files, strict=True):
        path = tmp_path / "read.yaml"
        path.write_bytes(text)
        m = re.search(rf"^pose residual over the points: rms ({NUMBER}) px checked, "
                      rf"({NUMBER}) px refined$", out, re.M)  # fmt: skip
        assert m, out
        refined = _pose(path)
        assert refined.refined_by_arm
        assert refined.rms_px == pytest.approx(float(m.group(2)), abs=5e-4)
        assert refined.rms_px <= float(m.group(1))


@pytest.mark.bad_input
def test_a_marker_fit_the_check_does_not_measure_is_not_replaced(tmp_path: Path) -> None:
    """OUT holds another marker fit (rms 0.5 px over its markers): a refined pose's rms is
    over the arm's points, so the two are not compared; refused before the arm moves."""
    argv, pose = _rig(tmp_path)
    other = tmp_path / "other.yaml"
    save_calibration(other, _moved(_pose(pose), 0.4, rms_px=0.5, by_arm=False))
    out = check_bad_input(["check-camera", *argv, "--points", "2", "--refine", other],
                          keep=[tmp_path])  # fmt: skip
    assert "marker-fitted pose this check does not measure" in out.line
    assert "--force" in out.line
    assert out.stdout == ""  # nothing checked: the arm did not move


def _check(refined_px: float, checked_px: float, checked: Extrinsics) -> ArmCheck:
    """A finished check whose refined pose has ``refined_px`` and the checked ``checked_px``."""
    points = (CheckPoint(np.zeros(2), np.zeros(2)), CheckPoint(np.ones(2), np.ones(2)))
    refined = _moved(checked, 0.1, rms_px=refined_px, by_arm=True)
    return ArmCheck("red", np.zeros(2), points, refined=refined, checked_rms_px=checked_px,
                    returned=True)  # fmt: skip


def test_the_pose_checked_is_weighed_over_the_same_points(tmp_path: Path) -> None:
    """OUT holds the pose checked, a marker fit of 0.306 px over its markers: a refined pose
    of 2.6 px over the points replaces it when the checked pose had 2.8 px over the same
    points, and not when it had 2.4 px."""
    from mearm.tools.check_camera import write_refined

    _, pose = _rig(tmp_path)
    checked, marker_fit = _pose(pose), pose.read_bytes()
    with pytest.raises(CalibrationError, match=r"fits the check's points better \(rms 2.400"):
        write_refined(pose, _check(2.6, 2.4, checked), checked, force=False)
    assert pose.read_bytes() == marker_fit
    assert not (tmp_path / "pose.yaml.bak").exists()
    write_refined(pose, _check(2.6, 2.8, checked), checked, force=False)
    assert _pose(pose).rms_px == 2.6 and _pose(pose).refined_by_arm
    assert (tmp_path / "pose.yaml.bak").read_bytes() == marker_fit
    assert not (tmp_path / "pose.yaml.markers.bak").exists()


def test_another_refined_pose_is_weighed_by_its_rms(tmp_path: Path) -> None:
    """OUT holds a pose refined by another check (3.0 px over its points): replaced by one
    of 2.6 px, not by one of 3.2 px; the marker fit, unchanged, is never touched."""
    from mearm.tools.check_camera import write_refined

    _, pose = _rig(tmp_path)
    checked = _pose(pose)
    out = tmp_path / "refined.yaml"
    save_calibration(out, _moved(checked, 0.2, rms_px=3.0, by_arm=True))
    before = out.read_bytes()
    with pytest.raises(CalibrationError, match="holds a better calibration"):
        write_refined(out, _check(3.2, 3.5, checked), checked, force=False)
    assert out.read_bytes() == before
    write_refined(out, _check(2.6, 3.5, checked), checked, force=False)
    assert _pose(out).rms_px == 2.6
    assert (tmp_path / "refined.yaml.bak").read_bytes() == before
    assert pose.read_bytes() == (CALIB / "twin_pose.yaml").read_bytes()


@pytest.mark.bad_input
@pytest.mark.parametrize("held", ["notes", "intrinsics"])
def test_an_out_no_refined_pose_may_replace_is_refused_before_the_arm_moves(
    tmp_path: Path, held: str
) -> None:
    """OUT holds a user's notes, or the camera's intrinsics: writing the refined pose would
    be refused, so the check is, before any point (until 2026-12-06 the arm ran the whole
    check first, then the write was refused)."""
    argv, _ = _rig(tmp_path)
    out_file = tmp_path / "out.yaml"
    if held == "notes":
        out_file.write_text("my notes\n")
    else:
        shutil.copy(tmp_path / "twin_intrinsics.yaml", out_file)
    before = out_file.read_bytes()
    out = check_bad_input(["check-camera", *argv, "--points", "2", "--refine", out_file],
                          keep=[tmp_path])  # fmt: skip
    what = "is not a readable camera calibration" if held == "notes" else "holds the intrinsics"
    assert what in out.line and "write elsewhere" in out.line
    assert out.stdout == ""  # nothing checked: the arm did not move
    assert out_file.read_bytes() == before
