"""After the servos' calibration at the start, the arm goes home the checked way.

``servo.calibrate_at_start`` calibrates the servos by the camera, the arm parked at home
as the calibration had it; with the fit, home is a degree or two away, and until
2026-12-07 the sort and ``mearm check-camera`` went there along the straight line in
joint space unchecked. A calibration that left the arm short of home (seen once on the
kit twin, beside a large red bin) had the jaws taken through a bin's wall. Now both go
home as the sort parks (:func:`mearm.task.homing.go_home`): the straight line where it is
clear, else up first. Here the calibration leaves the arm low beside the green bin, where
the straight line home drives the jaws' pads 0.5 cm into its wall.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from checked_commands import watch_streams
from conftest import ROOT

from mearm.config import Config, SceneObject, load_config
from mearm.ik.target import IKTarget
from mearm.kinematics import ArmModel
from mearm.kinematics.collision import TOUCH_M
from mearm.sim.table_collision import collision_model
from mearm.task import armcheck
from mearm.task.execute import Executor
from mearm.task.plan import Planner
from mearm.task.rig import open_rig
from mearm.task.route import Route
from mearm.task.sorter import Sorter
from mearm.vision import ColorDetector

KITS = ROOT / "configs" / "sim_mujoco_kits.yaml"
#: Where the calibration leaves the TCP [cm]: low beside the green bin, the straight line
#: home from there through its wall (``bin_green_wall_px``).
LEFT_AT_CM = (-14.6, 48.4, 12.7)


def _config() -> Config:
    return load_config(KITS, ["twin.kit.per_trial=false", "twin.kit.seed=5"])


def _world(config: Config, model: ArmModel) -> Any:
    """The bins and the table, the jaws open: what the arm keeps clear of before a look."""
    col = collision_model(config, model, clearance_cm=config.task.clearance_cm)
    col.set_world([], opening_cm=config.arm.tool.gripper.open_cm)
    return col


def _leaves_the_arm_short(sent: list[np.ndarray]) -> Callable[..., Any]:
    """A calibration that parks short of home, at :data:`LEFT_AT_CM` (a checked route
    there), keeps the nominal calibration, and has every later command recorded."""

    def calibrate(config, camera, bus, model, *, simulated):  # noqa: ANN001, ANN202
        col = _world(config, model)
        planner = Planner(config, model, col)
        ex = Executor(config, bus, model, collision=col)
        route = Route("", "", "home", 1, IKTarget(LEFT_AT_CM, config.arm.tool.pick_approach))
        assert planner.plan(route, ex.q_now()).planned, route.failure
        ex.stream(route, "travel", closed=False)
        straight = col.first_contact(ex.joint_path(model.home))
        assert straight is not None and "bin_green_wall" in straight.obstacle, straight
        move = bus.move

        def recorded(command, *args, **kwargs):  # noqa: ANN001, ANN202
            sent.append(model.chain.from_named(command.joints))
            return move(command, *args, **kwargs)

        bus.move = recorded
        return config, ["calibrated (a test's calibration: parked short of home)"]

    return calibrate


def _kept_clear(config: Config, sent: list[np.ndarray]) -> None:
    model = ArmModel(config.arm)
    col = _world(config, model)
    assert sent, "nothing was sent after the calibration"
    assert np.allclose(sent[-1], model.home, atol=1e-6), "the arm did not end at home"
    gaps = [col.gap(q)[0] for q in sent]
    worst = int(np.argmin(gaps))
    assert gaps[worst] > -TOUCH_M, (
        f"command {worst} of {len(sent)} comes within the clearance: {col.gap(sent[worst])}"
    )


@pytest.mark.heavy
def test_the_sort_goes_home_the_checked_way_after_calibrating() -> None:
    config = _config()
    sent: list[np.ndarray] = []
    scene = [SceneObject(color="red", x=10.0, y=40.0)]
    with open_rig(config, scene) as rig:
        calibrate = _leaves_the_arm_short(sent)
        sorter = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None,
                        in_bins=rig.in_bins, calibrate_first=calibrate)  # fmt: skip
        sorter.executor.home_pose()
        sorter._calibrate_by_camera()
    _kept_clear(config, sent)


@pytest.mark.heavy
def test_check_camera_goes_home_the_checked_way_after_calibrating() -> None:
    config = _config()
    sent: list[np.ndarray] = []
    with open_rig(config, []) as rig:
        geometry = armcheck.camera_geometry(config.calibration, config.camera)
        detector = ColorDetector(config.vision, geometry, config.task.classes)
        # an empty table: the check stops at its first look, after the way home
        with pytest.raises(armcheck.NothingToCheck):
            armcheck._check(
                config, rig, geometry, detector, points=4, class_name=None, refine=False,
                calibrate_first=_leaves_the_arm_short(sent), say=lambda _line: None,
            )  # fmt: skip
    _kept_clear(config, sent)


def test_check_camera_checks_each_route_as_the_servos_follow_it(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Every route ``check-camera`` streams is sent as commands whose chords were checked.

    Between two commands the servos move on the chord between them, a little off the
    plan's polyline: the sort checks the commands themselves (:meth:`Executor.followed
    <mearm.task.execute.Executor.followed>`); until 2026-12-07 the check's executor had
    no collision model and sent them unchecked.
    """
    from mearm.tools.check_camera import main

    watch = watch_streams(monkeypatch)
    code = main(["--config", str(ROOT / "configs" / "sim.yaml"), "--points", "2"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert len(watch.streamed) >= 2 * 6, out  # each point: above, down, up, across, down, up
    unchecked = watch.unchecked()
    assert not unchecked, f"routes {unchecked} of {len(watch.streamed)} were sent unchecked"
