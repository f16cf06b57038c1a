"""A sort that calibrated its servos at its start replays with that calibration.

``servo.calibrate_at_start: when_uncalibrated`` (``sim_mujoco_kits``): the sort measured
its kit's servos by the camera and sorted with that fit, which the dataset did not keep;
the replay ran the nominal calibration, and a ``--random 3 --seed 7`` sort (servo and
camera seeds 7) sorted 3 of 3 but replayed 1 of 3 (the ``--random 2`` sort here: 2 of 2,
replayed 1 of 2; docs/learning.md told the user to save the calibration with
``--save-calibration`` and give it back by ``--set``). The dataset now keeps it as a
servo calibration file (``meta/mearm_servos/``) and the replay applies it.
"""

from __future__ import annotations

import contextlib
import json
from pathlib import Path

import pytest
from badinput import run_in_process
from conftest import ROOT, run_main

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from mearm.config import load_config  # noqa: E402
from mearm.config.servo_file import (  # noqa: E402
    ActuatorFit,
    ServoCalibrationFile,
    apply_servo_calibration_file,
    load_servo_calibration,
    save_servo_calibration,
    servo_of,
)
from mearm.envs.replay import main as replay_main  # noqa: E402
from mearm.envs.replay import plan_replay  # noqa: E402

pytestmark = [pytest.mark.heavy, pytest.mark.slow]

#: The sort's config, as given.
SETS = ("servo.error_model.seed=7", "camera.seed=7")


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """``mearm sort --config sim_mujoco_kits --random 2 --seed 7 --record`` per scene at
    the servo rate (in this process), its calibration also saved by --save-calibration:
    the dataset and that file."""
    here = tmp_path_factory.mktemp("calibrated")
    ds, saved = here / "ds", here / "saved.servos.yaml"
    sets = [arg for s in SETS for arg in ("--set", s)]
    with contextlib.chdir(ROOT):
        out = run_in_process(
            ["sort", "--config", "sim_mujoco_kits", *sets, "--random", "2", "--seed", "7",
             "--record", ds, "--record-per", "scene", "--record-fps", "50",
             "--record-codec", "h264", "--save-calibration", saved, "--quiet"],
            within_s=60,
        )  # fmt: skip
    assert out.code == 0 and "sorted 2 of 2 objects" in out.stdout, out.stderr
    return ds, saved


def test_the_dataset_keeps_the_calibration_the_sort_made(calibrated):
    """The episode names a servo calibration file in the dataset; applied to the sort's
    config it gives the servos (and limits) the sort's own calibration gave."""
    ds, saved = calibrated
    (start,) = json.loads((ds / "meta" / "mearm_starts.json").read_text())["episodes"]
    assert start == {"after": None, "servos": "meta/mearm_servos/episode-000000.servos.yaml"}
    kept = load_servo_calibration(ds / start["servos"])
    assert {a.name for a in kept.actuators} == {"base", "shoulder", "elbow"}
    assert all(a.replaces is not None for a in kept.actuators)  # the twin's physics
    nominal = load_config("sim_mujoco_kits", SETS)
    sorted_with = apply_servo_calibration_file(nominal, saved)
    assert apply_servo_calibration_file(nominal, ds / start["servos"]).arm == sorted_with.arm
    plan = plan_replay(ds, 0)
    assert plan.config.arm == sorted_with.arm != nominal.arm
    assert Path(str(plan.config.servo.calibration_file)) == (ds / start["servos"]).resolve()


def test_the_replay_ends_as_the_sort_did(calibrated, capsys, monkeypatch):
    """The replay command from another folder, nothing given: 2 of 2 in their bins, exit
    0. Before (the nominal calibration): 1 of 2, exit 1."""
    ds, _ = calibrated
    monkeypatch.chdir(ds)
    code, out, err = run_main(capsys, replay_main, ds)
    assert code == 0, out + err
    assert "2 of 2 objects in their bins" in out


def test_a_calibration_file_the_replay_is_given_is_the_one_it_runs(calibrated, tmp_path):
    """``--config`` with a ``servo.calibration_file`` of its own: that one, not the
    recorded one (the user's choice)."""
    ds, _ = calibrated
    arm = load_config("sim_mujoco_kits").arm
    base = servo_of(arm, "base")
    fit = ActuatorFit("base", "deg", base, (), 0.0, replaces=base)
    cal = ServoCalibrationFile(arm.name, "test", "", "2026-01-01T00:00:00+00:00", (fit,))
    own = save_servo_calibration(tmp_path / "own.servos.yaml", cal)
    plan = plan_replay(
        ds, 0, config="sim_mujoco_kits", overrides=(*SETS, f"servo.calibration_file={own}")
    )
    assert Path(str(plan.config.servo.calibration_file)) == own.resolve()
    assert plan.config.arm == apply_servo_calibration_file(load_config("sim_mujoco_kits"), own).arm
