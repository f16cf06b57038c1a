"""``init-config --of MINE``: the twin keeps the maker's classes, bins and table, and sorts.

The twin once wrote the reference's simulated table (``task.scene``) over the maker's
whatever it held: a config of classes of its own (``ruby``, ``lime``), with a table of
them, made a twin that did not load (``task.scene.0.color: 'red' is not a class``, exit
2), with either simulated rig, as did the packaged ``sim_shapes`` (cubes, cylinders and
prisms); and the twin of ``sim_4colours`` sorted its red, green and blue objects, never
its yellow ones. Each case here runs the real ``init-config`` and then sorts the twin it
wrote, as docs/maker-path.md ("Try your own arm in simulation") promises.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from conftest import mearm_here

from mearm.config import load_config

#: The maker's own classes over the starter config (docs/maker-path.md, step 1), with a
#: table of them where the MeArm v1 picks.
RUBY_LIME = """\
extends: my_arm.yaml
task:
  classes:
    - name: ruby
      hue_bands_deg: [{lo_deg: 330.0, hi_deg: 15.0}]
      draw_rgb: [200, 30, 35]
      bin_cm: [-15.0, 16.0, 6.0]
      diameter_cm: 1.5
      height_cm: 1.5
      grip_height_cm: 1.0
    - name: lime
      hue_bands_deg: [{lo_deg: 75.0, hi_deg: 165.0}]
      draw_rgb: [30, 160, 60]
      bin_cm: [15.0, 16.0, 6.0]
      diameter_cm: 1.5
      height_cm: 1.5
      grip_height_cm: 1.0
"""
RUBY_LIME_SCENE = """\
  scene:
    - {color: ruby, x: 8.7, y: 15.07}
    - {color: ruby, x: -5.75, y: 17.69}
    - {color: lime, x: 1.8, y: 17.11}
    - {color: lime, x: -8.7, y: 15.07}
"""


def _starter(folder: Path) -> None:
    done = mearm_here("init-config", "--arm", "mearm_v1", "--rig", "uno", "my_arm.yaml", cwd=folder)
    assert done.returncode == 0, done.stderr


def _sorts(folder: Path, twin: str, count: int) -> None:
    done = mearm_here("sort", "--config", twin, cwd=folder)
    assert done.returncode == 0, done.stderr
    assert f"sorted {count} of {count} objects (simulated)" in done.stdout, done.stdout


@pytest.mark.parametrize("rig", ["sim_mujoco", "sim"])
def test_a_twin_of_a_config_with_classes_and_a_table_of_its_own_keeps_them(tmp_path, rig):
    _starter(tmp_path)
    (tmp_path / "my_arm2.yaml").write_text(RUBY_LIME + RUBY_LIME_SCENE, encoding="utf-8")
    argv = ["--of", "my_arm2.yaml", "--arm", "mearm_v1", "--rig", rig, "my_twin2.yaml"]
    done = mearm_here("init-config", *argv, cwd=tmp_path)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert "  1. mearm sort --config my_twin2.yaml" in done.stdout
    twin = load_config(tmp_path / "my_twin2.yaml")
    assert twin.task.class_names == ["ruby", "lime"]
    assert twin.task.scene == load_config(tmp_path / "my_arm2.yaml").task.scene
    # the table is the maker's, in the file the twin extends: an edit there is simulated
    written = yaml.safe_load((tmp_path / "my_twin2.yaml").read_text(encoding="utf-8"))
    assert "scene" not in written.get("task", {})
    _sorts(tmp_path, "my_twin2.yaml", 4)


def test_a_twin_of_a_packaged_config_of_other_classes_keeps_its_table(tmp_path):
    done = mearm_here("init-config", "--of", "sim_shapes", "--rig", "sim", "t.yaml", cwd=tmp_path)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert load_config(tmp_path / "t.yaml").task.scene == load_config("sim_shapes").task.scene
    _sorts(tmp_path, "t.yaml", 12)


def test_a_twin_keeps_the_objects_of_every_class(tmp_path):
    """sim_4colours' yellow objects too, not the reference's red, green and blue alone."""
    done = mearm_here("init-config", "--of", "sim_4colours", "--rig", "sim", "t.yaml", cwd=tmp_path)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    scene = load_config(tmp_path / "t.yaml").task.scene
    assert scene == load_config("sim_4colours").task.scene
    assert sum(obj.color == "yellow" for obj in scene) == 4
    _sorts(tmp_path, "t.yaml", 16)


def test_a_twin_of_an_empty_table_of_other_classes_says_which_key_to_give(tmp_path):
    """A real rig's ``task.scene: []`` borrows the reference's table, when its objects
    are of the maker's classes; of ruby and lime they are not: the twin is written, and
    one warning line names the maker's file and key, as for a bin out of reach."""
    _starter(tmp_path)
    (tmp_path / "my_arm3.yaml").write_text(RUBY_LIME + "  scene: []\n", encoding="utf-8")
    argv = ["--of", "my_arm3.yaml", "--arm", "mearm_v1", "--rig", "sim", "my_twin3.yaml"]
    done = mearm_here("init-config", *argv, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    (warning,) = done.stderr.splitlines()
    assert warning.startswith(
        "mearm init-config: warning: mearm sort would refuse it as it is: my_arm3.yaml: "
        "task.scene: [], and the simulated table of configs/sim_mearm_v1.yaml holds red, "
        "green, blue objects, not your classes (ruby, lime): give task.scene objects"
    ), warning
    assert "  1. change what the warning names, in my_arm3.yaml or my_twin3.yaml" in done.stdout
    assert load_config(tmp_path / "my_twin3.yaml").task.class_names == ["ruby", "lime"]
    sort = mearm_here("sort", "--config", "my_twin3.yaml", "--random", "4", cwd=tmp_path)
    assert sort.returncode == 0 and "sorted 4 of 4 objects (simulated)" in sort.stdout, sort


def test_a_twin_of_a_table_its_camera_does_not_see_says_so(tmp_path):
    """The maker's own objects, laid out for another arm's camera: named by their file."""
    argv = ["--of", "sim_shapes", "--arm", "mearm_v1", "--rig", "sim", "t.yaml"]
    done = mearm_here("init-config", *argv, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    (warning,) = done.stderr.splitlines()
    assert "sim_shapes: task.scene[0] (red_cube at x -10.99, y 49.7 cm): outside the " in warning


def test_a_physical_twin_of_other_classes_grips_each_as_the_reference_twin_does(tmp_path):
    """The paper arm's twin reference sets its classes by name (``red: {grip_height_cm:
    null}``: grip at half the object's height); over sim_shapes' cubes, cylinders and
    prisms that named no class ("task.classes.red: no item named 'red'", exit 2). Each of
    the maker's classes takes what the reference gives all of its own alike."""
    argv = ["--of", "sim_shapes", "--rig", "sim_mujoco", "t.yaml"]
    done = mearm_here("init-config", *argv, cwd=tmp_path)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    twin = load_config(tmp_path / "t.yaml")
    assert twin.simulator == "mujoco"
    assert twin.task.class_names == ["red_cube", "red_cylinder", "green_prism"]
    assert [c.grip_height_cm for c in twin.task.classes] == [None, None, None]
    assert twin.task.scene == load_config("sim_shapes").task.scene
    _sorts(tmp_path, "t.yaml", 12)


def test_a_physical_twin_of_a_config_that_writes_no_arm_keeps_the_built_in_arm(tmp_path):
    """sim_4colours writes no ``arm:``: its arm is the built-in one (the paper's). The
    twin's ``arm: {joints: …}`` (the reference twin's servo limits) was all the arm there
    was, and the twin did not load ("arm.name: required but missing; …"), its errors
    about the file written, not the maker's, though sim_4colours itself sorts."""
    argv = ["--of", "sim_4colours", "--rig", "sim_mujoco", "t.yaml"]
    done = mearm_here("init-config", *argv, cwd=tmp_path)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    twin, mine = load_config(tmp_path / "t.yaml"), load_config("sim_4colours")
    assert twin.simulator == "mujoco" and twin.arm.name == mine.arm.name == "mearm_paper"
    assert [j.dh for j in twin.arm.joints] == [j.dh for j in mine.arm.joints]
    reference = load_config("sim_mujoco").arm.joints
    assert [j.servo for j in twin.arm.joints] == [j.servo for j in reference]
    assert twin.task.class_names == ["red", "green", "blue", "yellow"]
    assert twin.task.scene == mine.task.scene
    _sorts(tmp_path, "t.yaml", 16)


def test_a_physical_twin_of_a_config_that_writes_no_classes_keeps_the_built_in_ones(tmp_path):
    """sim_paper_arm writes neither ``arm:`` nor ``task.classes``: the reference twin's
    class settings by name (``red: {grip_height_cm: null}`` …) were then all the classes
    there were ("task.classes: Input should be a valid list"). The twin writes the
    built-in classes out, with those settings."""
    argv = ["--of", "sim_paper_arm", "--rig", "sim_mujoco", "t.yaml"]
    done = mearm_here("init-config", *argv, cwd=tmp_path)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    twin, mine = load_config(tmp_path / "t.yaml"), load_config("sim_paper_arm")
    assert twin.task.classes == load_config("sim_mujoco").task.classes
    assert [c.model_copy(update={"grip_height_cm": None}) for c in mine.task.classes] == list(
        twin.task.classes
    )
    assert twin.arm.name == mine.arm.name and twin.task.clearance_cm == mine.task.clearance_cm
    _sorts(tmp_path, "t.yaml", 12)
