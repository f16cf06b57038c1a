"""Bad-input corpus: the commands added after the corpus was first written.

The maker's commands (find-port, flash, find-camera, init-config, calibrate-servos,
jog), the twin's (twin-scenes, servo-steps, render-calibration, camera-accuracy,
``twin.faults``), the virtual Uno's (virtual-uno-pulses), aruco-sheet, reproduce-paper
and ik-stalls. Each case: exit 2, one line on stderr naming the problem, no
traceback, within the time bound, the files around intact (:func:`badinput.check_bad_input`).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import ROOT, check_bad_input, run_in_process

bad_input = pytest.mark.bad_input

CONFIGS = ROOT / "configs"
TWIN = str(CONFIGS / "sim_mujoco.yaml")


@pytest.fixture(scope="module")
def spots(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """Places to point outputs and inputs at: a folder and a plain file."""
    d = tmp_path_factory.mktemp("commands")
    (d / "folder").mkdir()
    (d / "file.txt").write_text("keep me\n")
    (d / "snap.png").write_bytes(b"a camera's snapshot")  # a .png a sheet must not replace
    return {
        "dir": str(d), "folder": str(d / "folder"), "file": str(d / "file.txt"),
        "png": str(d / "snap.png"),
    }  # fmt: skip


@pytest.fixture(scope="module", autouse=True)
def _imported() -> None:
    for name in ("aruco-sheet", "twin-scenes", "servo-steps", "find-port", "calibrate-servos"):
        run_in_process([name, "--help"], within_s=60)


#: (argv, words the one line must hold). ``{dir}`` etc. are filled from ``spots``.
CASES: list[tuple[list[str], str]] = [
    # aruco-sheet
    (
        ["aruco-sheet", "--output", "{dir}/s.png", "--ids", "abc"],
        "--ids must be comma-separated integers (at most 10 fit one A4 page)",
    ),
    (["aruco-sheet", "--output", "{dir}/s.png", "--side-cm", "nan"], "--side-cm must be in"),
    (["aruco-sheet", "--output", "{dir}/s.png", "--dpi", "0"], "--dpi must be in [72, 2400]"),
    (["aruco-sheet", "--output", "{folder}"], "--output must be a .png file"),
    (["aruco-sheet", "--output", "{png}"], "exists; pass --force to replace it"),
    (["charuco-board", "--output", "{png}"], "exists; pass --force to replace it"),
    (["aruco-sheet", "--output", "{dir}/s.png", "--dictionary", "NOPE"], "unknown ArUco dict"),
    # render-calibration (the twin's camera)
    (["render-calibration", "--out", "{file}"], "exists and is not a directory"),
    (["render-calibration", "--out", "{dir}/r", "--views", "0"], "--views must be in [1, 200]"),
    (["render-calibration", "--out", "{dir}/r", "--noise-std", "-1"], "--noise-std must be"),
    # twin-scenes
    (["twin-scenes", "--scenes", "0"], "--scenes must be ≥ 1, got 0"),
    (["twin-scenes", "--objects", "-1"], "--objects must be 1 to 500 a scene, got -1"),
    (["twin-scenes", "--objects", "501"], "--objects must be 1 to 500 a scene, got 501"),
    (["twin-scenes", "--require", "2"], "--require is a share sorted, 0 to 1, got 2.0"),
    (["twin-scenes", "--require", "nan"], "--require is a share sorted, 0 to 1, got nan"),
    (["twin-scenes", "--jobs", "0"], "a number of workers must be ≥ 1"),
    (["twin-scenes", "--config", "sim"],
     "--config sim: simulator is 'kinematic'; twin-scenes sorts in the twin"),
    (["twin-scenes", "--config", "sim_conveyor"],
     "--config sim_conveyor: it has a belt, whose sort takes only what the belt brings"),
    # servo-steps
    (["servo-steps", "--degrees", "nan", "--csv", "s.csv"], "must be in (0, 90], got nan"),
    (["servo-steps", "--degrees", "10", "0", "--csv", "s.csv"], "(0, 90], got 0"),
    (["servo-steps", "--csv", "{folder}"], "exists and is not a regular file (a folder)"),
    # camera-accuracy
    (["camera-accuracy", "--heights", "x"], "--heights wants numbers like 1,2.5"),
    (["camera-accuracy", "--config", TWIN, "--views", "0"],
     "--views must be a whole number in 6 … 60, got 0"),
    (["camera-accuracy", "--config", "sim"], "sim: simulator is 'kinematic'; this needs the twin"),
    (["camera-accuracy", "--heights", "1,1"], "--heights names a height twice"),
    # the twin's injected faults
    (["sort", "--config", TWIN, "--set", "twin.faults=[{kind: melt, at_s: 1}]"], "twin.faults"),
    (["sort", "--config", TWIN, "--set", "twin.faults=[{kind: limp_servo, at_s: 1, "
      "joint: wrist}]"], "'wrist' is not an actuated joint"),
    (["sort", "--config", TWIN, "--set", "twin.faults=[{kind: camera_black, at_s: -1}]"],
     "twin.faults.0"),
    (["sort", "--config", TWIN, "--set", "twin.faults=[{kind: camera_bump, at_s: 1, "
      "shift_cm: [100, 0, 0]}]"], "twin.faults.0"),
    (["sort", "--config", TWIN, "--set", "twin.faults=[{kind: knock_object, at_s: 1, "
      "object: purple9}]"], "no object 'purple9' in the twin"),
    # reproduce-paper, ik-stalls
    (["reproduce-paper", "--mode", "fast"], "invalid choice: 'fast'"),
    (["reproduce-paper", "--set", "controller.mode=coupled"], "--set changes neither"),
    (["reproduce-paper", "--config", "sim_5dof"], "this config's arm is desk_5dof"),
    (["ik-stalls", "--targets", "0"], "--targets must be in [1, 1000000]"),
    (["ik-stalls", "{dir}/nosuch.yaml"], "config file not found"),
    # the maker's commands
    (["find-port", "--timeout", "nan"], "must be a positive number s"),
    (["find-port", "--wait", "-1"], "must be a positive number s"),
    (["find-port", "--port", "spy://x"], "the URL scheme 'spy' is not allowed"),
    (["find-port", "--only"], "--only tries only the ports given with --port"),
    (["flash", "--upload-baud", "9600"], "invalid choice: 9600"),
    (["flash", "--port", "spy://x", "--dry-run"], "--port must be the board's device path"),
    (["flash", "--set", "servo.backend=ssc32", "--dry-run"], "an SSC-32 (servo.backend: ssc32)"),
    (["find-camera", "--out", "{file}"], "exists and is not a folder"),
    (["init-config", "--arm", "nope"], "invalid choice: 'nope'"),
    (["init-config", "--rig", "nope"], "invalid choice: 'nope'"),
    (["init-config", "{dir}/new.yaml"], "needs --arm, --rig"),
    (["calibrate-servos", "--port", "/dev/null"], "interactive and needs a terminal"),
    (["calibrate-servos", "--simulate", "--output", "{dir}/c.yaml"], "against the MuJoCo twin"),
    (["calibrate-servos", "--config", TWIN, "--simulate", "--output", "{dir}/c.yaml",
      "--actuators", "nope"], "no actuator 'nope'"),
    (["calibrate-servos", "--simulate", "--reading-error", "nan"], "a reading error lies in"),
    (["jog", "--servo-calibration", "{dir}/nosuch.yaml"], "servo calibration file not found"),
    (["jog"], "interactive and needs a terminal"),
    # the virtual Uno
    (["virtual-uno-pulses", "--commands", "0"], "--commands must be from 1 to 100000, got 0"),
    (["virtual-uno-pulses", "--commands", "2.5"], "--commands: must be a plain integer"),
]  # fmt: skip


def _fill(argv: list[str], spots: dict[str, str]) -> list[str]:
    """``{dir}`` etc. filled in (only those: YAML flow mappings keep their braces)."""
    out = []
    for a in argv:
        for key, value in spots.items():
            a = a.replace("{" + key + "}", value)
        out.append(a)
    return out


@bad_input
@pytest.mark.parametrize(
    ("argv", "words"), [pytest.param(a, w, id=" ".join(a)[:60]) for a, w in CASES]
)
def test_bad_arguments_are_refused(argv: list[str], words: str, spots: dict[str, str]) -> None:
    """Each bad command line: exit 2, one line naming the problem, nothing touched."""
    out = check_bad_input(_fill(argv, spots), within_s=5, keep=[Path(spots["dir"]), CONFIGS])
    assert words in out.line
    assert Path(spots["file"]).read_text() == "keep me\n"
    assert list(Path(spots["folder"]).iterdir()) == []
