"""A detour goes over what lies under its way, where over everything is out of reach.

``mearm init-config --arm mearm_v1 --rig sim`` writes a config whose bins' walls may be
raised to 5 cm (its note). With the red bin's raised so (``task.classes.0.bin_height_cm=5``)
the blue bin became unreachable: the straight way from each blue's pick met the blue bin's
wall, and the way over the top travelled at the height that clears every wall on the
table, the red bin's 5 cm ones too, 7.1 cm, which the MeArm cannot reach over the blue
bin (its elbow past -20 deg): ``sorted 4 of 6``. The red bin stands at (-15, 16) cm, well
off the way from the blues (at 72 and 96 deg about the base) to their bin (at 90 deg). When
every height over the top fails, the way over is tried once more over only what lies
under it: what the arm, turning about its base, sweeps between the two azimuths.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.sim.table_collision import collision_model
from mearm.sort import main
from mearm.task.plan import DETOUR_MARGIN_CM, Planner
from mearm.task.route import Route

V1 = ROOT / "configs" / "sim_mearm_v1.yaml"
RED_WALLS = "task.classes.0.bin_height_cm=5"


def _planner(*sets: str) -> Planner:
    config = load_config(V1, list(sets))
    model = ArmModel(config.arm)
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm)
    return Planner(config, model, collision)


def _blue1s_place(planner: Planner) -> tuple[Route, np.ndarray]:
    """blue1 picked beside blue2 (the MeArm v1's scene), and its place planned from there."""
    collision, model = planner.collision, planner.model
    assert collision is not None
    blue = planner.config.task.class_named("blue")
    collision.set_world([("blue2", "blue", -1.8, 17.11)])
    pick = Route("blue1", "blue", "pick", 1, planner.pick_target(blue, 5.75, 17.69))
    assert planner.plan(pick, model.home, target="blue1").planned, pick.failure
    assert pick.plan is not None
    collision.set_world(
        [("blue2", "blue", -1.8, 17.11)], opening_cm=blue.diameter_cm, held=("blue1", "blue")
    )
    place = Route("blue1", "blue", "place", 1, planner.place_target(blue))
    planner.plan_place(place, pick.plan.q)
    return place, pick.plan.q


@pytest.mark.heavy
def test_the_red_bins_taller_walls_leave_the_blues_sorted(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code = main(["--config", str(V1), "--set", RED_WALLS])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "sorted 6 of 6 objects (simulated)" in out, out
    places = [ln for ln in out.splitlines() if ln.startswith("place blue")]
    assert len(places) == 2 and all(" ok " in ln for ln in places), places


def test_a_blues_place_goes_over_the_blue_bin_not_the_red_ones_walls() -> None:
    planner = _planner(RED_WALLS)
    collision = planner.collision
    assert collision is not None
    place, q = _blue1s_place(planner)
    assert place.planned, place.failure
    assert place.plan is not None and place.detour_cm is not None
    # lower than over the red bin's walls, which the arm cannot reach over the blue bin
    assert place.detour_cm < planner.safe_height_cm(q)
    # checked as every plan is: within the limits, and clear all the way
    assert planner.pose_allowed(place.plan.q_path)
    assert collision.first_contact(place.plan.q_path) is None


def test_what_the_arm_sweeps_about_its_base_is_under_the_way() -> None:
    # the blue bin's walls the tallest: from the green bin (47 deg) to the red (133 deg)
    # the TCP's straight line keeps 3.6 cm in front of the blue bin, but the arm turns
    # about its base, its links over the blue bin (at 90 deg); from over the green bin
    # to a pick beside it, nothing but the green bin and the objects by the way count
    planner = _planner("task.classes.2.bin_height_cm=5")
    collision, model = planner.collision, planner.model
    assert collision is not None
    config = planner.config
    green, red = config.task.class_named("green"), config.task.class_named("red")
    collision.set_world([("red1", "red", -5.75, 17.69), ("green1", "green", 8.7, 15.07)])
    result = planner.solver.solve(planner.place_target(green), model.home)
    q = result.q
    across = collision.clear_height_between_cm(q, red.bin_cm)
    assert across == pytest.approx(collision.clear_height_cm(q))
    near = collision.clear_height_between_cm(q, (8.7, 15.07, 1.0))
    assert near + DETOUR_MARGIN_CM < planner.safe_height_cm(q)
    assert near > 4.5  # the green bin's walls, with the tool hanging below the TCP


def test_a_refusal_names_the_way_over_what_lies_under_it_too() -> None:
    # the blue bin's own walls raised to 4.8 cm as well: over them alone is 6.9 cm, out
    # of reach over the blue bin too; the refusal named only the height over the red
    # bin's walls (7.1 cm), as though lowering those would let the blues in
    planner = _planner(RED_WALLS, "task.classes.2.bin_height_cm=4.8")
    collision = planner.collision
    assert collision is not None
    place, q = _blue1s_place(planner)
    assert not place.planned and place.failure_kind == "collision"
    under = collision.clear_height_between_cm(q, place.target.position_cm) + DETOUR_MARGIN_CM
    assert under < planner.safe_height_cm(q)
    reach = r"needs elbow = [-\d.]+ deg, outside its limits \[-150, -20\] deg"
    assert re.search(
        rf"; over the top at {planner.safe_height_cm(q):.1f} cm: {reach}; "
        rf"over what lies under the way at {under:.1f} cm: {reach}$",
        place.failure or "",
    ), place.failure
