"""A pick whose place cannot be planned lets its object go where the jaws closed.

The walk found the pick logged ``FAILED`` with no reason (and counted in "failed picks")
when the place after it could not be planned, and on the twins the object was lifted
first and let go from the lift's height. The place is now planned from where the lift
will end before the lift: refused, nothing is lifted, the jaws open where they closed,
and the pick is logged unconfirmed (its grip never checked), not failed.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from badinput import run_in_process
from conftest import ROOT

from mearm.task.execute import Executor
from mearm.task.plan import Planner
from mearm.task.sorter import Sorter

pytestmark = pytest.mark.heavy

SCENE = "- {color: red, x: -10.99, y: 49.70}\n"
REFUSED = "the test refuses every place"


def test_a_refused_place_lifts_nothing_and_the_pick_is_not_counted_failed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    plan, stream, outcome = Planner.plan, Executor.stream, Sorter.outcome
    lifted: list[str] = []
    objects: list[np.ndarray] = []

    def refuse_places(self, route, *args, **kwargs):  # type: ignore[no-untyped-def]
        out = plan(self, route, *args, **kwargs)
        if route.step == "place" and route.object_id:  # (not the start-up check's)
            route.failure, route.failure_kind = REFUSED, "unreachable"
        return out

    def watch(self, route, *args, **kwargs):  # type: ignore[no-untyped-def]
        if route.step == "lift":
            lifted.append(route.object_id)
        out = stream(self, route, *args, **kwargs)
        if route.step == "pick":  # where the object stands as the jaws go down on it
            objects.append(self.bus.object_pose("red1").position_cm.copy())
        return out

    def at_the_end(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        objects.append(self.bus.object_pose("red1").position_cm.copy())
        return outcome(self, *args, **kwargs)

    monkeypatch.setattr(Sorter, "outcome", at_the_end)
    monkeypatch.setattr(Planner, "plan", refuse_places)
    monkeypatch.setattr(Executor, "stream", watch)
    (tmp_path / "scene.yaml").write_text(SCENE)
    log = tmp_path / "run.jsonl"
    argv = ["sort", "--config", "sim_mujoco", "--scene", tmp_path / "scene.yaml", "--log", log]
    out = run_in_process(argv, within_s=60, cwd=ROOT)
    assert out.code == 1, out.stderr
    assert lifted == [], "the object was lifted with no place planned"
    lines = out.stdout.splitlines()
    (pick,) = [ln for ln in lines if ln.startswith("pick  ")]
    assert " unconfirmed " in pick and "FAILED" not in pick
    assert f"skip  red1      bin unreachable: {REFUSED}" in lines
    assert any(ln.startswith("routes 1, failed picks 0,") for ln in lines)
    records = [json.loads(ln) for ln in log.read_text().splitlines()]
    (route,) = [r for r in records if r["type"] == "route"]
    assert (route["success"], route["confirmed"], route["why_failed"]) == (False, False, None)
    # let go where the jaws closed: it stands where it stood (the twin's truth)
    (summary,) = [r for r in records if r["type"] == "summary"]
    assert summary["left"] == {"bin_unreachable": 1}
    (before, after) = objects
    assert np.linalg.norm(after - before) < 0.3, (before, after)
