"""The twin's camera: where it stands, its lens, and the calibration pictures it takes."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import mujoco
import numpy as np
import pytest
from badinput import ROOT, check_bad_input, run_in_process

from mearm.config import load_config
from mearm.config.twin_camera_config import TwinCameraConfig
from mearm.exceptions import CalibrationError
from mearm.sim.twin.calibration_scenes import (
    board_poses,
    default_sheet_layout,
    render_board_views,
    render_sheet,
)
from mearm.sim.twin.twin_camera import (
    SORTER_MSAA_SAMPLES,
    SORTER_SHADOWS,
    LensRenderer,
    TwinCamera,
    _distorted_px,
    _lens_maps,
    camera_pose,
    twin_camera_model,
)
from mearm.vision.aruco import detect_markers, diagonal_center, table_corners_cm
from mearm.vision.calibration import Calibration
from mearm.vision.charuco import DEFAULT_BOARD

bad_input = pytest.mark.bad_input
CONFIGS = ROOT / "configs"


@pytest.fixture(scope="module")
def default_config():
    return load_config(CONFIGS / "sim_mujoco.yaml")


@pytest.fixture(scope="module")
def perspective():
    return load_config(CONFIGS / "sim_mujoco_perspective.yaml")


def _projected(config, markers, side_cm):
    """Marker id → its true corners projected by the ground-truth camera, (4, 2) [px]."""
    truth = twin_camera_model(config)
    R_cam_base = truth.R_base_cam.T
    rvec = cv2.Rodrigues(R_cam_base)[0]
    tvec = -R_cam_base @ truth.camera_centre_cm
    out = {}
    for i, xy in markers.items():
        corners = np.c_[table_corners_cm(xy, side_cm), np.zeros(4)]
        px, _ = cv2.projectPoints(corners, rvec, tvec, truth.K, truth.dist)
        out[i] = px.reshape(4, 2)
    return out


@pytest.mark.heavy
def test_default_camera_keeps_the_homography(default_config):
    """Unconfigured, the twin renders table points where the homography maps them.

    The homography's pixels have the frame's outer corner at (0, 0) (the twin's field
    runs from u = 0 to u = w); OpenCV's have pixel (0, 0)'s centre there: ½ px apart.
    """
    assert default_config.twin.camera is None
    layout = default_sheet_layout(default_config)
    frame = render_sheet(default_config, layout, 4.0)
    found = detect_markers(frame)
    assert set(found) == set(layout)
    cal = Calibration.from_config(default_config.calibration)
    for i, xy in layout.items():
        centre_px = diagonal_center(found[i]) + 0.5  # OpenCV's pixel centres → corners
        expected = cal.table_to_pixel(np.array([xy]))[0]
        assert np.abs(centre_px - expected).max() <= 0.2, (i, centre_px, expected)


def test_default_pose_is_straight_down(default_config):
    """The default camera looks straight down from 52 cm over the field's centre."""
    truth = twin_camera_model(default_config)
    assert np.allclose(truth.R_base_cam, np.diag([1.0, -1.0, -1.0]))
    assert np.allclose(truth.camera_centre_cm, [-0.5, 44.0, 52.0])
    assert np.allclose(truth.dist, 0.0)


def test_tilted_axis_meets_the_target(perspective):
    """Tilted, the camera stays height_cm up, looks down at tilt_deg, its axis on the target."""
    cam = perspective.twin.camera
    pose = camera_pose(perspective)
    forward = -pose.R_base_mj[:, 2]
    assert math.isclose(pose.centre_m[2], cam.height_cm / 100)
    assert math.isclose(math.degrees(math.acos(-forward[2])), cam.tilt_deg, abs_tol=1e-9)
    hit = pose.centre_m + forward * (pose.centre_m[2] / -forward[2])
    assert np.allclose(hit[:2], [-0.005, 0.44]) and abs(hit[2]) < 1e-12
    assert pose.centre_m[1] < 0.44 and forward[1] > 0  # on the robot's side, looking away
    assert np.allclose(pose.R_base_mj.T @ pose.R_base_mj, np.eye(3))


@pytest.mark.heavy
def test_configured_camera_renders_where_the_truth_projects(perspective):
    """Markers on the table appear where the ground-truth camera (lens too) projects them.

    Centres within 0.3 px; corners within 0.6 px: the detector's corners of a ~50 px
    marker sit 0.2–0.3 px inside its true ones (blur), more where the lens bends its edges
    (it fits straight lines), and this inward bias cancels in the diagonals' crossing.
    """
    side = 6.0
    layout = {0: (-12.0, 52.0), 1: (0.0, 52.0), 2: (12.0, 52.0), 3: (-12.0, 36.0),
              4: (0.0, 36.0), 5: (12.0, 36.0), 6: (24.0, 62.0), 7: (-28.0, 24.0)}  # fmt: skip
    frame = render_sheet(perspective, layout, side)
    found = detect_markers(frame)
    assert set(found) == set(layout)
    expected = _projected(perspective, layout, side)
    for i in layout:
        centre_err = diagonal_center(found[i]) - diagonal_center(expected[i])
        assert np.abs(centre_err).max() <= 0.3, (i, centre_err)
        assert np.abs(found[i] - expected[i]).max() <= 0.6, (i, found[i] - expected[i])


def test_distortion_direction():
    """Each distorted pixel takes the ideal pixel that projectPoints distorts onto it."""
    K = np.array([[500.0, 0, 319.5], [0, 500.0, 239.5], [0, 0, 1]])
    dist = np.array([-0.12, 0.05, 0.0005, -0.0003, -0.01])
    map_x, map_y, mx, my = _lens_maps(K, dist, (640, 480))
    for u, v in ((0, 0), (639, 0), (639, 479), (100, 300), (320, 240)):
        p_u = np.array([map_x[v, u] - mx, map_y[v, u] - my])
        ray = np.array([(p_u[0] - 319.5) / 500, (p_u[1] - 239.5) / 500, 1.0])
        p_d, _ = cv2.projectPoints(ray[None], np.zeros(3), np.zeros(3), K, dist)
        assert np.abs(p_d.ravel() - [u, v]).max() < 1e-2
    # barrel: the frame's corner sees an ideal point further out than itself
    assert map_x[0, 0] - mx < 0 and map_y[0, 0] - my < 0


def test_the_lens_check_distorts_as_opencv_does():
    """The lens maps' check moves each point as ``cv2.projectPoints`` does, to 1e-9 px:
    random lenses, over and past a frame (OpenCV's model has no skew: it reads none)."""
    rng = np.random.default_rng(20261201)
    for _ in range(20):
        f, cx, cy = rng.uniform(200.0, 900.0), rng.uniform(250, 390), rng.uniform(190, 290)
        K = np.array([[f, rng.uniform(-2, 2), cx], [0, f * rng.uniform(0.9, 1.1), cy], [0, 0, 1]])
        dist = rng.uniform(-1.0, 1.0, 5) * [0.3, 0.1, 0.01, 0.01, 0.02]
        ideal = rng.uniform(-200.0, 840.0, (500, 2))
        rays = np.column_stack([(ideal - K[:2, 2]) / np.diag(K)[:2], np.ones(len(ideal))])
        want, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), K, dist)
        assert np.abs(_distorted_px(K, dist, ideal) - want.reshape(-1, 2)).max() < 1e-9


@pytest.mark.heavy
def test_folding_distortion_is_refused(default_config):
    """A distortion with no inverse over the frame is a named error, not a garbled frame."""
    from mearm.exceptions import CameraError

    K = np.array([[300.0, 0, 319.5], [0, 300.0, 239.5], [0, 0, 1]])
    with pytest.raises(CameraError, match="distortion"):
        _lens_maps(K, np.array([-1.0, 0.0, 0.0, 0.0, 0.0]), (640, 480))


@pytest.mark.heavy
def test_board_views_are_detected(perspective):
    """Most board views show ≥ 12 ChArUco corners, at the pose the board was put."""
    n = 8
    frames = render_board_views(perspective, n, seed=3)
    poses = board_poses(perspective, n, seed=3)
    truth = twin_camera_model(perspective)
    board = DEFAULT_BOARD.board()
    detector = cv2.aruco.CharucoDetector(board)
    good, errors_cm, errors_deg = 0, [], []
    for frame, T in zip(frames, poses, strict=True):
        corners, ids, _, _ = detector.detectBoard(cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY))
        if ids is None or len(ids) < 12:
            continue
        good += 1
        obj, img = board.matchImagePoints(corners, ids)
        ok, rvec, tvec = cv2.solvePnP(obj, img, truth.K, truth.dist)
        assert ok
        R_true = truth.R_base_cam.T @ T[:3, :3]
        t_true = truth.R_base_cam.T @ (T[:3, 3] * 100 - truth.camera_centre_cm)
        R = cv2.Rodrigues(rvec)[0]
        angle = math.degrees(math.acos(np.clip((np.trace(R.T @ R_true) - 1) / 2, -1, 1)))
        errors_cm.append(np.linalg.norm(tvec.ravel() - t_true))
        assert errors_cm[-1] <= 0.1  # mostly along the line of sight, 45 cm away
        errors_deg.append(angle)
        assert angle <= 0.3
    assert good >= 0.75 * n
    assert np.median(errors_cm) <= 0.05 and np.median(errors_deg) <= 0.1


@pytest.mark.heavy
def test_renders_are_deterministic(perspective):
    """One seed, one picture (noise included)."""
    a = render_board_views(perspective, 1, seed=5, noise_std=2.0)[0]
    b = render_board_views(perspective, 1, seed=5, noise_std=2.0)[0]
    assert np.array_equal(a, b) and a.dtype == np.uint8


def test_overlapping_markers_are_refused(default_config):
    """Two markers laid over each other are a named error."""
    with pytest.raises(CalibrationError, match="overlap"):
        render_sheet(default_config, {0: (0.0, 40.0), 1: (2.0, 40.0)}, 4.0)


def test_camera_config_is_bounded():
    """Tilt beyond 45° and distortion beyond ±1 are refused."""
    from pydantic import ValidationError

    with pytest.raises(ValidationError):
        TwinCameraConfig(tilt_deg=50)
    with pytest.raises(ValidationError):
        TwinCameraConfig(distortion=(2.0, 0, 0, 0, 0))


@pytest.mark.heavy
def test_tool_writes_the_pictures(tmp_path: Path):
    """``mearm render-calibration`` writes the views, the sheet and its marker list."""
    out = tmp_path / "calib"
    config = CONFIGS / "sim_mujoco_perspective.yaml"
    res = run_in_process(
        ["render-calibration", "--config", config, "--out", out, "--views", "2"], within_s=60
    )
    assert res.code == 0, res.stderr
    assert sorted(p.name for p in out.iterdir()) == [
        "board_00.png", "board_01.png", "sheet.png", "sheet_markers.txt"
    ]  # fmt: skip
    text = (out / "sheet_markers.txt").read_text()
    assert "--marker 0:" in text and "--marker-side-cm 4" in text
    assert cv2.imread(str(out / "sheet.png")).shape == (480, 640, 3)


@bad_input
@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--views", "0"], "--views"),
        (["--views", "x"], "--views"),
        (["--noise-std", "-1"], "--noise-std"),
        (["--seed", "-3"], "seed"),
    ],
)
def test_bad_arguments(tmp_path: Path, extra: list[str], words: str):
    """Bad numbers are refused with one line naming the option."""
    out = check_bad_input(
        ["render-calibration", "--config", CONFIGS / "sim_mujoco.yaml", "--out", tmp_path / "o",
         *extra],
        keep=[CONFIGS],
    )  # fmt: skip
    assert words in out.line


@bad_input
def test_out_is_a_file(tmp_path: Path):
    """An --out that is a file is refused and left alone."""
    f = tmp_path / "file"
    f.write_text("keep")
    out = check_bad_input(
        ["render-calibration", "--config", CONFIGS / "sim_mujoco.yaml", "--out", f], keep=[f]
    )
    assert "not a directory" in out.line


@bad_input
def test_unwritable_out(tmp_path: Path):
    """An --out that cannot be made (under a file) is refused with one line."""
    f = tmp_path / "file"
    f.write_text("keep")
    out = check_bad_input(
        ["render-calibration", "--config", CONFIGS / "sim_mujoco.yaml", "--out", f / "sub"],
        keep=[f],
    )
    assert "--out" in out.line


@bad_input
def test_not_a_twin_config(tmp_path: Path):
    """A config that does not simulate the twin is refused with one line."""
    out = check_bad_input(
        ["render-calibration", "--config", CONFIGS / "sim.yaml", "--out", tmp_path / "o"],
        keep=[CONFIGS],
    )
    assert "mujoco" in out.line


# --------------------------------------------------------------------------- the sorter's frames


@pytest.fixture(scope="module")
def twin_at_home(default_config):
    from mearm.sim.twin.twin_bus import TwinArm

    twin = TwinArm(default_config)
    yield twin
    twin.close()


def _quality(lens: LensRenderer) -> tuple[int, int]:
    """The samples per pixel and the shadow map's side of a renderer's GL context."""
    context = lens._renderer._mjr_context
    return int(context.offSamples), int(context.shadowSize)


def test_the_sorters_frames_are_rendered_without_msaa_or_shadows(default_config, twin_at_home):
    """TwinCamera's GL context has no multisamples and no shadow map; the calibration
    pictures' renderer keeps the model's (MuJoCo's 4× and 4096²); the twin's model is left
    as it was."""
    quality = twin_at_home.model.vis.quality
    assert (quality.offsamples, quality.shadowsize) == (4, 4096)
    with TwinCamera(default_config, twin_at_home) as camera:
        assert _quality(camera._lens) == (SORTER_MSAA_SAMPLES, 0) == (0, 0)
        assert not camera._lens._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW]
        frame = camera.read()
        assert camera.read().tobytes() == frame.tobytes()  # the setting holds frame to frame
    assert (quality.offsamples, quality.shadowsize) == (4, 4096)
    full = LensRenderer(twin_at_home.model, default_config)
    try:
        assert _quality(full) == (4, 4096)
        assert not np.array_equal(full.render(twin_at_home.data), frame)
    finally:
        full.close()
    bare = LensRenderer(twin_at_home.model, default_config, msaa_samples=0, shadows=False)
    try:
        assert np.array_equal(bare.render(twin_at_home.data), frame)
    finally:
        bare.close()


def test_shadows_darken_the_table_and_can_be_left_out(default_config, twin_at_home):
    """The light straight down casts each object's shadow beside it in the camera's
    perspective: drawn, about a thousand pixels are far darker; elsewhere the frames agree
    within a few levels (summed over B, G, R: 15 at most here, shading)."""
    frames = {}
    for shadows in (True, False):
        lens = LensRenderer(twin_at_home.model, default_config, msaa_samples=0, shadows=shadows)
        try:
            frames[shadows] = lens.render(twin_at_home.data).astype(int)
        finally:
            lens.close()
    darker = (frames[False] - frames[True]).sum(axis=2)
    assert (darker > 60).sum() > 500  # the shadows
    assert (darker < -20).sum() == 0  # a shadow only takes light away


@pytest.mark.parametrize("name", ["sim_mujoco.yaml", "sim_mujoco_perspective.yaml"])
def test_the_detector_finds_the_same_objects_in_the_sorters_frame(name):
    """What the sorter takes from a frame without MSAA and shadows is what it takes from
    the full-quality picture: the same objects, their centroids within 1 px and table
    positions within 0.1 cm (0.48 px and 0.065 cm at most over every frame of the
    paper's, the 5-DOF arm's and the perspective rig's sorts, simulated)."""
    from mearm.sim.twin.twin_bus import TwinArm
    from mearm.vision.calibration import camera_geometry
    from mearm.vision.detector import ColorDetector

    config = load_config(CONFIGS / name)
    twin = TwinArm(config)
    detector = ColorDetector(
        config.vision, camera_geometry(config.calibration, config.camera), config.task.classes
    )
    found = []
    try:
        for kwargs in ({}, {"msaa_samples": SORTER_MSAA_SAMPLES, "shadows": SORTER_SHADOWS}):
            lens = LensRenderer(twin.model, config, **kwargs)
            try:
                found.append(detector.detect(lens.render(twin.data)))
            finally:
                lens.close()
    finally:
        twin.close()
    full, sorter = found
    assert len(full) == len(config.task.scene)
    assert [(d.color, d.merged) for d in sorter] == [(d.color, d.merged) for d in full]
    for a, b in zip(sorter, full, strict=True):
        assert np.abs(a.centroid_px - b.centroid_px).max() <= 1.0
        assert a.table_cm is not None and b.table_cm is not None
        assert np.hypot(*(a.table_cm - b.table_cm)) <= 0.1


def test_a_render_holds_every_geom_of_a_crowded_twin():
    """The renderer's scene is sized to the model (``scene_geoms``), not MuJoCo's default
    10,000 (20–35 ms of CPU to make): a twin with 15 objects still draws every geom that a
    scene of 10,000 does, with room to spare (a full scene drops geoms from the picture,
    and MuJoCo says nothing)."""
    from mearm.sim.twin.frame_drawer import close_renderer, offscreen_renderer
    from mearm.sim.twin.mjcf import twin_model
    from mearm.task.scene import random_scene

    config = load_config(ROOT / "configs" / "sim_mujoco.yaml")
    scene = random_scene(config, 15, seed=5)
    crowded = config.model_copy(update={"task": config.task.model_copy(update={"scene": scene})})
    model = twin_model(crowded)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    full = mujoco.MjvScene(model, maxgeom=10_000)
    mujoco.mjv_updateScene(
        model, data, mujoco.MjvOption(), None, mujoco.MjvCamera(), mujoco.mjtCatBit.mjCAT_ALL, full
    )
    renderer = offscreen_renderer(model, (64, 48), msaa_samples=0, shadows=False)
    try:
        renderer.update_scene(data)
        drawn, room = renderer.scene.ngeom, renderer.scene.maxgeom
    finally:
        close_renderer(renderer)
    assert full.ngeom >= model.ngeom - 1  # every object, the arm, the bins: all drawn
    assert drawn == full.ngeom
    assert room >= 2 * drawn
