"""A round object beside a bin's wall: the wrist roll turns the jaws to clear the wall."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mearm.config import load_config
from mearm.config.sections import SceneObject
from mearm.task.plan import Planner
from mearm.task.rig import open_rig
from mearm.task.route import Route
from mearm.task.sorter import Sorter

ROOT = Path(__file__).resolve().parent.parent


def test_a_disc_beside_the_blue_bins_wall_is_picked_with_the_jaws_turned() -> None:
    """The 5-DOF arm, picks via a point above: a green disc 0.85 cm from the blue bin's
    wall (where one fell from the jaws in the kit twin, seed 7309), whose pad passes the
    wall within the clearance with the jaws as planned, is picked with them turned along
    the wall and ends in its bin; the roll is part of the checked plan."""
    config = load_config(ROOT / "configs" / "sim_5dof.yaml", ["task.approach_height_cm=6.0"])
    plan = Planner.plan
    picks: list[tuple[float, float]] = []  # each planned pick: its end's roll [deg], gap [cm]

    def watched(self: Planner, route: Route, *args: Any, **kwargs: Any) -> Route:
        plan(self, route, *args, **kwargs)
        if route.step == "pick" and route.planned:
            assert self.collision is not None and route.plan is not None
            roll = self.model.chain.names.index("wrist_roll")
            gap = min(d for q in route.plan.q_path for _, _, d in self.collision.bins_at(q))
            picks.append((float(np.rad2deg(route.plan.q[roll])), gap))
        return route

    scene = [SceneObject(color="green", x=-10.85, y=17.93)]
    Planner.plan = watched  # type: ignore[method-assign]
    try:
        with open_rig(config, scene) as rig:
            report = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None).run()
            objects = rig.world.objects
    finally:
        Planner.plan = plan  # type: ignore[method-assign]
    assert [(o.id, o.bin) for o in objects] == [("green1", "green")], report.skipped
    assert picks, "no pick was planned"
    roll_deg, gap_cm = picks[-1]
    assert abs(roll_deg) >= 29.9  # turned off the jaws' planned 0°
    assert gap_cm >= config.task.clearance_cm - 1e-9
