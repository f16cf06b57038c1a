"""``mearm render-calibration --truth``: the twin's own camera written as calibration files."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import ROOT, run_in_process

from mearm.config import load_config
from mearm.sim.twin.twin_optics import twin_camera_model
from mearm.vision.pinhole import PerspectiveCamera

CONFIG = ROOT / "configs" / "sim_mujoco_perspective.yaml"


def _truth_pixels(config, points_cm: np.ndarray) -> np.ndarray:
    t = twin_camera_model(config)
    in_cam = (points_cm - t.camera_centre_cm) @ t.R_base_cam  # base → camera frame
    px, _ = cv2.projectPoints(in_cam.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), t.K, t.dist)
    return px.reshape(-1, 2)


@pytest.mark.heavy
def test_truth_files_project_as_the_twin_renders(tmp_path: Path):
    """The files load as a camera that projects every point, on the table and 20 cm above
    it, where the twin's own pinhole and lens put it."""
    out = tmp_path / "calib"
    res = run_in_process(
        ["render-calibration", "--config", CONFIG, "--out", out, "--views", "1", "--truth"],
        within_s=120,
    )
    assert res.code == 0, res.stderr
    assert "truth_intrinsics.yaml" in res.stdout and "truth_pose.yaml" in res.stdout
    config = load_config(CONFIG)
    camera = PerspectiveCamera.from_files(out / "truth_intrinsics.yaml", out / "truth_pose.yaml")
    points = np.array([[x, y, z] for x in (-10, 0, 10) for y in (30, 42) for z in (0, 20)], float)
    np.testing.assert_allclose(camera.project(points), _truth_pixels(config, points), atol=1e-6)
