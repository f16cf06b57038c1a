"""A miss with the claw seen high lowers the next attempt; the drop that held is kept."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.task.claw_loop import GRIP_HOLD_CM, UNMOVED_CM, GripDrops

KITS = ROOT / "configs" / "sim_mujoco_kits.yaml"
HERE = np.array([0.0, 48.0])


def test_a_miss_over_an_unmoved_object_with_the_claw_seen_high_lowers_the_retry():
    drops = GripDrops()
    # the looks saw the marker 0.3 cm high; the open jaws reached 0.55 cm down its side
    retry = drops.missed("red1", 0.0, 0.1, [0.2, 0.4], overlap_cm=0.55)
    assert retry == pytest.approx(0.55 - GRIP_HOLD_CM)
    assert drops.drop_cm("red1", HERE) == retry
    # the looks measure more than the overlap says: the measured step
    assert drops.missed("red2", 0.0, 0.1, [0.7, 0.9], overlap_cm=0.55) == pytest.approx(0.8)
    # a second miss lowers again, from the drop it had
    assert drops.missed("red1", retry, 0.1, [0.3], overlap_cm=1.0) > retry


def test_a_miss_that_moved_the_object_or_saw_the_claw_low_is_not_lowered():
    drops = GripDrops()
    assert drops.missed("red1", 0.0, UNMOVED_CM + 0.5, [0.5, 0.6], overlap_cm=0.55) == 0.0
    assert drops.missed("red2", 0.0, 0.0, [-0.3, -0.1], overlap_cm=0.55) == 0.0
    assert drops.missed("red3", 0.0, 0.0, [], overlap_cm=0.55) == 0.0  # no look: no lowering
    assert drops.missed("red4", 0.2, 2.0, [0.5], overlap_cm=0.55) == 0.2  # keeps what it had


def test_the_drop_that_held_is_kept_for_picks_nearby_and_a_first_time_pick_is_not_lowered():
    drops = GripDrops()
    drops.held("blue1", HERE, 0.0)  # held at the planned height: nothing learned
    assert drops.drop_cm("blue2", HERE) == 0.0
    drops.missed("red1", 0.0, 0.0, [0.5], overlap_cm=0.55)
    drops.held("red1", HERE, 0.4)
    assert "red1" not in drops.retry_cm
    assert drops.drop_cm("green1", HERE + [3.0, 0.0]) == pytest.approx(0.4)
    assert drops.drop_cm("green2", HERE + [30.0, 0.0]) == 0.0  # out of the neighbourhood


def _sort_kit_21():
    from mearm.task.rig import open_rig
    from mearm.task.sorter import Sorter

    # kit 21 leaves the claw 0.3-0.8 cm high, more the farther out: far out at y = 49
    # the jaws close above a 1 cm object; near the base at y = 34 they hold it
    scene = "[{color: red, x: 6.2, y: 33.9}, {color: red, x: 0.6, y: 48.9}, {color: blue, x: 4.9, y: 46.9}]"  # noqa: E501
    config = load_config(
        KITS, ["twin.kit.per_trial=false", "twin.kit.seed=21", f"task.scene={scene}"]
    )
    with open_rig(config) as rig:
        sorter = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None,
                        in_bins=rig.in_bins)  # fmt: skip
        report = sorter.run()
    return sorter, report


@pytest.mark.slow
def test_a_kit_whose_claw_is_high_misses_lowers_and_later_picks_start_lower():
    sorter, report = _sort_kit_21()
    assert sorter.eye is not None
    picks = [r for r in report.routes if r.step == "pick" and r.executed]
    by_place = {}
    for r in picks:
        by_place.setdefault(r.object_id, []).append(r)
    kept = sorter.eye.drops.kept
    assert kept.places_cm, "nothing learned"
    # the far red missed at the planned height, then held lower, and that drop was kept
    far = next(o for o in sorter._objects if o.y_cm > 48)
    tries = by_place[far.id]
    assert not tries[0].success and tries[-1].success, [r.success for r in tries]
    d = [np.linalg.norm(p - [far.x_cm, far.y_cm]) for p in kept.places_cm]
    assert min(d) < 1.0 and kept.corrections_cm[int(np.argmin(d))][0] > GRIP_HOLD_CM
    # the blue beside it started from that drop and held at the first attempt
    blue = next(o for o in sorter._objects if o.class_name == "blue")
    assert [r.success for r in by_place[blue.id]] == [True]
    # the near red held at the first attempt, at the planned height: nothing kept there
    near = next(o for o in sorter._objects if o.y_cm < 40)
    assert [r.success for r in by_place[near.id]] == [True]
    assert all(np.linalg.norm(p - [near.x_cm, near.y_cm]) > 5 for p in kept.places_cm)
    # every lowered pick was planned with the open jaws above the table
    lowest = [sorter.collision.tool_lowest_cm(r.plan.q)[0] for r in picks if r.plan is not None]
    assert min(lowest) >= 0.0, lowest
    assert report.outcome.n_sorted == 3
    assert report.outcome.n_seen <= 3
