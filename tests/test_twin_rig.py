"""The physical twin behind the rig (``simulator: mujoco``): one MuJoCo scene drives the
servo bus and renders the camera the detector reads."""

from __future__ import annotations

import numpy as np
import pytest
from badinput import check_bad_input
from conftest import ROOT

from mearm.config import SceneObject, load_config
from mearm.task.rig import open_rig
from mearm.vision import Calibration, ColorDetector

TWIN_5DOF = ["simulator=mujoco"]


@pytest.fixture(scope="module")
def config():
    return load_config(ROOT / "configs" / "sim_5dof.yaml", TWIN_5DOF)


def test_the_twin_camera_shows_the_scene_where_it_lies(config):
    """The rendered frame, read by the detector through the calibration, puts every
    object within 0.5 cm of where the physics has it; nothing else is taken for one."""
    with open_rig(config) as rig:
        frame = rig.camera.read()
        assert frame.shape == (config.camera.height_px, config.camera.width_px, 3)
        detector = ColorDetector(config.vision, Calibration.from_config(config.calibration),
                                 config.task.classes)  # fmt: skip
        found = detector.detect(frame)
        cm = Calibration.from_config(config.calibration).pixel_to_table(
            np.array([d.centroid_px for d in found])
        )
        assert len(found) == len(config.task.scene)
        for obj in config.task.scene:
            d = [np.hypot(x - obj.x, y - obj.y) for det, (x, y) in zip(found, cm, strict=True)
                 if det.color == obj.color]  # fmt: skip
            assert d and min(d) < 0.5, (obj, d)
        assert rig.in_bins is not None and sum(rig.in_bins().values()) == 0


def test_hold_lets_the_twin_run_its_physics(config):
    """A tool setting is given time to take effect: the bus's hold runs the twin."""
    with open_rig(config) as rig:
        bus = rig.bus
        bus.connect()
        t0 = bus.time_s
        bus.hold(0.3)
        assert bus.time_s == pytest.approx(t0 + 0.3, abs=2e-3)


def test_a_class_bin_footprint():
    cls = load_config(None).task.class_named("red")
    x, y, _ = cls.bin_cm
    half = cls.bin_inner_width_cm / 2
    assert cls.bin_inner_width_cm == 3 * cls.diameter_cm
    assert cls.in_bin(x + half - 0.01, y) and not cls.in_bin(x + half + 0.01, y)


def test_an_object_seen_inside_a_bin_is_not_on_the_table():
    """A camera that sees the bins does not take what lies in one for an object to pick.

    (A scene given to ``mearm sort`` may not put one there: check_scene refuses it; an
    object lands in a bin while the sort runs, so the sorter is given one directly.)
    """
    from mearm.task import run_sort

    config = load_config(None)
    red = config.task.class_named("red")
    scene = [SceneObject(color="green", x=red.bin_cm[0] + 0.5, y=red.bin_cm[1]),
             SceneObject(color="red", x=-5.0, y=40.0)]  # fmt: skip
    report = run_sort(config, scene=scene, echo=None)
    assert report.complete
    assert report.outcome.line() == "sorted 1 of 1 objects"


@pytest.mark.bad_input
def test_the_twin_needs_both_servos_and_camera_simulated():
    out = check_bad_input(["sort", "--set", "simulator=mujoco", "--set", "servo.backend=serial"])
    assert "simulator" in out.line and "servo.backend: sim" in out.line


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "n"), [("sim_mujoco", 12), ("sim_5dof_mujoco", 9), ("sim_mearm_v1_mujoco", 6)]
)
def test_the_scene_is_sorted_physically(capsys, tmp_path, name, n):
    """configs/sim_mujoco.yaml (the paper's arm and scene), sim_5dof_mujoco.yaml and
    sim_mearm_v1_mujoco.yaml (the MeArm, its claw forward and level): every object
    grasped, carried and resting in its class's bin in the physics; the run says so and
    exits 0."""
    from mearm.runlog import read_runlog
    from mearm.sim.twin import twin_bus
    from mearm.sort import main

    arms: list[twin_bus.TwinArm] = []
    real_init = twin_bus.TwinArm.__init__

    def spying_init(self, *args, **kwargs):
        real_init(self, *args, **kwargs)
        arms.append(self)

    log = tmp_path / "run.jsonl"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(twin_bus.TwinArm, "__init__", spying_init)
        code = main(["--config", str(ROOT / "configs" / f"{name}.yaml"), "--quiet",
                     "--log", str(log)])  # fmt: skip
    lines = capsys.readouterr().out.splitlines()
    assert code == 0 and lines[-1] == f"sorted {n} of {n} objects (simulated)"
    twin = arms[-1]
    in_bins = twin.objects_in_bin()
    assert sorted(in_bins) == sorted(twin.object_ids)
    assert all(oid.rstrip("0123456789") == cls for oid, cls in in_bins.items())
    summary = read_runlog(log).trials[-1].summary
    assert summary is not None and sum(summary.sorted.values()) == n and summary.left == {}


def test_a_pick_whose_jaws_would_land_on_a_neighbour_waits(tmp_path):
    """Two objects closer than the open jaws' reach: the sorter first takes an object
    whose jaws come down clear (here a red one farther from the arm), then the others."""
    from mearm.task.rig import run_sort

    config = load_config(None)
    g = config.arm.tool.gripper
    reach = g.open_cm / 2 + g.jaw_thickness_cm + 1.0  # a 2 cm object's radius
    scene = [SceneObject(color="red", x=0.0, y=45.0),
             SceneObject(color="green", x=reach - 0.3, y=45.0),  # under the open jaws
             SceneObject(color="red", x=10.0, y=55.0)]  # fmt: skip
    report = run_sort(config, scene=scene, echo=None)
    picks = [r for r in report.routes if r.step == "pick"]
    assert [(r.class_name, round(float(r.target.position_cm[0]))) for r in picks] == [
        ("red", 10),
        ("red", 0),
        ("green", round(reach - 0.3)),
    ]
    assert report.complete
