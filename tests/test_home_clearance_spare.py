"""A clearance the arm at home keeps by less than the checks' hair is refused at load.

The way home is checked with :data:`~mearm.kinematics.collision.TOUCH_CM` (0.005 cm) to
spare beyond ``task.clearance_cm`` (:meth:`CollisionModel.first_contact
<mearm.kinematics.collision.CollisionModel.first_contact>`); the config's check of home
held it to the clearance alone. The kinematic belt with 14 arrivals (seed 34131) and its
reds 1.81 cm wide grows the red bin's walls to 0.3009 cm from the paper arm's jaws at
home: the check passed a clearance of 0.3 cm, and the sort stopped after its first
object, ``not parked``. Now it is refused with the clearance that holds, and that one
sorts the belt whole.
"""

from __future__ import annotations

import re

import pytest
from badinput import ROOT, check_bad_input, run_in_process

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.kinematics.collision import TOUCH_CM
from mearm.sim.table_collision import collision_model
from mearm.task.check import bins_near_home

BELT = ROOT / "configs" / "sim_conveyor_kinematic.yaml"
SETS = ["task.classes.red.diameter_cm=1.81", "belt.arrivals.count=14", "belt.arrivals.seed=34131"]


def _argv(*sets: str) -> list[str]:
    argv = ["sort", "--config", str(BELT)]
    for s in [*SETS, *sets]:
        argv += ["--set", s]
    return argv


def test_home_within_the_checks_hair_of_a_wall_is_near_it() -> None:
    config = load_config(BELT, SETS)
    model = ArmModel(config.arm)
    near = list(bins_near_home(config, model, collision_model(config, model, clearance_cm=0.0)))
    assert [(name, part) for name, part, _ in near] == [("red", "gripper_jaw_right_pad")]
    distance = near[0][2]
    assert config.task.clearance_cm <= distance < config.task.clearance_cm + TOUCH_CM


@pytest.mark.bad_input
def test_the_refusal_names_a_clearance_that_holds(tmp_path) -> None:
    result = check_bad_input(_argv(), code=2, within_s=10, keep=[tmp_path])
    assert "red's bin" in result.line, result.line
    assert "less than the 0.005 cm the checks keep beyond it" in result.line, result.line
    assert "fewer objects (belt.arrivals.count)" in result.line, result.line
    most = re.search(r": at most ([\d.]+) cm, or move the bin", result.line)
    assert most is not None, result.line
    assert float(most.group(1)) == 0.29


@pytest.mark.heavy
def test_the_belt_sorts_whole_at_the_clearance_it_names() -> None:
    result = run_in_process(_argv("task.clearance_cm=0.29"), within_s=60)
    assert result.code == 0, result.stderr
    assert "sorted 14 of 14 objects (simulated)" in result.stdout, result.stdout[-2000:]
