"""A belt seed that brings many of one class: the twin's bin walls say why they are tall.

The twin builds each bin's walls to hold its class's objects stacked. The reference twin
belt (``configs/sim_conveyor.yaml``, 20 objects) with ``belt.arrivals.seed=997012`` brings
12 greens: the green bin's walls are 13 cm, over the 12.2 cm its objects are released at,
and the sort is refused (exit 2). The line said only "raise bin_cm z", for a config whose
bins serve every other seed: it now names how many the walls hold and that the seed drew
them (4.5 % of seeds 997000-997199 draw 12 or more of one class).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import run_in_process

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.heavy
def test_bin_walls_too_tall_for_a_belt_seed_name_the_count_and_the_seed(
    capfd: pytest.CaptureFixture[str],
) -> None:
    """In this process (a refusal before the twin starts); its stderr the command's lines
    and what was written to the file descriptor (C code's), as a process's would be."""
    capfd.readouterr()
    out = run_in_process(
        ["sort", "--config", "configs/sim_conveyor.yaml", "--set", "belt.arrivals.seed=997012",
         "--quiet"],
        within_s=30, cwd=ROOT,
    )  # fmt: skip
    stderr = capfd.readouterr().err + out.stderr
    assert out.code == 2, stderr
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    assert "class green:" in lines[0]
    assert "below the bin's 13 cm walls" in lines[0]
    assert "its 12 objects stacked" in lines[0]
    assert "the belt brings 12 of its 20, as belt.arrivals.seed 997012" in lines[0]
    # the belt fills the table: its count and its seed are the levers, not the class's objects
    assert lines[0].endswith(
        "or bring fewer objects (belt.arrivals.count) or draw another belt.arrivals.seed"
    ), lines[0]
    assert "Traceback" not in stderr
