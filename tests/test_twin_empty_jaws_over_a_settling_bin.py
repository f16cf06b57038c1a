"""Jaws that closed on nothing carried nothing: a place is not ``ok`` because an object
placed before is still settling in the bin.

``mearm sort --config sim_mujoco_lamp --random 9 --seed 28050 --set twin.lamp.diffuse=0.4
--set twin.camera.height_cm=60`` (found by a fresh-seed sweep of the twin's variants: the
camera 5 cm higher than its calibration): green1's jaws closed beside it and pushed it
8 cm aside, out of the camera's reach, so the pick read ``ok``; over the green bin the
twin counted the green placed just before, not yet at rest among the others, as just let
fall there, and the place said ``ok`` too. Only the sort's end found green1 on the table
("not confirmed in its bin"). The place now says the jaws had closed on nothing.
"""

from __future__ import annotations

import pytest
from conftest import ROOT, run_main

from mearm import sort
from mearm.runlog import read_runlog

CONFIG = ROOT / "configs" / "sim_mujoco_lamp.yaml"
NOTHING = "over the bin the jaws held nothing of its class: they had closed on nothing at the pick"


@pytest.mark.heavy
def test_a_place_whose_jaws_closed_on_nothing_fails_over_a_settling_bin(tmp_path, capsys) -> None:
    log = tmp_path / "run.jsonl"
    code, out, err = run_main(
        capsys, sort.main, "--config", CONFIG, "--random", 9, "--seed", 28050,
        "--set", "twin.lamp.diffuse=0.4", "--set", "twin.camera.height_cm=60", "--log", log,
    )  # fmt: skip
    (place,) = (line for line in out.splitlines() if line.startswith("place green1"))
    assert " FAILED " in place and place.endswith(f" ms: {NOTHING}"), place
    assert "not confirmed in its bin" not in out, out
    assert code == 1, err
    (trial,) = read_runlog(log, strict=True).trials
    assert trial.summary is not None
    (route,) = (r for r in trial.routes if r.object_id == "green1" and r.step == "place")
    assert (route.success, route.why_failed) == (False, NOTHING)
    places = [r for r in trial.routes if r.step == "place" and r.success]
    assert sum(trial.summary.sorted.values()) == len(places) == 7
