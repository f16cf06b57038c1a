"""A release's way up counts only what lies within the arm's reach, not a bin behind it.

``mearm sort --config configs/sim_4colours.yaml --set task.classes.green.height_cm=4``
grows the green bin's walls to 20 cm for its four greens. The yellow bin stands 32 cm out
at 112 deg about the base, the green bin 45 cm out at 114 deg: on the same azimuth, well
beyond the arm over the yellow bin (its shapes reach 35 cm out). The yellows' places were
refused, ``bin unreachable: collision: the jaws opened at the release have no way up:
needs shoulder = 136.55 deg`` (``sorted 12 of 16``): the way up from the release aimed
over the green bin's walls, 33 cm, and the height over what lies under it there counted
every wall on that azimuth from the base's axis out, the green bin's too. A way straight
up keeps the TCP where it is and the arm reaches about as far all the way: the walls
beyond that reach are not under it (the way up is still checked whole).
"""

from __future__ import annotations

import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.sim.table_collision import collision_model
from mearm.sort import main
from mearm.task.plan import Planner
from mearm.task.route import Route

FOUR = ROOT / "configs" / "sim_4colours.yaml"
TALL_GREENS = "task.classes.green.height_cm=4"


def test_a_yellow_is_released_with_the_green_bins_tall_walls_behind_it() -> None:
    config = load_config(FOUR, [TALL_GREENS])
    model = ArmModel(config.arm)
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm)
    planner = Planner(config, model, collision)
    yellow = config.task.class_named("yellow")
    collision.set_world([], opening_cm=yellow.diameter_cm, held=("yellow1", "yellow"))
    place = Route("yellow1", "yellow", "place", 1, planner.place_target(yellow))
    planner.plan_place(place, model.home)
    assert place.planned, place.failure
    assert place.plan is not None
    q = place.plan.q
    with collision.released(config.arm.tool.gripper.open_cm):
        # over the green bin's walls is out of reach there, and on the same azimuth
        assert not planner.way_up(q).planned
        tcp = model.fk_cm(q)
        assert collision.clear_height_between_cm(q, tcp) == pytest.approx(
            collision.clear_height_cm(q)
        )
        assert collision.clear_height_between_cm(q, tcp, within_reach=True) < float(tcp[2])


@pytest.mark.heavy
def test_the_tall_greens_leave_the_yellows_sorted(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["--config", str(FOUR), "--set", TALL_GREENS])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "sorted 16 of 16 objects (simulated)" in out, out
    places = [ln for ln in out.splitlines() if ln.startswith("place yellow")]
    assert len(places) == 4 and all(" ok " in ln for ln in places), places
