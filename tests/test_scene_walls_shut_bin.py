"""A table whose objects grow a bin's walls past the arm's reach is refused before a sort.

Both simulators build each bin's walls to hold its class's objects stacked. On the MeArm
v1, three reds raise the red bin's walls to 6 cm, the height it releases at: carrying an
object over them, straight or over the top, meets a wall. ``mearm sort --config
sim_mearm_v1 --random 7`` laid the table out, picked each red and blue object and left it
(``sorted 2 of 7 objects (simulated; 5 bin out of reach)``, exit 1) where the twin's config
refused the same table at once (exit 2). Now the kinematic simulator refuses it too, with
the class, its walls and how many objects the walls take. The same three reds given as the
config's own table (``task.scene``) were sorted and left, each after its pick (``sorted 1
of 7``, exit 1): the walls stand above the bottom of a red held at the release, and that
table is refused at the start as well.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import run_main

from mearm import sort
from mearm.config import load_config
from mearm.task.scene import SceneError, check_scene, load_scene, random_scene


def test_random_objects_whose_walls_shut_a_bin_are_refused_before_the_sort(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code, out, err = run_main(
        capsys, sort.main, "--config", "sim_mearm_v1", "--random", 7, "--seed", 12021
    )
    assert code == 2 and out == ""
    (line,) = err.strip().splitlines()
    assert ": error: class red: its bin's walls, built 6 cm tall " in line
    assert "to hold its 3 objects stacked, leave the arm no way in with one held" in line
    assert "bin_red_wall" in line  # what the carry meets
    assert "ask for 6 or fewer" in line and "bin_height_cm" in line


def test_a_scene_file_whose_walls_shut_a_bin_is_refused(tmp_path: Path) -> None:
    config = load_config("sim_mearm_v1")
    path = tmp_path / "three_reds.yaml"
    path.write_text(
        "- {color: red, x: 8.7, y: 15.07}\n"
        "- {color: red, x: -5.75, y: 17.69}\n"
        "- {color: red, x: 1.8, y: 17.11}\n"
    )
    with pytest.raises(SceneError, match=r"three_reds\.yaml: class red: its bin's walls"):
        check_scene(config, load_scene(path, config.task.class_names), str(path))


#: The MeArm v1's six objects and a third red one between them, as the config's own table.
OWN_SCENE = (
    "task.scene=[{color: red, x: 8.7, y: 15.07}, {color: red, x: -5.75, y: 17.69}, "
    "{color: red, x: 0.0, y: 18.6}, {color: green, x: 1.8, y: 17.11}, "
    "{color: green, x: -8.7, y: 15.07}, {color: blue, x: 5.75, y: 17.69}, "
    "{color: blue, x: -1.8, y: 17.11}]"
)


def test_the_configs_own_table_whose_walls_shut_a_bin_is_refused_before_the_sort(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code, out, err = run_main(capsys, sort.main, "--config", "sim_mearm_v1", "--set", OWN_SCENE)
    assert code == 2 and out == ""
    (line,) = err.strip().splitlines()
    assert ": error: task.scene: class red: its bin's walls, built 6 cm tall " in line
    # both ways in named: straight, and over the top
    assert "collision: held red comes within" in line and "; over the top at " in line
    assert line.endswith(
        "give the class fewer objects, or set the class's bin_height_cm (task.classes)"
    )


def test_walls_of_their_own_take_the_same_table() -> None:
    """The remedy the line names: walls given a height lay the seven objects out."""
    config = load_config("sim_mearm_v1", overrides=["task.classes.red.bin_height_cm=4.5"])
    assert len(random_scene(config, 7, seed=12021)) == 7


def test_grown_walls_the_arm_reaches_over_are_laid_out() -> None:
    """Sixteen objects grow the paper arm's walls; it still reaches into every bin."""
    assert len(random_scene(load_config("sim"), 16, seed=12031)) == 16


def test_a_full_table_names_the_count_the_walls_take_too() -> None:
    """Seven fit on the MeArm v1's table; seven are refused by the walls: six is named."""
    with pytest.raises(SceneError) as err:
        random_scene(load_config("sim_mearm_v1"), 30, seed=0)
    text = str(err.value)
    assert "at most 7 fit in 20000 draws with seed 0, of which the bins' walls take 6" in text
    assert text.endswith("ask for 6 or fewer")
