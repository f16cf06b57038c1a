"""What the sort pays before its first route: imports, defaults and the target box's check."""

import subprocess
import sys

import numpy as np
import pytest
from test_startup_check import planned_one_by_one

from mearm.config import Config, load_config
from mearm.config.root import TwinConfig
from mearm.config.sections import SimErrorModel, VirtualUnoConfig
from mearm.kinematics import ArmModel
from mearm.task import check, plan
from mearm.task.plan import Planner


def _planner(name):
    config = load_config(name)
    model = ArmModel(config.arm)
    return config, model, Planner(config, model)


@pytest.mark.parametrize("name", ["sim", "sim_5dof"])
def test_box_reach_is_any_point_planned(name):
    """Trying the middle first answers as planning every point of the target box would."""
    config, model, planner = _planner(name)
    cls = config.task.classes[0]
    points = check._box_points_cm(config)
    expected = any(planned_one_by_one(planner, model, cls, points))
    assert check._reached_somewhere(planner, model, cls.name, points) is expected


def test_box_reach_finds_a_point_away_from_the_middle():
    """The one point reached is found wherever it lies (the middle and the rest unreachable)."""
    config, model, planner = _planner("sim")
    cls = config.task.classes[0]
    reached = check._box_points_cm(config)[17]
    far = [[0.0, 200.0], [150.0, 150.0], [-150.0, 150.0], [200.0, 0.0]]  # beyond the arm
    points = np.array([*far[:2], reached, *far[2:]])
    assert planned_one_by_one(planner, model, cls, points) == [False, False, True, False, False]
    assert check._reached_somewhere(planner, model, cls.name, points)
    assert not check._reached_somewhere(planner, model, cls.name, np.array(far))
    assert not check._reached_somewhere(planner, model, cls.name, np.zeros((0, 2)))


def test_box_reach_solves_only_the_middle_when_it_is_reached(monkeypatch):
    """The 5-DOF arm's batch solve runs on one point, not the whole box (most of it far)."""
    config, model, planner = _planner("sim_5dof")
    sizes = []
    solve = plan.solve_batch

    def counted(model, positions, *args, **kwargs):
        sizes.append(len(positions))
        return solve(model, positions, *args, **kwargs)

    monkeypatch.setattr(plan, "solve_batch", counted)
    points = check._box_points_cm(config)
    assert check._reached_somewhere(planner, model, config.task.classes[0].name, points)
    assert sizes == [1]


def _run(code):
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


@pytest.mark.heavy
def test_the_sort_imports_no_conveyor_and_compiles_no_tokenizer():
    """``import mearm.sort`` leaves the belt's sorter and tokenize's patterns for who needs them.

    (pydantic reads a builtin ``default_factory``'s signature by tokenizing its text.)
    """
    code = (
        "import sys, mearm.sort, mearm.config\n"
        "mearm.config.load_config('sim')\n"
        "t = sys.modules.get('tokenize')\n"
        "print('mearm.task.conveyor' in sys.modules, t is not None and "
        "t._compile.cache_info().currsize > 0)"
    )
    assert _run(code) == "False False"


def test_a_belt_config_still_gets_the_conveyor_sorter():
    """The sorter of a belt is imported when a belt asks for it."""
    from mearm.task import rig
    from mearm.task.conveyor import ConveyorSorter

    assert rig._conveyor_sorter() is ConveyorSorter


def test_list_and_mapping_defaults_are_each_model_s_own():
    """A default list or mapping is copied: no two models share one."""
    tool = Config().arm.tool
    no_actuators = tool.model_dump(exclude={"actuators"})
    for make, field in [
        (lambda: type(tool).model_validate(no_actuators), "actuators"),
        (TwinConfig, "faults"),
        (SimErrorModel, "offset_deg"),
        (VirtualUnoConfig, "defines"),
    ]:
        x, y = getattr(make(), field), getattr(make(), field)
        assert x == y
        assert not x
        assert x is not y


@pytest.mark.heavy
def test_the_sort_leaves_what_only_other_runs_need_unimported():
    """``import mearm.sort`` and loading ``sim`` import none of what only other runs need.

    A thread pool (``--jobs``), the servo calibration file's module (a config that names
    one), ``difflib`` (an unknown key's suggestion) and ``shlex`` (the note for servos
    never calibrated) are each imported where they are used.
    """
    code = (
        "import sys, mearm.sort, mearm.config\n"
        "mearm.config.load_config('sim')\n"
        "names = ('concurrent.futures', 'mearm.config.servo_file', 'difflib', 'shlex')\n"
        "print(sorted(n for n in names if n in sys.modules))"
    )
    assert _run(code) == "[]"
