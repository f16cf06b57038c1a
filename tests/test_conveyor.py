"""Sorting from a conveyor belt: tracked objects picked where they will be."""

from __future__ import annotations

import json
import math

import pytest
from belt_sort import sort_measuring_grips
from conftest import ROOT

from mearm.config import config_from_dict, load_config
from mearm.sim import SimCamera
from mearm.task.conveyor import ConveyorSorter, GripAim
from mearm.task.rig import open_rig

KINEMATIC = ROOT / "configs" / "sim_conveyor_kinematic.yaml"
TWIN = ROOT / "configs" / "sim_conveyor.yaml"


def _config(path, **belt):
    data = load_config(path).model_dump(mode="json")
    for key, value in belt.items():
        if isinstance(value, dict):
            data["belt"][key] = {**data["belt"][key], **value}
        else:
            data["belt"][key] = value
    return config_from_dict(data)


def test_the_kinematic_conveyor_sorts_every_object_it_brings():
    """Three objects at 3 cm/s, 3 to 4 s apart: each tracked, intercepted and sorted; the
    jaws close within 0.05 cm of where the object is."""
    arrivals = {"count": 3, "first_s": 0.5, "min_gap_s": 3.0, "max_gap_s": 4.0}
    config = _config(KINEMATIC, speed_cm_s=3.0, arrivals=arrivals)
    report, errors = sort_measuring_grips(config)
    assert report.complete and report.outcome.n_sorted == 3, report.outcome.line()
    assert len(errors) == 3 and max(errors) < 0.05, errors


def test_an_object_that_leaves_the_belt_first_is_missed():
    """A short, fast belt carries its object off before the arm can get there: it is
    reported missed on the belt and the run is not complete (exit 1)."""
    arrivals = {"count": 1, "first_s": 0.5, "max_gap_s": 1.0, "min_gap_s": 1.0}
    config = _config(KINEMATIC, length_cm=6.0, speed_cm_s=20.0, arrivals=arrivals)
    report, errors = sort_measuring_grips(config)
    assert not report.complete and errors == []
    assert report.outcome.left == {"missed_belt": 1}
    assert "1 missed on the belt" in report.outcome.line()
    assert [s.kind for s in report.skipped] == ["missed_belt"]
    assert report.skipped[0].reason.startswith("missed on the belt")


@pytest.mark.slow
def test_the_twin_conveyor_sorts_what_it_brings():
    """The physical twin: three objects at 2 cm/s, 4 to 5 s apart, gripped on the moving
    belt by the contacts and counted in their bins by the physics (within 0.5 cm: the
    camera's parallax on their tops)."""
    arrivals = {"count": 3, "first_s": 0.5, "min_gap_s": 4.0, "max_gap_s": 5.0}
    report, errors = sort_measuring_grips(_config(TWIN, arrivals=arrivals))
    assert report.outcome.n_sorted == 3, report.outcome.line()
    assert len(errors) == 3 and max(errors) < 0.5, errors


def test_mearm_sort_reports_a_miss_in_its_log_and_exits_1(tmp_path):
    """``mearm sort`` on a belt too short to catch its object: exit 1, the last line and
    the run log's skip and summary say missed on the belt. (8 cm at 20 cm/s: seen four
    times, its velocity learnt from the last three, before it would pass the end; a 6 cm
    belt carries it off before that, its track lost.)"""
    from badinput import run_in_process

    log = tmp_path / "run.jsonl"
    sets = ["belt.length_cm=8", "belt.speed_cm_s=20", "belt.arrivals.count=1"]
    sets += ["belt.arrivals.first_s=0.5", "belt.arrivals.min_gap_s=1", "belt.arrivals.max_gap_s=1"]
    argv = ["sort", "--config", str(KINEMATIC), "--log", str(log), "--quiet"]
    out = run_in_process([*argv, *(a for s in sets for a in ("--set", s))], within_s=10)
    assert out.code == 1
    assert out.line == "mearm sort: sorted 0 of 1 objects (simulated; 1 missed on the belt)"
    records = [json.loads(line) for line in log.read_text().splitlines()]
    (skip,) = [r for r in records if r["type"] == "skip"]
    assert skip["reason"].startswith("missed on the belt: it would be")
    assert records[-1]["type"] == "summary" and records[-1]["left"] == {"missed_belt": 1}


class _LateCamera(SimCamera):
    """A simulated camera whose frames show the belt as it was ``late_s`` before the read:
    each object on the belt drawn where the belt had it then."""

    def __init__(self, config, world, late_s):
        super().__init__(config, world)
        self.late_s = late_s

    def _read(self):
        belt, moved = self.world.belt, []
        for o in self.world.table_objects():
            if belt.carries(o.x_cm, o.y_cm):
                moved.append((o, o.x_cm, o.y_cm))
                o.x_cm, o.y_cm = (o.x_cm, o.y_cm) - belt.velocity_cm_s * self.late_s
        try:
            return super()._read()
        finally:
            for o, x, y in moved:
                o.x_cm, o.y_cm = x, y


@pytest.mark.parametrize(("latency_s", "within_cm"), [(0.3, 0.05), (0.0, None)])
def test_the_cameras_latency_is_taken_into_account(latency_s, within_cm):
    """Frames 0.3 s late at 3 cm/s: with camera.latency_s = 0.3 the jaws close within
    0.05 cm of the object; told none, they close 0.9 cm (v x 0.3 s) behind it."""
    arrivals = {"count": 1, "first_s": 0.5, "min_gap_s": 1.0, "max_gap_s": 1.0}
    data = _config(KINEMATIC, speed_cm_s=3.0, arrivals=arrivals).model_dump(mode="json")
    data["camera"]["latency_s"] = latency_s
    config = config_from_dict(data)
    errors = []
    with open_rig(config) as rig:
        camera = _LateCamera(config, rig.world, 0.3)

        def measure(aim: GripAim) -> None:
            errors.append(
                min(math.dist(aim.aim_cm, (o.x_cm, o.y_cm)) for o in rig.world.table_objects())
            )

        ConveyorSorter(config, camera, rig.bus, model=rig.model, echo=None, in_bins=rig.in_bins,
                       on_grip=measure).run()  # fmt: skip
    if within_cm is not None:
        assert len(errors) == 1 and errors[0] < within_cm, errors
    else:
        assert len(errors) == 1 and errors[0] == pytest.approx(0.9, abs=0.05), errors
