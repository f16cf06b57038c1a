"""A table whose objects grow a bin's walls into the arm at home is refused before the sort.

Both simulators build each bin's walls to hold its class's objects stacked. The paper's
rig (``sim_paper_arm``: the paper's 1.5 cm clearance) hangs its jaws at home beside the
red bin: ``mearm sort --config sim_paper_arm --random 20`` (7 reds: walls 8 cm tall, 0.47
cm from the jaws at home) ran for 35 simulated seconds, left 13 objects "bin out of
reach" and ended "stopped: not parked", the arm stranded beside the bin, on every seed
tried. The config's own table was checked when it loaded; the table laid out was not.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import mearm_here, one_stderr_line

from mearm.config import load_config
from mearm.task.scene import (
    SceneError,
    _class_order,
    _walls_by_home,
    check_scene,
    random_scene,
)


def test_a_random_table_whose_walls_reach_home_names_the_most_that_fit() -> None:
    config = load_config("sim_paper_arm")
    with pytest.raises(SceneError) as info:
        random_scene(config, 20, seed=1)
    text = str(info.value)
    assert re.search(
        r"class red: its bin's walls, built 8 cm tall to hold its 7 objects stacked, come "
        r"within 0\.\d\d cm of the arm at home \(gripper_jaw_\w+\), less than "
        r"task\.clearance_cm \(1\.5 cm\): ask for (\d+) or fewer$",
        text,
    ), text
    most = int(re.findall(r"ask for (\d+) or fewer", text)[0])
    assert 12 <= most < 20  # (the config's own 12 passed when it loaded)
    check_scene(config, random_scene(config, most, seed=1), "--random")
    with pytest.raises(SceneError, match=rf"ask for {most} or fewer"):
        random_scene(config, most + 1, seed=1)


def test_the_same_table_at_a_clearance_the_walls_leave_is_taken() -> None:
    config = load_config("sim_paper_arm", ["task.clearance_cm=0.3"])
    assert len(random_scene(config, 20, seed=1)) == 20


def test_a_scene_file_whose_walls_reach_home_is_refused_before_the_log(tmp_path: Path) -> None:
    scene = tmp_path / "reds.yaml"
    rows = [(-12 + 4 * i, 38) for i in range(7)]
    scene.write_text("".join(f"- {{color: red, x: {x}, y: {y}}}\n" for x, y in rows))
    log = tmp_path / "run.jsonl"
    done = mearm_here(
        "sort", "--config", "sim_paper_arm", "--scene", scene, "--log", log, cwd=tmp_path
    )
    line = one_stderr_line(done, 2)
    assert "reds.yaml: class red: its bin's walls, built 8 cm tall" in line, line
    assert line.endswith("(1.5 cm): give the class fewer objects"), line
    assert not log.exists()
    assert not done.stdout


def test_walls_that_reach_into_the_arm_at_home_say_so_not_a_negative_distance() -> None:
    """``sim_shapes --random 29 --seed 43247`` with a 1.2 cm red cylinder: 10 of them grow
    11 cm walls that overlap the jaws at home, which read "come within -0.65 cm of the arm
    at home". Only the walls are built: nothing is laid out or planned."""
    sets = ("task.classes.red_cylinder.diameter_cm=1.2",)
    config = load_config("sim_shapes", sets).with_scene([])
    problem = _walls_by_home(config, _class_order(config, 29, 43247))
    assert problem is not None
    assert re.fullmatch(
        r"class red_cylinder: its bin's walls, built 11 cm tall to hold its 10 objects "
        r"stacked, reach into the arm at home \(gripper_jaw_\w+\) by 0\.\d\d cm",
        problem,
    ), problem
    assert "-" not in problem, problem
