"""A trial a worker process recorded keeps the servo calibration the trial made at its start.

``servo.calibrate_at_start`` (``sim_mujoco_kits``): each trial measures its kit's servos
by the camera and sorts with that fit, and the dataset keeps it (``meta/mearm_servos/``)
so a replay runs those servos. ``mearm experiment --jobs N --record DIR`` dropped it:
its workers record through :class:`~mearm.dataset.sampler.EpisodeCapture`, which the
sorter had no calibration to hand, so their episodes named no servo file and replayed
with the nominal calibration. Now each episode carries its sort's calibration, and a
worker's trial keeps what the same trial run in the command's own process keeps.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from badinput import run_in_process
from conftest import ROOT

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from mearm.config import load_config  # noqa: E402
from mearm.config.servo_file import load_servo_calibration  # noqa: E402
from mearm.dataset.format_check import check_dataset  # noqa: E402
from mearm.envs.replay import plan_replay  # noqa: E402

pytestmark = [pytest.mark.heavy, pytest.mark.slow]

#: One trial of two objects, recorded per pick: two episodes of one sort.
SCENE = "- {color: red, x: -10.99, y: 49.70}\n- {color: blue, x: 5.0, y: 45.0}\n"
#: The servo file the trial's first episode names; the second names it too.
SERVOS = "meta/mearm_servos/episode-000000.servos.yaml"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The same one-trial experiment on ``sim_mujoco_kits`` recorded twice, at once: in
    the command's own process (``--jobs 1``, run in this one) and by a worker process
    (``--jobs 2``, a command of its own)."""
    here = tmp_path_factory.mktemp("jobs_calibration")
    scene = here / "scene.yaml"
    scene.write_text(SCENE)

    def argv(jobs: str) -> list[str]:
        return [
            "experiment", "--config", "sim_mujoco_kits", "--scene", str(scene), "--trials", "1",
            "--seed", "3", "--jobs", jobs, "--log", str(here / f"jobs{jobs}.jsonl"),
            "--record", str(here / f"jobs{jobs}"), "--record-codec", "h264", "--record-fps", "5",
        ]  # fmt: skip

    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    workers = subprocess.Popen(
        [sys.executable, "-m", "mearm", *argv("2")],
        cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    serial = run_in_process(argv("1"), within_s=60, cwd=ROOT)
    out, err = workers.communicate(timeout=600)
    ran = {"1": (serial.code, serial.stdout, serial.stderr), "2": (workers.returncode, out, err)}
    for jobs, (code, said, errors) in ran.items():
        assert code == 0, f"--jobs {jobs}: {said}{errors}"
        assert "sorted 2 of 2 objects" in said, said
    return {jobs: here / f"jobs{jobs}" for jobs in ("1", "2")}


def _starts(root: Path) -> list[dict[str, object]]:
    return json.loads((root / "meta" / "mearm_starts.json").read_text())["episodes"]


def test_a_workers_episodes_name_the_calibration_its_trial_made(recorded):
    """Both picks name the trial's servo file, as the serial run's do; the file holds
    the same fit. Before: ``[{"after": null}, {"after": 0, ...}]``, no file."""
    serial, worker = recorded["1"], recorded["2"]
    assert _starts(worker) == _starts(serial)
    assert [start.get("servos") for start in _starts(worker)] == [SERVOS, SERVOS]
    kept, made = load_servo_calibration(worker / SERVOS), load_servo_calibration(serial / SERVOS)
    assert kept.actuators == made.actuators and kept.actuators
    assert all(fit.replaces is not None for fit in kept.actuators)  # the kit's physics kept
    assert check_dataset(worker, videos=False) == []


def test_a_workers_episodes_replay_with_the_servos_the_trial_ran(recorded):
    """The replay of each pick runs the calibrated servos, those of the serial run's
    replay, not the nominal ones (before: the nominal ones)."""
    serial, worker = recorded["1"], recorded["2"]
    nominal = load_config("sim_mujoco_kits").arm
    for episode in (0, 1):
        arm = plan_replay(worker, episode).config.arm
        assert arm == plan_replay(serial, episode).config.arm != nominal
