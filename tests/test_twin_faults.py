"""Faults injected into the physical twin (``twin.faults``): each ends the sort with a
named reason, the arm parked where it can be, exit 1 and a complete run log.

The scene is two objects (three for the bumped camera: a move of the view is told from
a jaw that caught an object by two objects moving alike); the first is picked from
0.02 s to about 1.6 s of simulated time, when the arm, over the red bin, looks again. A
fault at 0.5 s strikes on the way to the first pick, one at 1.0 s between the first look
and the second.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.errors import ConfigError
from mearm.runlog import read_runlog
from mearm.sim.errors import WorldError
from mearm.sim.twin.twin_bus import TwinArm
from mearm.sim.twin.twin_camera import TwinCamera
from mearm.sort import main as sort_main
from mearm.task.pick_place import PICK_EMPTY
from mearm.vision.errors import CameraError
from mearm.vision.frame_check import FrameCheck

pytestmark = pytest.mark.heavy

TWO = "{color: red, x: -5, y: 45}, {color: green, x: 6, y: 50}"
SCENE = f"task.scene=[{TWO}]"
THREE = f"task.scene=[{TWO}, {{color: blue, x: 8, y: 40}}]"
CONFIG = ROOT / "configs" / "sim_mujoco.yaml"
PARKED = "; arm parked at home"


def _sort_with(fault: str, tmp_path, capsys, scene: str = SCENE):
    """Sort the objects with one fault; (exit code, stderr, the run log's one trial)."""
    log = tmp_path / "run.jsonl"
    code = sort_main(
        ["--config", str(CONFIG), "--set", scene, "--set", f"twin.faults=[{fault}]",
         "--log", str(log), "--quiet"]
    )  # fmt: skip
    err = capsys.readouterr().err
    contents = read_runlog(log, strict=True)
    (trial,) = contents.trials
    assert trial.complete, "the log ends with its summary"
    return code, err, trial


def _stopped_by(contents, reason: str) -> str:
    """The one fault record's reason, which must name ``reason``; the summary says not ok."""
    (fault,) = contents.faults
    assert reason in fault.reason, fault.reason
    assert contents.summary is not None and not contents.summary.ok
    assert contents.header is not None
    assert fault.last_joints  # the last confirmed pose is kept
    return fault.reason


def test_a_servo_that_goes_limp_mid_route_stops_the_sort(tmp_path, capsys):
    """The shoulder's servo loses its torque on the way to the first pick: the joint sags,
    the bus reports the stall, nothing more is sent (a limp joint cannot be parked)."""
    code, err, contents = _sort_with("{kind: limp_servo, at_s: 0.5, joint: shoulder}",
                                     tmp_path, capsys)  # fmt: skip
    assert code == 1
    reason = _stopped_by(contents, "joint shoulder stalled")
    assert reason.endswith("nothing more sent to the servos")
    assert "mearm sort: stopped: joint shoulder stalled" in err


def test_an_object_knocked_off_the_table_is_left_with_its_reason(tmp_path, capsys):
    """The green object leaves the table while the red one is carried: the red one is
    sorted, the green one left as no longer in the work area, the arm goes home, exit 1."""
    code, err, contents = _sort_with("{kind: knock_object, at_s: 1.0, object: green1}",
                                     tmp_path, capsys)  # fmt: skip
    assert code == 1
    (skip,) = contents.skips
    assert skip.object_id == "green1" and "no longer in the work area" in skip.reason
    summary = contents.summary
    assert summary is not None
    assert summary.sorted["red"] == 1 and summary.left == {"off_table": 1}
    assert "(simulated; 1 no longer in the work area)" in err
    assert not contents.faults


def _knocked_at(at_s: float, tmp_path, capsys):
    """Sort the two objects with red1 knocked off the table at ``at_s``: it exits 1.
    Returns what it printed and its run log."""
    log = tmp_path / "run.jsonl"
    code = sort_main(
        ["--config", str(CONFIG), "--set", SCENE, "--set",
         f"twin.faults=[{{kind: knock_object, at_s: {at_s}, object: red1}}]", "--log", str(log)]
    )  # fmt: skip
    assert code == 1
    return capsys.readouterr().out, log


def test_a_pick_whose_jaws_closed_on_nothing_fails_and_the_object_is_left_with_its_reason(
    tmp_path, capsys
):
    """The red object leaves the table as the jaws come down on it (1.0 s): the camera over
    the bin sees it gone from its spot, but the twin's jaws closed on nothing, so the pick
    is FAILED, not ``ok`` (until 2026-12-07 it counted, and its place was FAILED), says
    so, and the red one is left as no longer in the work area."""
    out, log = _knocked_at(1.0, tmp_path, capsys)
    (trial,) = read_runlog(log, strict=True).trials
    red = [(r.step, r.success, r.confirmed) for r in trial.routes if r.object_id == "red1"]
    assert red == [("pick", False, True)]
    (pick,) = (line for line in out.splitlines() if line.startswith("pick  red1"))
    assert "FAILED" in pick and " ok " not in pick
    # the line and the log say why: the twin's jaws closed on nothing
    assert pick.endswith(f" ms: {PICK_EMPTY}")
    assert [r.why_failed for r in trial.routes if r.object_id == "red1"] == [PICK_EMPTY]
    (skip,) = trial.skips
    assert skip.object_id == "red1" and "no longer in the work area" in skip.reason
    assert trial.summary is not None
    assert trial.summary.sorted == {"red": 0, "green": 1, "blue": 0}
    assert trial.summary.left == {"off_table": 1}


def test_an_object_lost_after_the_grip_is_said_where_it_went(tmp_path, capsys):
    """Knocked out of the closed jaws on the way (1.4 s: after the grip; at 1.0 s the jaws
    close on nothing), the place says where the twin has the object it gripped."""
    out, log = _knocked_at(1.4, tmp_path, capsys)
    (place,) = (line for line in out.splitlines() if line.startswith("place red1"))
    # (knocked out of view, past the table's edge: the twin's table plane goes on)
    lost = "over the bin the jaws held nothing of its class: it was lost on the way and is "
    assert f" ms: {lost}past the table's edge, at (" in place, place
    (trial,) = read_runlog(log, strict=True).trials
    (why,) = [r.why_failed for r in trial.routes if r.object_id == "red1" and r.step == "place"]
    assert why is not None and why.startswith(lost) and why.endswith(") cm")
    # not seen from home, it is left, and the twin says where it went, not the camera's guesses
    (skip,) = trial.skips
    assert skip.object_id == "red1" and trial.summary is not None
    assert trial.summary.left == {"off_table": 1}
    gone = "not seen from home; lost from the jaws on the way to its bin, it is past the table's"
    assert gone in skip.reason and "knocked off the table" not in skip.reason, skip.reason


@pytest.mark.parametrize(
    ("fault", "reason"),
    [
        ("{kind: camera_black, at_s: 1.0}", "camera (twin): the frame is black"),
        ("{kind: camera_frozen, at_s: 1.0}", "camera (twin): the stream froze"),
        ("{kind: camera_bump, at_s: 1.0, shift_cm: [1, 0, 0]}", "camera (twin): the view moved"),
    ],
    ids=["black", "frozen", "bumped"],
)
def test_a_camera_fault_stops_the_sort_and_parks_the_arm(fault, reason, tmp_path, capsys):
    """A black frame, a frozen stream or a camera moved 1 cm, seen at the look over the
    bin: the sort stops with the camera named, the arm is parked at home, exit 1."""
    code, err, contents = _sort_with(fault, tmp_path, capsys, THREE if "bump" in fault else SCENE)
    assert code == 1
    text = _stopped_by(contents, reason)
    assert text.endswith(PARKED)
    assert f"mearm sort: stopped: {reason}" in err
    (pick,) = contents.routes  # the first pick, never confirmed: the look failed
    assert pick.step == "pick"


def test_the_bump_moves_the_view_by_what_it_says():
    """A camera moved 1 cm along x sees the scene 1 cm the other way (the twin's truth)."""
    from mearm.vision import Calibration, ColorDetector

    config = load_config(CONFIG, [SCENE, "twin.faults=[{kind: camera_bump, at_s: 0.1, "
                                  "shift_cm: [1, 0, 0]}]"])  # fmt: skip
    twin = TwinArm(config)
    detector = ColorDetector(config.vision, Calibration.from_config(config.calibration),
                             config.task.classes)  # fmt: skip
    with TwinCamera(config, twin) as camera:
        before = {d.color: d.table_cm for d in detector.detect(camera.read())}
        twin.settle(0.2)
        after = {d.color: d.table_cm for d in detector.detect(camera.read())}
    for color in ("red", "green"):
        np.testing.assert_allclose(after[color] - before[color], (-1.0, 0.0), atol=0.1)


def test_a_frame_check_refuses_a_black_or_stale_frame():
    """Black: too few pixels lit; stale: not newer than the last; a dim lit frame passes."""
    check = FrameCheck("test")
    dim = np.full((48, 64, 3), 40, np.uint8)
    check.check(dim, 1.0)
    with pytest.raises(CameraError, match="the stream froze: this frame was taken at 1.000 s"):
        check.check(dim, 1.0)
    with pytest.raises(CameraError, match="the frame is black"):
        check.check(np.full((48, 64, 3), 8, np.uint8), 2.0)
    check.check(dim, None)  # a source that does not tell its frames' times
    check.check(dim, 3.0, 3.0)
    check.check(dim, 3.0, 3.0)  # read again at the same instant: the same frame, not frozen
    with pytest.raises(CameraError, match="the stream froze"):
        check.check(dim, 3.0, 3.5)  # the clock moved on, the frame did not


def test_looking_twice_at_one_instant_is_not_a_frozen_stream(tmp_path, capsys):
    """Two objects whose picks are each refused for the other: the sort looks again with
    nothing moved in between (the same simulated instant) and ends without a fault."""
    scene = "task.scene=[{color: red, x: 0, y: 45}, {color: red, x: 0, y: 48.2}]"
    log = tmp_path / "run.jsonl"
    code = sort_main(["--config", str(CONFIG), "--set", scene, "--log", str(log), "--quiet"])
    assert code == 1
    assert "(simulated; 2 no route clear of collisions)" in capsys.readouterr().err
    (trial,) = read_runlog(log, strict=True).trials
    assert trial.complete and not trial.faults


def test_a_fault_names_what_it_needs():
    """An unknown joint is refused at load; an unknown object when the twin is built."""
    with pytest.raises(ConfigError, match=r"twin\.faults\.0\.joint: 'wrist' is not an actuated"):
        load_config(CONFIG, ["twin.faults=[{kind: limp_servo, at_s: 1, joint: wrist}]"])
    with pytest.raises(ConfigError, match="twin.faults"):
        load_config(CONFIG, ["twin.faults=[{kind: melt, at_s: 1}]"])
    config = load_config(CONFIG, [SCENE, "twin.faults=[{kind: knock_object, at_s: 1, "
                                  "object: blue1}]"])  # fmt: skip
    with pytest.raises(WorldError, match="no object 'blue1' in the twin; its objects: red1, gr"):
        TwinArm(config)


def test_one_object_moved_alone_is_not_a_moved_view():
    """A lone shift may be a jaw's doing; two alike are the view's; two apart are not."""
    from mearm.task.sorter import TrackedObject, _check_view

    a, b = TrackedObject("red1", "red", 0, 40), TrackedObject("green1", "green", 5, 45)
    one_cm, other = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    _check_view([(a, one_cm)], "test")
    _check_view([(a, one_cm), (b, other)], "test")
    _check_view([(a, one_cm), (b, np.zeros(2))], "test")
    with pytest.raises(CameraError, match=r"the view moved: red1, green1, .* 1\.05 cm"):
        _check_view([(a, one_cm), (b, one_cm + 0.1)], "test")


def test_a_limp_servo_leaves_the_callers_model_whole():
    """The fault takes the torque of the twin's own copy: a model shared by others keeps it."""
    from mearm.sim.twin.mjcf import twin_model

    config = load_config(CONFIG, ["twin.faults=[{kind: limp_servo, at_s: 0.01, joint: shoulder}]"])
    shared = twin_model(config)
    twin = TwinArm(config, shared)
    twin.settle(0.05)
    assert [type(f).__name__ for f in twin.faults.struck] == ["LimpServo"]
    assert twin.model.actuator("shoulder").gainprm[0] == 0.0
    assert shared.actuator("shoulder").gainprm[0] > 0.0


@pytest.mark.heavy
@pytest.mark.parametrize(
    ("fault", "reason"),
    [
        ("{kind: camera_black, at_s: 1.0}", "camera (twin): the frame is black"),
        ("{kind: camera_frozen, at_s: 1.0}", "camera (twin): the stream froze"),
    ],
    ids=["black", "frozen"],
)
def test_a_camera_fault_stops_a_belt_sort_too(fault, reason, tmp_path, capsys):
    """The belt's watch checked no frame: with the camera black from 1 s it ran on and
    ended 'sorted 1 of 2 objects (simulated; 1 never seen by the camera)'. Now it stops
    on the fault and parks, as the still table's look does."""
    log = tmp_path / "run.jsonl"
    code = sort_main(
        ["--config", str(ROOT / "configs" / "sim_conveyor.yaml"),
         "--set", f"twin.faults=[{fault}]", "--log", str(log), "--quiet"]
    )  # fmt: skip
    err = capsys.readouterr().err
    assert code == 1
    assert f"mearm sort: stopped: {reason}" in err and PARKED in err, err
