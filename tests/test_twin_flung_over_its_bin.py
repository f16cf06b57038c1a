"""A twin's place is ``ok`` only when the object lands in its bin.

``mearm sort --config sim_mujoco --scene S --set task.classes.blue.diameter_cm=1``, S one
blue object: the place printed ``ok`` and the sort's closing count said "sorted 0 of 1
objects (simulated; 1 not confirmed in its bin)", the twin having the disc beside the bin
or past the table's edge. The count was right, the place was not, in two ways:

- at (-5, 52) cm, as the arm stopped over the blue bin the 1 cm disc came out of the jaws
  at 1 m/s, 5 cm above the bin's 2 cm walls, and flew on past the bin. The place read it,
  over the bin in the plane and moving, as one falling in;
- at (-8, 54) cm the disc was still in the jaws over the bin, swinging, and the jaws let
  it go onto the table beside the bin. The place read only that the jaws held it.

Now both places are ``FAILED`` with where the disc is, and the sort leaves it as no
longer in the work area. The place reads it once it rests: the disc let go beside the
bin rolls on past the table's edge.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import ROOT, run_main

from mearm import sort
from mearm.config import Config, load_config
from mearm.kinematics.bodies import object_name
from mearm.sim.twin.mjcf import M_PER_CM
from mearm.sim.twin.twin_bus import TwinArm
from mearm.task.pick_place import place_failure

CONFIG = ROOT / "configs" / "sim_mujoco.yaml"
SMALL_BLUE = "task.classes.blue.diameter_cm=1"


@pytest.fixture(scope="module")
def one_disc() -> Config:
    return load_config(CONFIG, ["task.scene=[{color: blue, x: -5, y: 52}]", SMALL_BLUE])


def _throw(arm: TwinArm, centre_cm: tuple[float, float, float], velocity_m_s: tuple) -> None:
    """Put blue1 at ``centre_cm``, flying at ``velocity_m_s``, and awake."""
    m, d = arm.model, arm.data
    joint = m.joint(object_name("blue1"))
    q, v = int(joint.qposadr[0]), int(joint.dofadr[0])
    d.qpos[q : q + 3] = np.array(centre_cm) * M_PER_CM
    d.qvel[v : v + 6] = [*velocity_m_s, 0.0, 0.0, 0.0]
    d.qfrc_applied[v] = 1e-300  # wakes its tree, as the twin's belt does
    mujoco.mj_forward(m, d)
    d.qfrc_applied[v] = 0.0


def test_a_disc_flying_past_its_bin_is_not_brought_to_it(one_disc) -> None:
    """Where and how fast the disc left the jaws in the sort (over the blue bin's middle,
    7.2 cm up, 1 m/s away from the arm): not held, and the physics has it land past the
    bin. Dropped inside the walls, it is held (it falls in), and it lands in the bin."""
    x, y, _ = one_disc.task.class_named("blue").bin_cm
    arm = TwinArm(one_disc)
    _throw(arm, (x - 0.5, y + 0.1, 7.2), (-1.02, 0.14, -0.24))
    assert arm.held_ids() == frozenset()
    assert arm.held_classes() == frozenset()
    arm.settle(1.0)
    assert "blue1" not in arm.objects_in_bin()
    assert arm.in_own_bin("blue1") is None

    arm = TwinArm(one_disc)
    _throw(arm, (x, y, 1.5), (0.0, 0.0, -0.05))
    assert arm.held_classes() == frozenset({"blue"})
    arm.settle(1.0)
    assert arm.in_own_bin("blue1") == "blue"


def test_a_held_disc_let_go_beside_its_bin_is_not_placed(one_disc) -> None:
    """Held over the bin, the place reads where the jaws' object landed once they opened."""
    x, y, _ = one_disc.task.class_named("blue").bin_cm
    arm = TwinArm(one_disc)
    _throw(arm, (x - 6.0, y, 0.5), (0.0, 0.0, 0.0))  # beside the bin's wall, at rest
    got = place_failure(arm, "blue", held=True, gripped=frozenset({"blue1"}))
    assert got == f"released, it is on the table at ({x - 6.0:.1f}, {y:.1f}) cm"
    _throw(arm, (x, y, 0.5), (0.0, 0.0, 0.0))  # on the bin's floor
    assert place_failure(arm, "blue", held=True, gripped=frozenset({"blue1"})) is None


@pytest.mark.heavy
@pytest.mark.parametrize(
    ("x", "y", "why"),
    [
        (-5, 52, "over the bin the jaws held nothing of its class: it was lost on the way and "),
        (-8, 54, "released, it is past the table's edge, at "),
    ],
    ids=["flung out as the arm stopped", "let go beside the bin"],
)
def test_the_place_of_a_disc_that_misses_its_bin_fails(x, y, why, tmp_path, capsys) -> None:
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"- {{color: blue, x: {x}, y: {y}}}\n")
    code, out, _ = run_main(
        capsys, sort.main, "--config", CONFIG, "--scene", scene, "--set", SMALL_BLUE
    )
    (place,) = (line for line in out.splitlines() if line.startswith("place blue1"))
    assert " FAILED " in place and f" ms: {why}" in place, place
    assert "not confirmed in its bin" not in out, out
    assert out.strip().endswith("sorted 0 of 1 objects (simulated; 1 no longer in the work area)")
    assert code == 1
