"""The arm's body masked from detection, and the calibrated table as the default work area.

Rendered by the twin through its perspective camera, the detector using the calibration
made from the twin's own pictures (not the twin's truth).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.exceptions import ImageError
from mearm.ik import IKTarget, fastest_solver
from mearm.kinematics import ArmModel
from mearm.sim.table_collision import collision_model
from mearm.vision.arm_mask import ArmInView, arm_view, project_in_view
from mearm.vision.calibration import camera_geometry
from mearm.vision.detector import ColorDetector
from mearm.vision.pinhole import PerspectiveCamera

PERSPECTIVE = ROOT / "configs" / "sim_mujoco_perspective.yaml"
#: Where the arm reaches over the table, among the scene's objects [cm].
OVER_TABLE_CM = (2.0, 40.0, 11.0)


@pytest.fixture(scope="module")
def arm_over_table():
    """The twin's arm reaching over its objects, its body painted the first class's red.

    Returns the config, the joints, the frame and the arm's mask at those joints.
    """
    from mearm.sim.twin.twin_bus import TwinArm
    from mearm.sim.twin.twin_camera import LensRenderer

    config = load_config(PERSPECTIVE)
    model = ArmModel(config.arm)
    q = fastest_solver(model).solve(IKTarget(OVER_TABLE_CM), model.home).q
    twin = TwinArm(config)
    try:
        m = twin.model
        for i, name in enumerate(model.chain.names):
            twin.data.qpos[m.joint(name).qposadr[0]] = q[i]
        mujoco.mj_forward(m, twin.data)
        red = [*(np.array(config.task.classes[0].draw_rgb) / 255.0), 1.0]
        arm = {b for b in range(m.nbody) if m.body(b).name.startswith("link_")}
        arm |= {m.body("tcp").id}
        for g in range(m.ngeom):
            if m.geom_bodyid[g] in arm:
                m.geom_matid[g] = -1
                m.geom_rgba[g] = red
        lens = LensRenderer(m, config)
        try:
            frame = lens.render(twin.data)
        finally:
            lens.close()
        opening = twin.opening_cm
    finally:
        twin.close()
    camera = camera_geometry(config.calibration, config.camera)
    assert isinstance(camera, PerspectiveCamera)
    bodies = collision_model(config, model).bodies
    mask = ArmInView(camera, model, bodies, opening_cm=opening).mask(q, frame.shape)
    return config, q, frame, mask


def _detector(config) -> ColorDetector:
    return ColorDetector.from_config(
        config.vision, config.calibration, config.camera, config.task.classes
    )


def _nearest_object_cm(config, d) -> float:
    return min(float(np.hypot(d.table_cm[0] - o.x, d.table_cm[1] - o.y)) for o in config.task.scene)


def test_a_red_arm_is_taken_for_an_object_without_the_mask(arm_over_table) -> None:
    """The painted arm gives a red region where no object lies (so the test can fail)."""
    config, _, frame, _ = arm_over_table
    found = _detector(config).detect(frame)
    assert any(_nearest_object_cm(config, d) > 1.0 for d in found)


def test_with_the_mask_only_objects_are_found(arm_over_table) -> None:
    """Every detection is one of the scene's objects; the arm's red is gone."""
    config, _, frame, mask = arm_over_table
    found = _detector(config).detect(frame, exclude=mask)
    assert found
    assert all(_nearest_object_cm(config, d) < 0.5 for d in found)


def test_objects_beside_the_arm_are_still_found(arm_over_table) -> None:
    """Each object whose image lies clear of the mask is found, of its class."""
    config, _, frame, mask = arm_over_table
    camera = camera_geometry(config.calibration, config.camera)
    found = _detector(config).detect(frame, exclude=mask)
    clear = []
    for o in config.task.scene:
        (u, v), = camera.table_to_pixel(np.array([[o.x, o.y]]))  # fmt: skip
        r = 24  # px: the object's image and its shadow, with room
        if not mask[int(v) - r : int(v) + r, int(u) - r : int(u) + r].any():
            clear.append(o)
    assert len(clear) >= len(config.task.scene) - 4  # the arm covers only a few
    for o in clear:
        assert any(
            d.color == o.color and np.hypot(d.table_cm[0] - o.x, d.table_cm[1] - o.y) < 0.5
            for d in found
        ), o


def test_the_mask_covers_the_tool_where_the_camera_sees_it(arm_over_table) -> None:
    """The TCP's own pixel is in the mask; the far corners of the table are not."""
    config, q, frame, mask = arm_over_table
    camera = camera_geometry(config.calibration, config.camera)
    tcp = ArmModel(config.arm).fk_cm(q)
    (u, v), = camera.project(tcp[None, :])  # fmt: skip
    assert mask[int(round(v)), int(round(u))] == 255
    assert mask[5, 5] == 0 and mask[5, -5] == 0


def test_points_far_beside_the_frame_stay_outside_it() -> None:
    """The lens's polynomial would fold them back in; they are projected without it."""
    config = load_config(PERSPECTIVE)
    camera = camera_geometry(config.calibration, config.camera)
    assert isinstance(camera, PerspectiveCamera)
    far = np.array([[0.0, 0.0, 0.0], [-80.0, 45.0, 0.0], [80.0, 45.0, 0.0], [0.0, 150.0, 0.0]])
    px = project_in_view(camera, far)
    w, h = camera.size_px
    outside = (px[:, 0] < 0) | (px[:, 0] >= w) | (px[:, 1] < 0) | (px[:, 1] >= h)
    assert outside.all(), px
    near = np.array([[0.0, 45.0, 0.0]])
    assert np.allclose(project_in_view(camera, near), camera.project(near))


def test_no_mask_without_a_perspective_calibration() -> None:
    """A homography knows the table's plane only: no arm mask is made."""
    config = load_config(ROOT / "configs" / "sim_mujoco.yaml")
    model = ArmModel(config.arm)
    geometry = camera_geometry(config.calibration, config.camera)
    bodies = collision_model(config, model).bodies
    assert arm_view(geometry, model, bodies, opening_cm=1.0) is None


def test_an_exclude_mask_of_another_size_is_refused(arm_over_table) -> None:
    config, _, frame, _ = arm_over_table
    with pytest.raises(ImageError, match="exclude"):
        _detector(config).detect(frame, exclude=np.zeros((10, 10), np.uint8))


def test_the_work_area_is_the_calibrated_table_by_default(arm_over_table) -> None:
    """Perspective and no polygon: the table's outline; a homography or a polygon: as given."""
    config, _, frame, _ = arm_over_table
    area = _detector(config).work_area(frame.shape)
    assert area is not None
    camera = camera_geometry(config.calibration, config.camera)
    objects = camera.table_to_pixel(np.array([[o.x, o.y] for o in config.task.scene]))
    assert all(area[int(v), int(u)] == 255 for u, v in objects)
    base = camera.project(np.zeros((1, 3)))[0]  # the arm's base: off the table's field
    assert not (0 <= base[0] < frame.shape[1] and 0 <= base[1] < frame.shape[0]) or (
        area[int(base[1]), int(base[0])] == 0
    )
    assert area[2, 2] == 0  # the room beyond the table
    given = config.vision.model_copy(update={"work_area_px": [(0, 0), (50, 0), (50, 50)]})
    mine = ColorDetector.from_config(
        given, config.calibration, config.camera, config.task.classes
    ).work_area(frame.shape)
    assert mine is not None and int(mine.sum()) < int(area.sum()) and mine[10, 30] == 255
    flat = load_config(ROOT / "configs" / "sim_mujoco.yaml")
    assert _detector(flat).work_area(frame.shape) is None
