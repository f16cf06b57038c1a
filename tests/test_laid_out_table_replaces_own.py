"""A table laid out by ``--random`` or ``--scene`` is checked instead of the config's own.

Both simulators build each bin's walls to hold the table's objects of its class stacked.
``mearm sort --config sim_paper_arm --set task.classes.red.height_cm=2.18 --random 1``
was refused before the sort: "task.clearance_cm: 1.5 cm is more than the arm keeps from
red's bin at home … lower its walls: 10.9 cm, built to hold its 4 objects (2.18 cm high)
stacked": the four reds of the config's own table, which the run was not going to lay
out, and the one object asked for sorted whole once that table was emptied (found by a
sweep of seeds 34001–34300, 2026-12-08, simulated; ``--random 22``, ``36`` and ``3`` on
``sim_paper_arm``, ``sim_shapes`` and ``sim_4colours`` likewise). The table laid out is
checked against every bin's walls as it grows them (its refusal names how many fit).
"""

from __future__ import annotations

from pathlib import Path

from conftest import mearm_here, one_stderr_line

from mearm.config import load_config
from mearm.config.sections import SceneObject
from mearm.task import run_sort

TALL_REDS = ["task.classes.red.height_cm=2.18"]


def test_a_random_table_is_not_refused_for_the_config_own_tables_walls(tmp_path: Path) -> None:
    done = mearm_here(
        "sort", "--config", "sim_paper_arm", "--set", TALL_REDS[0], "--random", "1",
        "--seed", "1", "--quiet", cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "sorted 1 of 1 objects (simulated)"


def test_a_scene_file_is_not_refused_for_the_config_own_tables_walls(tmp_path: Path) -> None:
    scene = tmp_path / "one.yaml"
    scene.write_text("- {color: green, x: 0, y: 45}\n")
    done = mearm_here(
        "sort", "--config", "sim_paper_arm", "--set", TALL_REDS[0], "--scene", scene,
        "--quiet", cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "sorted 1 of 1 objects (simulated)"


def test_the_table_laid_out_is_still_checked_against_its_own_walls(tmp_path: Path) -> None:
    # four tall reds, as the config's own table holds: their 10.9 cm walls come within
    # 0.37 cm of the jaws at home, less than the paper rig's 1.5 cm
    scene = tmp_path / "reds.yaml"
    scene.write_text("".join(f"- {{color: red, x: {-9 + 6 * i}, y: 40}}\n" for i in range(4)))
    done = mearm_here(
        "sort", "--config", "sim_paper_arm", "--set", TALL_REDS[0], "--scene", scene,
        cwd=tmp_path,
    )  # fmt: skip
    line = one_stderr_line(done, 2)
    assert "reds.yaml: class red: its bin's walls, built 10.9 cm tall" in line, line
    assert line.endswith("give the class fewer objects"), line


def test_the_config_own_table_is_still_checked(tmp_path: Path) -> None:
    done = mearm_here("sort", "--config", "sim_paper_arm", "--set", TALL_REDS[0], cwd=tmp_path)
    line = one_stderr_line(done, 2)
    assert "built to hold its 4 objects (2.18 cm high) stacked" in line, line


def test_run_sort_of_a_table_laid_out_checks_the_config_without_its_own() -> None:
    config = load_config("sim_paper_arm", TALL_REDS)
    scene = [SceneObject(color="green", x=0.0, y=45.0)]
    assert run_sort(config, scene=scene, echo=None).outcome.line() == "sorted 1 of 1 objects"
