"""The camera sees the claw's marker, and what it sees fits the servos (real MuJoCo, OpenCV)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.config.errors import CalibrationError
from mearm.ik import IKTarget
from mearm.kinematics import ArmModel
from mearm.kinematics.bodies import MARKER_PLATE_M
from mearm.task.claw_fit import ClawCamera, Sighting
from mearm.task.claw_loop import ClawEye, CorrectionMap, claw_eye
from mearm.task.execute import Executor
from mearm.task.plan import Planner
from mearm.task.rig import open_rig
from mearm.task.route import Route
from mearm.vision.calibration import camera_geometry
from mearm.vision.claw_marker import check_marker, find_claw_marker

PERSPECTIVE = ROOT / "configs" / "sim_mujoco_perspective.yaml"
KITS = ROOT / "configs" / "sim_mujoco_kits.yaml"
#: TCP points over the table the camera sees the claw at (paper arm) [cm].
POINTS = [
    (x, y, z)
    for x, y, z in [
        (-8, 40, 19), (4, 44, 22), (10, 38, 19), (-4, 50, 24),
        (8, 52, 20), (-12, 46, 21), (0, 36, 23), (12, 46, 25),
    ]
]  # fmt: skip


def _at(rig, config, point):
    """Plan and stream the TCP to ``point`` as the sort does, coming down from 3 cm above
    it (every look then follows the same final move). Returns the commanded joints."""
    planner = Planner(config, rig.model)
    ex = Executor(config, rig.bus, rig.model, None)
    x, y, z = point
    for target in ((x, y, z + 3.0), (x, y, z)):
        route = Route("", "", "approach", 1, IKTarget(target))
        assert planner.plan(route, ex.q_now()).planned, route.failure
        ex.stream(route, "travel", closed=False)
    rig.bus.hold(0.3)
    return ex.q_now()


def _true_marker_cm(bus):
    """The marker's face centre in the twin: its plate's centre, half the plate up [cm]."""
    gid = mujoco.mj_name2id(bus.model, mujoco.mjtObj.mjOBJ_GEOM, "claw_marker_plate")
    normal = bus.data.geom_xmat[gid].reshape(3, 3)[:, 2]
    return (bus.data.geom_xpos[gid] + normal * MARKER_PLATE_M / 2) * 100.0


def test_the_claw_marker_is_seen_where_the_twin_has_it():
    config = load_config(PERSPECTIVE)
    camera = camera_geometry(config.calibration, config.camera)
    with open_rig(config) as rig:
        rig.bus.connect()
        eye = claw_eye(config, rig.model, camera, rig.camera.read, rig.bus.hold)
        assert eye is not None
        errors = []
        for point in POINTS[:4]:
            q = _at(rig, config, point)
            look = eye.look(q)
            assert look is not None, point
            seen = eye.planned_cm(q) + look.error_cm
            errors.append(np.linalg.norm(seen[:2] - _true_marker_cm(rig.bus)[:2]))
    # the calibrated camera (0.03 cm on the table) sees the marker 20-30 cm above it to
    # about a millimetre (0.04-0.15 cm measured)
    assert max(errors) < 0.25, errors
    assert len(eye.heights.places_cm) == 4  # each look's height kept for the next ones


def test_a_looks_ray_is_met_at_the_height_the_looks_nearby_saw():
    """One look's height (the marker's apparent size) is off by up to 1.6 cm, the claw's
    own by a few millimetres that vary smoothly over the table: the ray is met at the
    mean of the heights the looks within 12 cm saw, the kinematics weighing as one."""
    config = load_config(PERSPECTIVE)
    camera = camera_geometry(config.calibration, config.camera)
    eye = ClawEye(config, ArmModel(config.arm), camera, read=lambda: None, hold=lambda s: None)
    here = np.array([0.0, 40.0, 20.0])
    assert eye._height_error_cm(here, 1.2) == pytest.approx(0.6)  # alone: half of it
    eye.heights.add(here + [5.0, 0.0, 0.0], [0.3])
    eye.heights.add(here + [0.0, -11.0, 0.0], [-0.3])
    eye.heights.add(here + [12.5, 0.0, 0.0], [9.0])  # too far to weigh in
    assert eye._height_error_cm(here, 1.2) == pytest.approx((1.2 + 0.3 - 0.3) / 4)


def test_no_eye_without_a_marker_a_perspective_camera_or_the_wish():
    config = load_config(PERSPECTIVE)
    camera = camera_geometry(config.calibration, config.camera)
    model = None  # not needed for the refusals

    def eye(c, geometry=camera):
        return claw_eye(c, model, geometry, lambda: None, lambda s: None)

    no_marker = config.model_copy(
        update={"arm": config.arm.model_copy(
            update={"tool": config.arm.tool.model_copy(update={"marker": None})})}
    )  # fmt: skip
    assert eye(no_marker) is None
    assert (
        eye(
            load_config(ROOT / "configs" / "sim_mujoco.yaml"),
            camera_geometry(
                (mj := load_config(ROOT / "configs" / "sim_mujoco.yaml")).calibration, mj.camera
            ),
        )
        is None
    )  # a homography: no
    off = config.model_copy(update={"task": config.task.model_copy(update={"look_at_claw": False})})
    assert eye(off) is None


def test_a_marker_id_outside_its_dictionary_is_refused():
    config = load_config(PERSPECTIVE, ["arm.tool.marker.id=60"])
    with pytest.raises(CalibrationError, match="not in DICT_4X4_50"):
        check_marker(config.arm.tool.marker)


def test_the_fit_recovers_a_kits_servos_from_what_the_camera_sees():
    # servos as published (spread 1): zeros off by up to 2 deg, scales 8.1-11.5 us/deg
    config = load_config(
        PERSPECTIVE, ["twin.kit.seed=11", "twin.kit.spread=1", "twin.kit.per_trial=false"]
    )
    camera = camera_geometry(config.calibration, config.camera)
    from mearm.config.servo_models import servo_named
    from mearm.kinematics.bodies import marker_in_tcp

    face = marker_in_tcp(config.arm, servo_named(config.twin.gripper_servo))
    with open_rig(config) as rig:
        rig.bus.connect()
        smap = rig.bus.servo_map
        cc = ClawCamera(rig.model, smap, face, config.arm.tool.marker.size_cm, camera)
        sightings, actual = [], []
        for point in POINTS:
            pose = rig.model.chain.named_actuated(_at(rig, config, point))
            seen = find_claw_marker(rig.camera.read(), config.arm.tool.marker, camera)
            if seen is None:
                continue
            pulses = {j.name: j.pulse_us(j.servo_value(pose)) for j in smap.joints}
            sightings.append(Sighting(pulses, seen.corners_px))
            actual.append(_true_marker_cm(rig.bus))
    assert len(sightings) >= 6
    fit = cc.fit(sightings, scales=True)
    before = [np.linalg.norm(cc.centre_cm(cc.joints(s.pulses_us, cc.start())) - a)
              for s, a in zip(sightings, actual, strict=True)]  # fmt: skip
    params = cc.params_of(fit.servos)
    after = [np.linalg.norm(cc.centre_cm(cc.joints(s.pulses_us, params)) - a)
             for s, a in zip(sightings, actual, strict=True)]  # fmt: skip
    # the nominal calibration puts the claw centimetres off; the fit, within the play
    assert np.mean(before) > 0.5, before
    assert np.mean(after) < 0.35 * np.mean(before), (before, after)
    start = np.sqrt(np.mean(cc.residuals(sightings, cc.start()) ** 2) * 2)
    assert fit.rms_px < 0.5 * start, (fit.rms_px, start)


def test_the_correction_map_starts_a_pick_from_its_neighbours():
    m = CorrectionMap()
    assert np.array_equal(m.guess(np.array([0.0, 40.0])), np.zeros(2))
    m.add(np.array([0.0, 40.0]), np.array([0.4, -0.2]))
    m.add(np.array([30.0, 40.0]), np.array([-1.0, 1.0]))
    near = m.guess(np.array([1.0, 40.0]))
    assert np.allclose(near, [0.4, -0.2], atol=1e-9)  # the far one is out of the neighbourhood
    assert np.array_equal(m.guess(np.array([-40.0, 0.0])), np.zeros(2))


def _pick_errors_cm(look: bool) -> tuple[np.ndarray, int]:
    """Table-plane errors of the TCP at each grip against the object, and objects sorted.

    One object per class: blind, the kit's claw misses each by about a centimetre already
    (with 5 objects the means were 1.10 cm blind, 0.16 cm looking; with 3, 1.02 and 0.11).
    """
    from mearm.task.scene import random_scene
    from mearm.task.sorter import Sorter

    config = load_config(
        KITS, ["twin.kit.spread=0.3", "twin.kit.per_trial=false", f"task.look_at_claw={look}"]
    )
    scene = random_scene(config, 3, seed=4)
    with open_rig(config, scene) as rig:
        sorter = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None,
                        in_bins=rig.in_bins)  # fmt: skip
        report = sorter.run()
    picks = [r for r in report.routes if r.step == "pick" and r.executed]
    xy = [np.linalg.norm(r.ee_cm[:2] - r.target.position[:2]) for r in picks]
    return np.array(xy), report.outcome.n_sorted


@pytest.mark.slow
def test_picks_that_look_put_the_claw_on_the_object():
    # a kit at 0.3 of the published spread: the claw misses by most of a centimetre
    blind, sorted_blind = _pick_errors_cm(look=False)
    looking, sorted_looking = _pick_errors_cm(look=True)
    assert np.mean(blind) > 0.4, blind
    assert np.mean(looking) < 0.5 * np.mean(blind), (looking, blind)
    assert sorted_looking >= sorted_blind
