"""A class without ``grip_height_cm`` whose picks the random table refuses is named, not a crash.

``mearm sort --config sim_5dof --random 9 --seed 34285 --set
task.classes.green.height_cm=0.66`` ended ``unexpected error: TypeError: unsupported
format string passed to NoneType.__format__``: the green objects, gripped at half their
height (0.33 cm: the class sets no ``grip_height_cm``), put the open jaws in the table at
every place drawn, and the refusal that says so formatted the unset ``grip_height_cm``
(a sweep of seeds 34001–34300, 2026-12-07, simulated). It now names the height the
jaws close at, and that it is the default; raised as it says, the table sorts.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import mearm_here, one_stderr_line

from mearm.config import load_config
from mearm.task.scene import SceneError, random_scene

LOW_GREENS = ["task.classes.green.height_cm=0.66"]


def test_jaws_in_the_table_name_the_default_grip_height(tmp_path: Path) -> None:
    done = mearm_here(
        "sort", "--config", "sim_5dof", "--random", "9", "--seed", "34285",
        "--set", LOW_GREENS[0], cwd=tmp_path,
    )  # fmt: skip
    line = one_stderr_line(done, 2)
    assert "unexpected error" not in line, line
    assert (
        "task.classes.green: picked at grip_height_cm 0.33 (unset: half its height_cm) "
        "(the TCP 0 cm above it, arm.tool.tcp_above_grip_cm), the open jaws' " in line
    ), line
    assert line.endswith("raise grip_height_cm"), line


def test_raised_as_it_says_the_table_lays_out() -> None:
    config = load_config("sim_5dof", [*LOW_GREENS, "task.classes.green.grip_height_cm=0.5"])
    assert len(random_scene(config, 9, seed=34285)) == 9


def test_a_tall_object_gripped_at_the_default_names_it_too() -> None:
    config = load_config("sim_5dof", ["task.classes.green.height_cm=5"])
    with pytest.raises(SceneError) as info:
        random_scene(config, 9, seed=1)
    text = str(info.value)
    assert (
        "task.classes.green: an object 5 cm tall picked at grip_height_cm 2.5 (unset: half "
        "its height_cm) comes within task.clearance_cm" in text
    ), text
