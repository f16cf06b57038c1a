"""The looks at the claw pass the table's frame check: a black frame or a frozen stream
stops the sort as a camera fault, never a pick judged on a stale frame (real MuJoCo,
OpenCV; simulated).

The scene is one object under the twin's perspective camera (configs/
sim_mujoco_perspective.yaml, picks that look at the claw): the table is read at 0.02 s,
the claw at 0.43, 0.80, 1.29 and 1.78 s as the jaws come down, and the table again at
3.36 s with the arm over the bin, where the grip is judged.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROOT

from mearm.runlog import read_runlog
from mearm.sort import main as sort_main
from mearm.task.pick_place import PICK_MISSED
from mearm.vision.camera import Camera
from mearm.vision.errors import CameraError
from mearm.vision.frame_check import FrameCheck

pytestmark = pytest.mark.heavy

CONFIG = ROOT / "configs" / "sim_mujoco_perspective.yaml"
SCENE = "task.scene=[{color: red, x: -5, y: 45}]"
PARKED = "; arm parked at home"


def _sort_with(fault: str, tmp_path, capsys):
    """Sort the object with one fault; (exit code, stderr, the run log's one trial)."""
    log = tmp_path / "run.jsonl"
    code = sort_main(
        ["--config", str(CONFIG), "--set", SCENE, "--set", f"twin.faults=[{fault}]",
         "--log", str(log), "--quiet"]
    )  # fmt: skip
    err = capsys.readouterr().err
    (trial,) = read_runlog(log, strict=True).trials
    assert trial.complete, "the log ends with its summary"
    return code, err, trial


@pytest.mark.parametrize(
    ("fault", "reason", "picks"),
    [
        # froze after the claw's last look: the look over the bin got that frame again
        # (the object on its spot, the jaws about to close): "FAILED: the camera still
        # sees it" though the grip held
        ("{kind: camera_frozen, at_s: 2.0}", "camera (twin): the stream froze", 1),
        # froze between two looks at the claw: the second saw the claw where it was
        ("{kind: camera_frozen, at_s: 1.0}", "camera (twin): the stream froze", 0),
        # black at a look at the claw: no marker seen, and the jaws closed unaimed
        ("{kind: camera_black, at_s: 1.0}", "camera (twin): the frame is black", 0),
    ],
    ids=["frozen-after-the-looks", "frozen-between-looks", "black-at-a-look"],
)
def test_a_camera_fault_at_the_claws_looks_stops_the_sort(fault, reason, picks, tmp_path, capsys):
    code, err, trial = _sort_with(fault, tmp_path, capsys)
    assert code == 1
    (stop,) = trial.faults
    assert reason in stop.reason and stop.reason.endswith(PARKED), stop.reason
    assert f"mearm sort: stopped: {reason}" in err
    assert trial.summary is not None and not trial.summary.ok
    assert all(r.why_failed != PICK_MISSED for r in trial.routes), trial.routes
    # stopped at the look that read the bad frame: a pick made is never confirmed
    assert len(trial.routes) == picks
    assert all(r.step == "pick" and not r.confirmed for r in trial.routes)


class _Frames(Camera):
    """Frames of one grey level, each taken at the time set before it is read."""

    def __init__(self) -> None:
        super().__init__("test", (64, 48))
        self.now_s = 0.0
        self.frozen = False

    def _read(self) -> np.ndarray:
        if not self.frozen:
            self.frame_time_s = self.now_s
        return np.full((48, 64, 3), 40, np.uint8)

    @property
    def clock_s(self) -> float:
        return self.now_s


def test_a_read_counts_the_frame_read_past_the_check_before():
    """A frame read past the check (another part's) is the one a stream that froze since
    gives again: the next read through the check is refused, not taken for a new one."""
    camera, check = _Frames(), FrameCheck("test")
    camera.now_s = 1.0
    check.read(camera)
    camera.now_s = 2.0
    camera.read()  # past the check
    camera.frozen, camera.now_s = True, 3.0
    with pytest.raises(CameraError, match="the stream froze: this frame was taken at 2.000 s"):
        check.read(camera)
    check = FrameCheck("test")
    check.after(3.0)  # a frame taken at 3 s was read elsewhere
    camera.now_s = 3.5
    with pytest.raises(CameraError, match="the stream froze"):
        check.read(camera)
    camera.frozen, camera.now_s = False, 4.0
    check.read(camera)  # a new frame
    check.read(camera)  # read again at the same instant: the same frame, not frozen
