"""A sort whose servos were never calibrated calibrates them by the camera first.

``servo.calibrate_at_start: when_uncalibrated`` (configs/sim_mujoco_kits.yaml): the twin's
kit, objects on the table, the procedure of ``mearm calibrate-servos --camera`` before the
first pick, and the sort with its fit.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from badinput import ROOT, check_bad_input

from mearm.config import Config, load_config
from mearm.config.servo_file import load_servo_calibration
from mearm.kinematics.bodies import object_name
from mearm.maker.camera_calibration import session as session_module
from mearm.maker.camera_calibration.at_start import calibrator, floor_cm
from mearm.sim.twin.twin_bus import TwinArm
from mearm.task.rig import open_rig
from mearm.task.scene import random_scene
from mearm.task.sorter import SortAborted, Sorter

KITS = ROOT / "configs" / "sim_mujoco_kits.yaml"
KIT = ["twin.kit.per_trial=false", "twin.kit.seed=5"]


class ObjectWatch:
    """Every 5 ms of the twin's time: the arm's contacts with the objects, their distance.

    The arm is every geom of a body below ``base_link`` that a joint moves; the objects,
    the scene's bodies.
    """

    def __init__(self, bus: TwinArm):
        m = bus.model
        root = m.body("base_link").id
        bodies = {m.body(object_name(i)).id for i in bus.object_ids}
        self.objects = [g for g in range(m.ngeom) if m.geom_bodyid[g] in bodies]
        self.arm = [
            g
            for g in range(m.ngeom)
            if m.body_rootid[m.geom_bodyid[g]] == root and m.body_weldid[m.geom_bodyid[g]]
        ]
        self.touches: list[tuple[str, str]] = []
        self.closest_cm = np.inf
        self._due = 0.0

    @property
    def due_s(self) -> float:
        return self._due

    def sample(self, bus: TwinArm) -> None:
        m, d = bus.model, bus.data
        arm, objects = set(self.arm), set(self.objects)
        for c in d.contact[: d.ncon]:
            pair = {int(c.geom1), int(c.geom2)}
            if pair & arm and pair & objects:
                self.touches.append((m.geom(c.geom1).name, m.geom(c.geom2).name))
        ft = np.zeros(6)
        for g in self.arm:
            for o in self.objects:
                dist = mujoco.mj_geomDistance(m, d, g, o, 0.05, ft) * 100.0
                self.closest_cm = min(self.closest_cm, dist)
        self._due = d.time + 0.005


def _config(*sets: str) -> Config:
    return load_config(KITS, [*KIT, *sets])


@pytest.mark.slow
def test_an_uncalibrated_kit_calibrates_clear_of_the_objects_then_sorts(tmp_path: Path) -> None:
    """The calibration moves over the objects without touching one, then the sort clears
    the table with its fit; the file written is the calibrate-servos file."""
    config = _config()
    scene = random_scene(config, 4, seed=11)
    out = tmp_path / "kit.servos.yaml"
    lines: list[str] = []
    watched: dict[str, object] = {}
    calibrate = calibrator(out)

    def watched_calibration(config, camera, bus, model, *, simulated):
        watch = ObjectWatch(bus)
        before = {i: bus.object_pose(i).position_cm for i in bus.object_ids}
        bus.sampler = watch
        try:
            result = calibrate(config, camera, bus, model, simulated=simulated)
        finally:
            bus.sampler = None
        moved = {i: float(np.linalg.norm(bus.object_pose(i).position_cm - p))
                 for i, p in before.items()}  # fmt: skip
        watched.update(watch=watch, moved=moved, clock_s=bus.clock_s)
        return result

    with open_rig(config, scene) as rig:
        sorter = Sorter(
            config, rig.camera, rig.bus, model=rig.model, echo=lines.append,
            in_bins=rig.in_bins, calibrate_first=watched_calibration,
        )  # fmt: skip
        report = sorter.run()
    watch = watched["watch"]
    assert isinstance(watch, ObjectWatch) and len(watch.objects) >= 4
    assert watch.touches == [], watch.touches[:5]
    # the tool stays floor_cm above the table within the doubt, the objects 1 cm high
    assert watch.closest_cm > 1.0, watch.closest_cm
    assert max(watched["moved"].values()) < 0.05, watched["moved"]  # type: ignore[union-attr]
    assert watched["clock_s"] <= 180.0  # type: ignore[operator]
    (said,) = [ln for ln in lines if ln.startswith("servos calibrated by the camera")]
    assert "rms" in said and "s of arm motion" in said
    assert f"wrote {out}" in lines
    assert sorter.config.servo.calibration_file is None  # kept in memory
    assert sorter.config.arm != config.arm  # the fit, not the nominal calibration
    assert {a.name for a in load_servo_calibration(out).actuators} == {
        "base", "shoulder", "elbow"}  # fmt: skip
    assert report.complete and report.outcome.n_sorted == 4, lines[-6:]


def test_the_floor_is_above_every_object() -> None:
    config = _config()
    assert floor_cm(config) == pytest.approx(max(c.height_cm for c in config.task.classes) + 1.0)


@pytest.mark.heavy
def test_a_fit_that_cannot_be_made_stops_the_sort_before_its_first_pick(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The marker never found (covered, say): exit 1, one line, nothing picked."""
    monkeypatch.setattr(session_module, "find_claw_marker", lambda *_args: None)
    config = _config()
    with open_rig(config, random_scene(config, 2, seed=1)) as rig:
        sorter = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None,
                        in_bins=rig.in_bins, calibrate_first=calibrator())  # fmt: skip
        with pytest.raises(SortAborted) as e:
            sorter.run()
        assert rig.bus.state is not None
        home = config.arm.home()
        assert rig.bus.state.joints == pytest.approx({n: home[n] for n in rig.bus.state.joints})
    assert "calibration by the camera" in e.value.reason and "not in view" in e.value.reason
    assert "nothing sorted" in e.value.reason
    assert sorter.report.routes == []


@pytest.mark.bad_input
@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["--config", ROOT / "configs" / "sim.yaml", "--set",
          "servo.calibrate_at_start=when_uncalibrated"],
         "servo.calibrate_at_start: when_uncalibrated needs a perspective calibration"),
        (["--config", KITS, "--set", "arm.tool.marker=null"],
         "servo.calibrate_at_start: when_uncalibrated needs a marker on the claw"),
        (["--config", KITS, "--set", "servo.calibrate_at_start=sometimes"],
         "servo.calibrate_at_start"),
        (["--config", ROOT / "configs" / "sim_mujoco.yaml", "--save-calibration", "x.yaml"],
         "--save-calibration writes the calibration a sort makes at its start"),
    ],
)  # fmt: skip
def test_bad_input_exits_2_with_one_line_before_anything_moves(argv, said, tmp_path) -> None:
    result = check_bad_input(["sort", *argv], code=2, within_s=10, keep=[tmp_path])
    assert said in result.line, result.line


@pytest.mark.bad_input
def test_a_calibration_at_start_the_rig_cannot_run_names_the_config_file(tmp_path) -> None:
    """Said like every whole-config problem: after the file it came from."""
    config = ROOT / "configs" / "sim.yaml"
    argv = ["sort", "--config", config, "--set", "servo.calibrate_at_start=when_uncalibrated"]
    result = check_bad_input(argv, code=2, within_s=10, keep=[tmp_path])
    assert f"error: {config} with --set: servo.calibrate_at_start: " in result.line, result.line
