"""Picks beside a bin's wall: checked where the claw goes, never made blind, looked at low.

A fixed kit's claw is 0.5-1 cm off its commanded pose; the looks bring it onto the object,
so the way down runs the aim's table-plane shift off the path the collision check saw. Beside
a bin's wall an open jaw then came down on the wall's top and the shoulder stalled: a fault
that stopped the whole scene (kits 21 / 52 / 62, seeds 902, 1510, 2710; docs/twin.md).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ROOT, rays_at_each_looks_height

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.sim.table_collision import collision_model
from mearm.task import looking_picks
from mearm.task.claw_loop import shifted
from mearm.task.looking_picks import WALL_MARGIN_CM, beside_wall
from mearm.task.plan import Planner
from mearm.task.route import Route

KITS = ROOT / "configs" / "sim_mujoco_kits.yaml"
#: An object 1.9 cm from the red bin's wall (where kit 21 at seed 2710 left one), and one
#: in the open.
BY_THE_WALL_CM = (-15.1, 32.75)
IN_THE_OPEN_CM = (0.0, 45.0)
#: The aim the looks gave the pick of the first (kit 21: its claw 0.74 cm off) [cm].
AIM_CM = (0.74, -0.15)


def _way_down(planner: Planner, xy: tuple[float, float], aim_xy=(0.0, 0.0)) -> Route:
    cls = planner.config.task.class_named("red")
    goal = shifted(planner.pick_target(cls, *xy), np.array(aim_xy))
    above = Route("red1", "red", "approach", 1, planner.above_target(goal, 6.0))
    assert planner.plan(above, planner.model.home).planned and above.plan is not None
    down = Route("red1", "red", "pick", 1, goal)
    return planner.plan(down, above.plan.q, target="red1")


def _planner(xy: tuple[float, float]) -> Planner:
    config = load_config(KITS)
    model = ArmModel(config.arm)
    collision = collision_model(config, model)
    collision.set_world([("red1", "red", *xy)])
    return Planner(config, model, collision=collision)


def test_a_way_down_by_a_bin_wall_is_found_and_one_in_the_open_is_not():
    """beside_wall names the bin whose wall the way down passes within the clearance and
    the margin, and nothing for a pick in the open."""
    planner = _planner(BY_THE_WALL_CM)
    down = _way_down(planner, BY_THE_WALL_CM, AIM_CM)
    assert down.planned and down.plan is not None
    assert planner.collision is not None
    assert beside_wall(planner, planner.collision, down) == "red"
    near = min(d for q in down.plan.q_path for c, _, d in planner.collision.bins_at(q))
    assert near < planner.config.task.clearance_cm + WALL_MARGIN_CM
    planner = _planner(IN_THE_OPEN_CM)
    assert planner.collision is not None
    assert beside_wall(planner, planner.collision, _way_down(planner, IN_THE_OPEN_CM)) is None


def test_the_commanded_way_down_can_be_clear_where_the_claw_would_hit_the_wall():
    """Why the check must see where the claw goes: aimed 0.74 cm away from the wall (the
    error the looks saw, kit 21), the commanded way down keeps the clearance; the way down
    at the object, where the looks bring the claw, does not."""
    planner = _planner(BY_THE_WALL_CM)
    assert _way_down(planner, BY_THE_WALL_CM, AIM_CM).planned
    real = _way_down(planner, BY_THE_WALL_CM)
    assert not real.planned and real.failure_kind == "collision"
    assert "bin_red_wall" in (real.failure or "")


def _sort(kit: int, seed: int):
    from mearm.task.rig import run_sort
    from mearm.task.scene import random_scene

    config = load_config(KITS, ["twin.kit.per_trial=false", f"twin.kit.seed={kit}"])
    scene = random_scene(config, 12, seed=seed)
    return run_sort(config, scene=scene, echo=None)  # a fault raises SortAborted


@pytest.mark.slow
def test_an_object_by_a_wall_where_the_claw_goes_is_left_not_the_scene_stopped(monkeypatch):
    """Kit 21, seed 2710: red1, dropped 1.9 cm from the red bin's wall, was picked aimed
    0.63 cm off it and an open jaw landed on the wall's top, the shoulder stalled and the
    scene stopped (8 objects left). Checked where the claw goes, it is left with a reason
    that names the wall, and the rest are sorted. Since the table has rolling friction
    (2026-12-01) that drop lands elsewhere; seed 2733 (kit 21, seeds 2700-2759 searched)
    left red2 by the red bin's wall, the claw 0.58 cm off its aim, until the places came
    down into the bins, and left them, straight (2026-12-07): there red2 was lost on the
    way beside the wall instead. Seed 49930 (kit 21, seeds 49921-49930 searched) leaves
    red2 by the red bin's wall, the claw 0.68 cm off its aim."""
    # the scene as traced, before picks went lower by their own looks (red2 then sorts)
    monkeypatch.setattr(looking_picks, "HIGH_LOOKS_CM", math.inf)
    rays_at_each_looks_height(monkeypatch)  # (and before the looks pooled their heights)
    report = _sort(21, 49930)
    skips = {s.object_id: s for s in report.skipped}
    assert "red2" in skips, [s.reason for s in report.skipped]
    assert skips["red2"].kind == "collision"
    assert "where the claw goes" in skips["red2"].reason
    assert "red bin's wall" in skips["red2"].reason
    assert report.outcome.n_objects <= 12
    assert report.outcome.n_sorted >= 10


@pytest.mark.slow
def test_a_pick_by_a_wall_where_the_camera_cannot_see_the_claw_is_not_made_blind():
    """Kit 52, seed 1510: red1 lies 1.9 cm from the blue bin's wall at the edge of the
    camera's view; the claw's marker is not seen over it, its error is unknown, and the
    jaw came down on the wall's top (11 objects left by the fault). It is not picked
    blind: looked at aside, where the camera sees the claw, it is picked with that
    correction (SortAborted would stop the test on a stall), and so are the rest."""
    report = _sort(52, 1510)
    blind = [s.object_id for s in report.skipped if "not picked blind" in s.reason]
    assert blind == []
    assert report.outcome.n_objects <= 12
    assert report.outcome.n_sorted >= 11


#: An object by the blue bin's wall far out (kit 82 left it at seed 901): over it, and at
#: the low point above the walls, the claw's marker is at the frame's top edge.
FAR_BY_THE_WALL_CM = (-14.3, 56.6)


def _eye(planner: Planner):
    from mearm.task.claw_loop import ClawEye
    from mearm.vision.calibration import camera_geometry

    config = planner.config
    camera = camera_geometry(config.calibration, config.camera)
    return ClawEye(config, planner.model, camera, read=lambda: None, hold=lambda s: None)


def _in_frame(eye, config, centre_cm) -> bool:
    from mearm.task.looking_picks import WALL_MARGIN_CM

    r = eye.marker.size_cm / 2.0 + WALL_MARGIN_CM
    square = np.array([[-r, -r, 0.0], [r, -r, 0.0], [r, r, 0.0], [-r, r, 0.0]])
    px = eye.camera.project(np.asarray(centre_cm) + square)
    return bool(np.all((px >= 0) & (px < [config.camera.width_px, config.camera.height_px])))


def test_a_look_aside_finds_the_nearest_point_where_the_marker_is_in_view():
    """At the low point over a far object by the blue bin the marker (with the claw's
    error around it) is not wholly in the frame; in_view_shift moves it, toward the
    image's centre and no farther than needed, to where it is."""
    from mearm.task.looking_picks import ASIDE_STEP_CM, MAX_ASIDE_CM, in_view_shift

    planner = _planner(FAR_BY_THE_WALL_CM)
    config = planner.config
    down = _way_down(planner, FAR_BY_THE_WALL_CM)
    assert down.plan is not None
    q_over = down.plan.q_path[0]
    z_cm = planner.safe_height_cm(q_over)
    up = np.array([0.0, 0.0, z_cm - down.target.position_cm[2]])
    low = Route("red1", "red", "approach", 1, shifted(down.target, up))  # as aim_low's
    assert planner.plan(low, q_over).planned and low.plan is not None
    eye = _eye(planner)
    centre = eye.planned_cm(low.plan.q)
    assert not _in_frame(eye, config, centre)
    shift = in_view_shift(eye, config, low.plan.q)
    assert shift is not None
    assert 0 < np.linalg.norm(shift) <= MAX_ASIDE_CM
    assert shift[2] == 0.0
    assert _in_frame(eye, config, centre + shift)
    smaller = shift * (1.0 - ASIDE_STEP_CM / np.linalg.norm(shift))
    assert not _in_frame(eye, config, centre + smaller)  # the nearest such point


@pytest.mark.slow
def test_picks_by_the_wall_where_the_claw_is_out_of_view_look_aside_not_left():
    """Kit 21, seed 1710: red1 and red2 lie by the blue bin's wall far out, where the
    claw's marker is above the frame over them and at the low point; they were left, not
    picked blind. Looked at a few centimetres aside, where the camera sees the claw, they
    are picked, and no pick is left blind."""
    report = _sort(21, 1710)
    blind = [s.object_id for s in report.skipped if "not picked blind" in s.reason]
    assert blind == []
    assert report.outcome.n_objects <= 12
    assert report.outcome.n_sorted >= 11
