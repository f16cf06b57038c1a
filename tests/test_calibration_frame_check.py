"""The servos' calibration by the camera at the start of a sort checks its frames: a
black frame or a frozen stream is named as the camera's fault, not blamed on the fit;
the sort's first look after it is checked against its last frame (real MuJoCo, OpenCV;
simulated).

configs/sim_mujoco_kits.yaml's calibration reads the camera at 0.34 s (the table, from
home), then at each point it visits (1.02, 1.54, 2.06 s, ...).
"""

from __future__ import annotations

import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.kinematics.model import ArmModel
from mearm.runlog import read_runlog
from mearm.sort import main as sort_main
from mearm.task.rig import open_rig
from mearm.task.sorter import SortAborted, Sorter

pytestmark = pytest.mark.heavy

KITS = ROOT / "configs" / "sim_mujoco_kits.yaml"
PERSPECTIVE = ROOT / "configs" / "sim_mujoco_perspective.yaml"
SCENE = "task.scene=[{color: red, x: -5, y: 45}, {color: green, x: 6, y: 50}]"


@pytest.mark.parametrize(
    ("fault", "reason", "before"),
    [
        # the marker seen where the arm was: "the fit does not converge: ... the marker
        # is not where the arm puts it"
        ("{kind: camera_frozen, at_s: 2.0}", "camera (twin): the stream froze", "fit"),
        # the marker seen nowhere: "the marker on the claw is not in view ... check that
        # it faces the camera"
        ("{kind: camera_black, at_s: 1.0}", "camera (twin): the frame is black", "in view"),
    ],
    ids=["frozen", "black"],
)
def test_a_camera_fault_in_the_calibration_at_the_start_names_the_camera(
    fault, reason, before, tmp_path, capsys
):
    log = tmp_path / "run.jsonl"
    code = sort_main(
        ["--config", str(KITS), "--set", SCENE, "--set", f"twin.faults=[{fault}]",
         "--log", str(log), "--quiet"]
    )  # fmt: skip
    err = capsys.readouterr().err
    assert code == 1
    (trial,) = read_runlog(log, strict=True).trials
    assert trial.complete and trial.summary is not None and not trial.summary.ok
    (stop,) = trial.faults
    assert stop.reason.startswith("the servos' calibration by the camera: "), stop.reason
    assert reason in stop.reason, stop.reason
    assert before not in stop.reason and "not where the arm puts it" not in stop.reason
    assert stop.reason.startswith(f"the servos' calibration by the camera: {reason}")
    # the calibration parked the arm before it gave up: the line says so, not that the
    # servos were left where they were
    assert stop.reason.endswith("; arm parked at home"), stop.reason
    home = ArmModel(load_config(KITS).arm)
    assert stop.last_joints == pytest.approx(home.chain.named(home.home), abs=0.01)
    assert reason in err
    assert trial.routes == ()


def test_the_first_look_after_the_calibration_is_checked_against_its_last_frame():
    """A stream that froze after the calibration's last look gives that frame (the arm
    where the calibration left it) to the sort's first look: refused there, before the
    sort goes for an object, not at the first look at the claw."""
    config = load_config(
        PERSPECTIVE,
        [SCENE, "servo.calibrate_at_start=when_uncalibrated",
         "twin.faults=[{kind: camera_frozen, at_s: 0.3}]"],
    )  # fmt: skip
    read_at: list[float] = []

    def calibrate_first(config, camera, bus, model, *, simulated):
        """A calibration's looks: a frame read, then the arm parked (time goes on)."""
        bus.hold(0.1)
        camera.read()
        read_at.append(camera.frame_time_s)
        bus.hold(0.5)  # the stream freezes meanwhile (0.3 s)
        return config, []

    with open_rig(config) as rig:
        sorter = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None,
                        in_bins=rig.in_bins, calibrate_first=calibrate_first)  # fmt: skip
        with pytest.raises(SortAborted, match="the stream froze") as e:
            sorter.run()
    (t,) = read_at
    assert t < 0.3
    assert f"this frame was taken at {t:.3f} s" in e.value.reason
    assert sorter._active is None, "the sort went for an object on the stale frame"
    assert sorter.executor.motion.arm_s == 0.0  # the arm never left home
