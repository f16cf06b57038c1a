"""``mearm learn-colours --camera`` on the MuJoCo twin: taught on the frame detect sees."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from badinput import run_in_process

from mearm.config import load_config

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "sim_mujoco_perspective.yaml"


def _detect(config: Path) -> list[dict]:
    out = run_in_process(["detect", "--config", config, "--camera", "--json"], within_s=30)
    assert out.code == 0, out.stderr
    return json.loads(out.stdout.splitlines()[0])


@pytest.mark.heavy
def test_colours_taught_on_the_twins_camera_find_its_objects(tmp_path: Path) -> None:
    """Each object `detect --camera` reports is clicked, and the taught config's detect
    finds every object of the scene where it lies. (learn-colours read the kinematic
    table's drawing instead of the twin's render: the pixels detect reports as red were
    refused as the table's colour, and clicks on that drawing taught a config that found
    4 of the 12 objects.)"""
    found = _detect(CONFIG)
    scene = load_config(CONFIG).task.scene
    assert len(found) == len(scene) == 12
    clicks = [
        a for d in found for a in ("--sample", f"{d['color']}={d['px'][0]:.0f},{d['px'][1]:.0f}")
    ]
    out = tmp_path / "taught.yaml"
    run = run_in_process(
        ["learn-colours", "--camera", *clicks, "--config", CONFIG, "--out", out], within_s=30
    )
    assert run.code == 0, run.stderr
    taught = load_config(out)
    assert all(c.learned_colour is not None for c in taught.task.classes)
    again = _detect(out)
    assert len(again) == len(scene), again
    for o in scene:
        near = min(
            np.hypot(d["cm"][0] - o.x, d["cm"][1] - o.y) for d in again if d["color"] == o.color
        )
        assert near <= 0.1, (o, again)
