"""A place from far out, past a grown wall: the tool rises tilted where it cannot point down.

The 5-DOF arm reaches 27 cm out with its wrist at its limit (-90 deg): from a pick that far
the way over a bin's wall cannot start straight up with the tool pointing down. With the
red bin's walls grown for nine reds, the straight way from the two farthest picks to it
met the green bin's wall, and the way over the top stopped at the wrist's limit: both were
left, ``no route clear of collisions`` (``sim_5dof --random 25 --seed 38002``, the table a
refusal of 500 named, 23 of 25). The way over the top now rises and travels with the tool
tilted where it must, turning down on the way to the bin, checked whole as before.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from conftest import ROOT

from mearm.sort import main

#: Nine reds of that table (the rest taken away while the sort still left the far two).
REDS = [
    (11.8, 10.76), (1.37, 21.24), (0.78, 16.42), (-0.47, 27.46), (9.22, 22.12),
    (4.73, 22.89), (12.76, 24.74), (0.35, 12.68), (-7.14, 23.1),
]  # fmt: skip


def test_far_picks_are_carried_over_a_grown_wall(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
):
    scene = tmp_path / "reds.yaml"
    scene.write_text(yaml.safe_dump([{"color": "red", "x": x, "y": y} for x, y in REDS]))
    code = main(["--config", str(ROOT / "configs" / "sim_5dof.yaml"), "--scene", str(scene)])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "sorted 9 of 9 objects (simulated)" in out
    places = [line for line in out.splitlines() if line.startswith("place ")]
    assert len(places) == 9 and all(" ok " in line for line in places), places
