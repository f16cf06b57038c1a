"""The physical twin refuses a servo rate faster than its physics steps.

The twin runs each command for its period rounded to whole physics steps (2 ms). At the
rate's documented top, 1000 Hz, that is half a step, rounded to none: the physics never
ran, the arm never left home, and ``mearm sort --config sim_mujoco --random 4 --seed 26854
--set servo.rate_hz=1000`` stopped at its first route on ``joint base did not arrive
within 2.00 s: commanded 107.90, measured 120.00`` (999 Hz sorted 4 of 4). A rate the twin
can follow, one step a command at most, is named at load instead.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import mearm_here, one_stderr_line

from mearm.config import load_config
from mearm.errors import ConfigError


def test_a_rate_faster_than_the_twins_steps_is_refused_at_load() -> None:
    with pytest.raises(ConfigError, match=r"servo\.rate_hz: 1000 Hz .* at most 500 Hz"):
        load_config("sim_mujoco", ["servo.rate_hz=1000"])
    load_config("sim", ["servo.rate_hz=1000"])  # the kinematic simulator takes it


def test_the_cli_says_so_in_one_line(tmp_path: Path) -> None:
    done = mearm_here(
        "sort", "--config", "sim_mujoco", "--random", "1", "--seed", "26854", "--quiet",
        "--set", "servo.rate_hz=1000", cwd=tmp_path,
    )  # fmt: skip
    assert "servo.rate_hz: 1000 Hz" in one_stderr_line(done, 2)
    assert not done.stdout


def test_the_twin_sorts_at_the_rate_named(tmp_path: Path) -> None:
    done = mearm_here(
        "sort", "--config", "sim_mujoco", "--random", "1", "--seed", "26854", "--quiet",
        "--set", "servo.rate_hz=500", cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().endswith("sorted 1 of 1 objects (simulated)"), done.stdout
