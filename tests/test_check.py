"""Consistency at load: what only the whole config can tell, found before anything moves."""

from __future__ import annotations

import pytest
from badinput import check_bad_input
from conftest import REFERENCE_CONFIGS, ROOT

from mearm.config import load_config
from mearm.exceptions import ConfigError
from mearm.runlog import read_runlog
from mearm.task.check import check_consistency


@pytest.mark.parametrize("name", REFERENCE_CONFIGS)
@pytest.mark.heavy
def test_reference_configs_are_consistent(name):
    found = check_consistency(load_config(ROOT / "configs" / name), notes=True)
    # the MeArm v1's elbow servo turns the forearm only within ±75° of level (its pulse
    # range, on shoulder + elbow): at the pick height it reaches a band 16–20 cm out,
    # a fifth of its camera's 24 × 18 cm view, and says so in a note
    most = 0.85 if name.startswith("sim_mearm_v1") else 0.6
    shares = found.unreachable_share
    assert found.pick_z_cm and set(shares) == {round(z, 6) for z in found.pick_z_cm.values()}
    assert all(0 <= s < most for s in shares.values())


def test_the_survey_of_the_view_is_made_for_the_notes_only(monkeypatch):
    """Without ``notes`` the check stops at the first point of the view reached (its
    failure needs no more); the survey is made when the notes are asked for, also after."""
    from mearm.task import check

    monkeypatch.setattr(check, "_CACHE", {})  # (another test may have surveyed it)
    config = load_config(ROOT / "configs" / "sim_mearm_v1.yaml")
    quiet = check_consistency(config)
    assert quiet.pick_z_cm and not quiet.unreachable_share and not quiet.notes
    said = check_consistency(config, notes=True)
    assert said.unreachable_share and len(said.notes) == 1  # a fifth of its view reached
    assert check_consistency(config) is said  # the survey serves the quiet ones too


def test_a_bin_out_of_reach_is_named_with_its_value():
    config = load_config(None, ["task.classes.green.bin_cm=[0, 80, 20]"])
    with pytest.raises(ConfigError, match=r"task\.classes\.green\.bin_cm: \[0, 80, 20\]"):
        check_consistency(config)


def test_a_pick_height_outside_the_box_is_named():
    config = load_config(None, ["arm.target_box.z_cm={min: 15, max: 60}"])
    with pytest.raises(ConfigError, match=r"task\.classes\.red\.grip_height_cm: .*z = 12\.76"):
        check_consistency(config)


def test_a_pick_height_reached_nowhere_is_named():
    config = load_config(
        None, ["arm.target_box.z_cm={min: 10, max: 100}", "arm.tool.tcp_above_grip_cm=90"]
    )
    with pytest.raises(ConfigError, match=r"task\.classes\.red\.grip_height_cm: .* nowhere"):
        check_consistency(config)


def test_the_unreachable_share_of_the_view_is_said_once(capsys):
    from mearm.sort import main

    code = main(["--random", "2", "--seed", "1"])
    lines = capsys.readouterr().err.splitlines()
    notes = [ln for ln in lines if ln.startswith("mearm sort: note:")]
    assert code == 0 and len(notes) == 1
    assert "of the camera's view of the table" in notes[0] and "12.76 cm" in notes[0]


@pytest.mark.bad_input
@pytest.mark.parametrize(
    "override, field",
    [
        ("task.classes.red.bin_cm=[0, 80, 20]", "task.classes.red.bin_cm"),
        ("task.classes.blue.bin_cm=[-40, 5, 10]", "task.classes.blue.bin_cm"),
        ("arm.target_box.z_cm={min: 20, max: 60}", "task.classes.red.grip_height_cm"),
        ("task.classes.green.grip_height_cm=45", "task.classes.green.grip_height_cm"),
        ("arm.joints.shoulder.limits={min: 30, max: 200}", "arm.joints"),
        ("arm.joints.base.limits.max=250", "arm.joints"),
        # the collision model's table: bins apart, off the base, clear of the arm at home
        ("task.classes.green.bin_cm=[-18, 37, 20]", "task.classes.green.bin_cm: [-18, 37]"),
        ("task.classes.blue.bin_cm=[1, 2, 20]", "on the arm's base plate"),
        ("task.clearance_cm=-0.5", "task.clearance_cm"),
    ],
)
def test_inconsistent_configs_stop_before_motion_with_exit_2(tmp_path, override, field):
    """Exit 2, one line naming the field; the run log holds the reason as a fault."""
    log = tmp_path / "run.jsonl"
    out = check_bad_input(["sort", "--set", override, "--log", log])
    assert field in out.line
    if log.exists():
        trial = read_runlog(log).trials[-1]
        assert trial.faults and field in trial.faults[0].reason
        assert trial.summary is not None and not trial.summary.ok


@pytest.mark.bad_input
def test_a_clearance_the_arm_breaks_at_home_stops_before_motion():
    """The paper's twin rests 3.31 cm above its red bin: a 5 cm clearance is refused at load."""
    out = check_bad_input(["sort", "--config", "sim_mujoco", "--set", "task.clearance_cm=5"])
    assert out.line.endswith(
        "task.clearance_cm: 5 cm is more than the arm keeps from red's bin at home "
        "(gripper_jaw_right_pad, 3.30 cm): at most 3.30 cm, or move the bin, or lower its "
        "walls: 5 cm, built to hold its 4 objects (1 cm high) stacked (fewer or lower "
        "objects, or task.classes.red.bin_height_cm)"
    )


@pytest.mark.bad_input
def test_objects_made_taller_name_the_walls_they_raise_into_the_arm():
    """8 cm reds raise their bin's walls to 40 cm, into the arm at home: the line said only
    that the clearance (unchanged) was too much."""
    out = check_bad_input(
        ["sort", "--config", "sim_mujoco", "--set", "task.classes.red.height_cm=8"]
    )
    assert "from red's bin at home" in out.line
    assert out.line.endswith(
        "or lower its walls: 40 cm, built to hold its 4 objects (8 cm high) stacked (fewer "
        "or lower objects, or task.classes.red.bin_height_cm)"
    ), out.line


#: The built-in calibration with the field moved 100 cm farther out: no pick reaches it.
FAR_FIELD = "calibration.homography=[[0.0625, 0, -20.5], [0, -0.0625, 159.0], [0, 0, 1]]"
#: Shoulder 10°, elbow −120°: the jaws, hanging below the hand, go through the table.
HOME_UNDER_TABLE = ("arm.joints.shoulder.limits.min=0", "arm.joints.shoulder.home=10",
                    "arm.joints.elbow.home=-120")  # fmt: skip


@pytest.mark.bad_input
@pytest.mark.parametrize(
    ("sets", "words"),
    [
        ((FAR_FIELD,), "calibration.homography: the camera's view of the table (x -20…19 cm, "
                       "y 129…159 cm) holds no point the arm can pick from"),
        (HOME_UNDER_TABLE, "arm.joints[].home: at home (base 120, shoulder 10, elbow -120) the "
                           "tool's gripper_jaw_left_pad is 19.89 cm below the table"),
    ],
)  # fmt: skip
@pytest.mark.parametrize("command", [("sort",), ("sort", "--quiet"), ("experiment",)])
def test_a_config_the_sort_cannot_use_is_refused_before_the_log(
    sets: tuple[str, ...], words: str, command: tuple[str, ...], tmp_path
):
    """A camera that sees nothing in reach ("sorted 0 of 0", exit 0 before) or a home with
    the tool under the table: exit 2, one line, and no run log started (a quiet sort, which
    does not survey the view for its note, too)."""
    log = tmp_path / "run.jsonl"
    argv = [*command, *(a for s in sets for a in ("--set", s)), "--log", log]
    out = check_bad_input([*argv, *(["--trials", "2"] if command[0] == "experiment" else [])])
    assert words in out.line
    assert not log.exists()
