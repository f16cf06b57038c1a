"""The planner checks its routes against the bin walls the twin built, not the config's.

The twin builds each bin's walls to hold the table's objects of its class stacked
(:func:`mearm.kinematics.bodies.wall_height_m`). A sort of ``--random N`` or ``--scene
FILE`` lays out another table than the config's ``task.scene``, and until 2026-12-05 the
sorter built its collision model from the config's: on the paper arm's twin with 21
objects (7 a class) the walls stood 8 cm high and the planner checked its routes against
5 cm ones. A carry to the blue bin from near the base cleared the walls it knew by 3 cm;
a jaw met the real wall, the elbow stalled and the sort stopped (``mearm sort --config
sim_mujoco --random 21 --seed 54000953``: 18 of 21, on two fresh seeds of four as well).
"""

from __future__ import annotations

import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.kinematics.bodies import TableContents, wall_height_m
from mearm.task.rig import run_sort
from mearm.task.scene import random_scene
from mearm.task.sorter import Sorter


class _Built(Exception):
    """Raised in place of the sort once the sorter is built: the test has what it needs."""


@pytest.mark.parametrize(
    ("name", "objects"),
    [("sim_mujoco", 21), ("sim_5dof_mujoco", 12), ("sim_shapes_mujoco", 9)],
)
def test_the_planners_walls_are_the_ones_the_twin_built(
    name: str, objects: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Another count of a class than the config's own scene holds: both see the same walls."""
    config = load_config(ROOT / "configs" / f"{name}.yaml")
    scene = random_scene(config, objects, seed=5500001)
    built: dict[str, dict[str, float]] = {}

    def opened(rig) -> None:
        built["twin"] = dict(rig.bus._bin_tops_m)

    def run(self: Sorter):
        table = self.collision.table
        built["planner"] = {c.name: wall_height_m(c, table.objects(c.name)) for c in table.classes}
        raise _Built

    monkeypatch.setattr(Sorter, "run", run)
    with pytest.raises(_Built):
        run_sort(config, scene=scene, echo=None, on_open=opened)
    own = {c.name: wall_height_m(c, sum(o.color == c.name for o in config.task.scene))
           for c in config.task.classes}  # fmt: skip
    assert built["twin"] != own  # the walls grew with the scene: the case this is about
    assert built["planner"] == built["twin"]


@pytest.mark.slow
def test_a_21_object_table_on_the_paper_arms_twin_is_sorted_whole() -> None:
    """The seed whose elbow stalled on the blue bin's wall: every object in its bin."""
    config = load_config(ROOT / "configs" / "sim_mujoco.yaml")
    report = run_sort(config, scene=random_scene(config, 21, seed=54000953), echo=None)
    assert report.outcome.n_sorted == 21, report.outcome.left
    assert report.complete


@pytest.mark.parametrize(("task", "objects"), [("pick_place", None), ("sort", 21)])
def test_an_environments_refusals_see_the_walls_its_episode_built(
    task: str, objects: int | None
) -> None:
    """The Gymnasium twin refuses a command whose way meets a bin or the table: checked
    against the walls each episode's twin built (one object: lower than the config's own
    scene's; 21: higher), not those of the config's own scene."""
    from mearm.envs import TwinEnv

    options = {} if objects is None else {"objects": objects}
    env = TwinEnv(config="sim_mujoco", task=task, obs_type="state", **options)
    try:
        env.reset(seed=5500002)
        assert env.twin is not None
        table = env.collision.table
        planner = {c.name: wall_height_m(c, table.objects(c.name)) for c in table.classes}
        assert planner == env.twin._bin_tops_m
    finally:
        env.close()


def test_the_kinematic_rigs_collision_faults_see_the_walls_of_the_table_laid_out() -> None:
    """The kinematic rig faults a move that touches a bin (``SimCollisionError``), checked
    against the walls of the table laid out: 6 objects (2 a class) stand 3 cm walls where
    the config's own 12 stand 5 cm, and the planner plans over the 3 cm ones."""
    from mearm.task.rig import open_rig

    config = load_config(ROOT / "configs" / "sim.yaml")
    scene = random_scene(config, 6, seed=5500003)
    with open_rig(config, scene) as rig:
        table = TableContents.of(rig.bus.config.task)  # what its collision model is built of
    assert [table.objects(c) for c in table.class_names] == [2, 2, 2]


def test_a_random_table_keeps_its_picks_clear_of_the_walls_it_will_have(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``random_scene`` keeps each pick's tool clear of the bins: of the walls the table
    being drawn will stand (18 objects on the 5-DOF twin, 6 a class: 7 cm), not of the
    config's own scene's (3 a class: 4 cm). Seed 54200009 placed an object whose pick
    came within the clearance of the taller walls."""
    from mearm.task import scene as scenes

    config = load_config(ROOT / "configs" / "sim_5dof_mujoco.yaml")
    seen: list[list[int]] = []
    build = scenes.collision_model

    def recorded(*args, **kwargs):
        model = build(*args, **kwargs)
        seen.append([model.table.objects(c) for c in model.table.class_names])
        return model

    monkeypatch.setattr(scenes, "collision_model", recorded)
    drawn = random_scene(config, 18, seed=54200009)
    assert seen and all(counts == [6, 6, 6] for counts in seen), seen  # (its walls' check too)
    monkeypatch.setattr(scenes, "_table_of", lambda config, colors: TableContents.of(config.task))
    assert random_scene(config, 18, seed=54200009) != drawn  # the walls made the difference


def test_a_bin_given_its_height_stands_that_tall_for_the_planner_and_the_twin() -> None:
    """``bin_height_cm`` (a real rig's bins as measured): the planner's walls and the
    twin's are that tall, whatever the table holds; the other classes' still grow."""
    from mearm.kinematics import ArmModel
    from mearm.sim.table_collision import collision_model
    from mearm.sim.twin.twin_bus import TwinArm

    config = load_config(
        ROOT / "configs" / "sim_mujoco.yaml", ["task.classes.blue.bin_height_cm=6.5"]
    )
    for objects in (3, 21):
        laid = config.with_scene(random_scene(config, objects, seed=5500004))
        table = collision_model(laid, ArmModel(laid.arm)).table
        planner = {c.name: wall_height_m(c, table.objects(c.name)) for c in table.classes}
        twin = TwinArm(laid)
        assert planner == twin._bin_tops_m
        assert planner["blue"] == pytest.approx(0.065)
    assert planner["red"] == pytest.approx(0.08)  # 7 reds stacked, and one more


def test_a_bin_taller_than_where_its_objects_are_released_is_refused_at_load() -> None:
    """Walls above an object's bottom as the jaws let it go would meet it on the way in."""
    from mearm.errors import ConfigError

    with pytest.raises(ConfigError, match=r"task\.classes\.blue\.bin_height_cm: 9 cm walls reach "
                       r"above the bottom of an object released at bin_cm z = 20 cm \(8\.24 cm "
                       r"above the table\): at most 8\.24 cm, or raise bin_cm z"):  # fmt: skip
        load_config(ROOT / "configs" / "sim_mujoco.yaml", ["task.classes.blue.bin_height_cm=9"])
