"""Round 5, t1: the CLI standards for tools/calibration_worth.py, twin-scenes' and
screenshots.py's help, servo-steps' missing output folder, and twin faults that never struck.

Each test failed on the code before its fix (found by a walk through docs/twin.md).
"""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
from badinput import exit_of, tool_module

from mearm.config import load_config
from mearm.sim.twin.twin_faults import FaultSchedule
from mearm.tools import servo_steps, twin_scenes

# ------------------------------------------------------------ tools/calibration_worth.py


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--config", "nope"], "'nope': config file not found"),
        (["--config", "sim"], "--config sim: simulator is 'kinematic'"),
        (["--kits", "0"], "--kits and --trials must be ≥ 1, got 0 and 1"),
        (["--trials", "x"], "argument --trials: must be a plain integer"),
        (["--jobs", "0"], "a number of workers must be ≥ 1"),
        (["--reading-seed", "-1"], "the seed must be in [0, 4294967295]"),
    ],
)
def test_calibration_worth_refuses_bad_input_in_one_line_before_making_out(
    tmp_path, capsys, args, says
):
    """Exit 2, one line (not the usage text), and no ``--out`` folder made: it used to
    exit 1 on a bad config after making the folder, and print the usage on a bad value."""
    out = tmp_path / "out"
    code = exit_of(tool_module("calibration_worth").main, [*args, "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, err
    assert len(err) == 1 and says in err[0], err
    assert ": error: " in err[0], err
    assert not out.exists()


def test_calibration_worth_refuses_an_out_under_a_file(tmp_path, capsys):
    (tmp_path / "file").write_text("mine")
    code = exit_of(tool_module("calibration_worth").main, ["--out", str(tmp_path / "file" / "o")])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert "--out" in line and "is a file, not a folder" in line
    assert (tmp_path / "file").read_text() == "mine"


def test_calibration_worth_explains_every_option(monkeypatch):
    """``--help`` says what each option is (it named most of them only)."""
    tool = tool_module("calibration_worth")
    parsers = []

    class Recorded(tool.ArgumentParser):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            parsers.append(self)

    monkeypatch.setattr(tool, "ArgumentParser", Recorded)
    with pytest.raises(SystemExit):
        tool.main(["--help"])
    (parser,) = parsers
    unexplained = [a.option_strings for a in parser._actions if not a.help]
    assert not unexplained


@pytest.mark.slow
def test_calibration_worth_names_every_file_it_writes(tmp_path, capsys, monkeypatch):
    """One kit, for real: a ``wrote PATH`` line for each file in ``--out`` (the
    calibration file and both logs the ``mearm`` commands wrote, the results). The kits'
    config with one object on its table: each trial sorts one, not 12 (the files are the
    point, not the figures)."""
    monkeypatch.chdir(tmp_path)
    Path("one.yaml").write_text(
        "extends: sim_mujoco_kits\ntask:\n  scene: [{color: red, x: -4, y: 45}]\n"
    )
    code = exit_of(
        tool_module("calibration_worth").main,
        ["--config", "one.yaml", "--kits", "1", "--trials", "1", "--out", "cw"],
    )
    out = capsys.readouterr().out
    assert code == 0, out
    written = {Path(line.split()[1]).name for line in out.splitlines() if line.startswith("wrote ")}
    assert written == {p.name for p in (tmp_path / "cw").iterdir()}
    assert written >= {"kit1.servos.yaml", "kit1.before.jsonl", "kit1.after.jsonl"}
    assert "| before |" in out and "| after |" in out


# ------------------------------------------------------------------------- twin-scenes


def test_twin_scenes_help_gives_the_defaults(capsys):
    with pytest.raises(SystemExit):
        twin_scenes.main(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "seeds S … S+N−1 (default 50)" in text
    assert "objects per scene (default 12)" in text
    assert "(0…1; default 0: no share asked for; a scene stopped on a fault exits 1" in text


# ------------------------------------------------------------------------- servo-steps


@pytest.mark.heavy
def test_servo_steps_makes_the_folders_it_writes_into(tmp_path, capsys):
    """As every command does (docs/safety.md): it refused a folder not made yet."""
    csv = tmp_path / "new" / "deeper" / "steps.csv"
    assert servo_steps.main(["--degrees", "5", "--csv", str(csv)]) == 0
    assert capsys.readouterr().out == f"wrote {csv}\n"
    assert csv.read_text().startswith("joint,step_deg,t_s,angle_deg\n")


@pytest.mark.parametrize(
    ("where", "says"),
    [
        ("folder", "exists and is not a regular file (a folder)"),
        ("file/steps.csv", "is a file, not a folder"),
    ],
)
def test_servo_steps_still_refuses_what_cannot_be_a_file(tmp_path, capsys, where, says):
    (tmp_path / "folder").mkdir()
    (tmp_path / "file").write_text("mine")
    code = exit_of(servo_steps.main, ["--csv", str(tmp_path / where)])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert f"--csv {tmp_path / where}: " in line and says in line
    assert (tmp_path / "file").read_text() == "mine"


# ------------------------------------------------------------------------ twin.faults


def test_faults_that_never_struck_are_said(caplog):
    """A fault timed after the run's end, or a camera fault no frame was read after,
    changed nothing: each is one warning, so nobody takes it for exercised."""
    faults = load_config(
        "sim_mujoco",
        [
            "twin.faults=[{kind: limp_servo, at_s: 3000, joint: base}, "
            "{kind: camera_black, at_s: 0.5}, {kind: camera_frozen, at_s: 2}]"
        ],
    ).twin.faults
    schedule = FaultSchedule(faults, [])
    with caplog.at_level(logging.WARNING, logger="mearm.sim.twin.twin_faults"):
        assert schedule.camera(1.0).black  # camera_black struck, camera_frozen not yet
        lines = schedule.never_struck(2.5)
    assert lines == [
        "twin: fault camera_frozen at_s = 2 s never struck: the run ended at t = 2.500 s; "
        "no frame was read after it",
        "twin: fault limp_servo joint=base at_s = 3000 s never struck: the run ended at "
        "t = 2.500 s",
    ]
    warned = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert warned[-2:] == lines


def test_a_run_whose_faults_all_struck_says_nothing_more(caplog):
    faults = load_config("sim_mujoco", ["twin.faults=[{kind: camera_black, at_s: 0.5}]"])
    schedule = FaultSchedule(faults.twin.faults, [])
    schedule.camera(1.0)
    assert schedule.never_struck(1.0) == []


# ----------------------------------------------------------------- tools/screenshots.py


def test_screenshots_help_says_it_replaces_its_pictures(capsys):
    """A developer tool that redraws the committed pictures: it replaces them by design,
    and says so (the mearm commands refuse without --force)."""
    with pytest.raises(SystemExit):
        tool_module("screenshots").main(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "replaced, without a --force" in text


def test_the_twin_says_on_closing_the_faults_that_never_struck(caplog):
    """Wired: the twin's bus, closed after a run shorter than a fault's time, logs it."""
    from mearm.sim.twin.mjcf import twin_model  # noqa: PLC0415
    from mearm.sim.twin.twin_bus import TwinArm  # noqa: PLC0415

    config = load_config(
        "sim_mujoco", ["twin.faults=[{kind: limp_servo, at_s: 3000, joint: base}]"]
    )
    arm = TwinArm(config, twin_model(config))
    arm.connect()
    arm.hold(0.1)
    with caplog.at_level(logging.WARNING, logger="mearm.sim.twin.twin_faults"):
        arm.close()
    warned = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any("limp_servo joint=base at_s = 3000 s never struck" in w for w in warned), warned
