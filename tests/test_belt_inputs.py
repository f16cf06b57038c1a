"""A belt config sorts only what the belt brings: a table laid with it is refused.

Found after the third walk: ``mearm experiment`` with a belt config laid a random table
each trial that the conveyor sorter ignored ("sorted 2 of 13 (11 never seen by the
camera)"), and a belt config whose own ``task.scene`` held objects ran and left them.
"""

from __future__ import annotations

import pytest
from badinput import run_in_process

from mearm.config import load_config
from mearm.errors import ConfigError


def test_a_belt_config_with_objects_on_its_table_is_refused_at_load():
    with pytest.raises(ConfigError, match=r"task\.scene: 1 object\(s\) on the table, but a "):
        load_config("sim_conveyor_kinematic", ["task.scene=[{color: red, x: 0, y: 30}]"])
    assert load_config("sim_conveyor_kinematic").task.scene == []  # the shipped belts: empty


@pytest.mark.heavy
def test_experiment_refuses_a_belt_config_before_any_output(tmp_path):
    log = tmp_path / "run.jsonl"
    r = run_in_process(  # in this process: a refusal before any work, not the process's
        ["experiment", "--config", "sim_conveyor_kinematic", "--trials", "1", "--log", log]
    )
    assert r.code == 2, r.stderr
    (line,) = r.stderr.strip().splitlines()
    assert line.startswith("mearm experiment: error: experiment lays random objects on the")
    assert "conveyor-sweep" in line
    assert not log.exists()
