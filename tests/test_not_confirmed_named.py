"""An object the sort placed but its bin does not hold is named, with where it is.

The walk found ``sorted 6 of 7 objects (simulated; 1 not confirmed in its bin)`` after
every route said ``ok``, with nothing saying which object or where: three 1.5 cm
cylinders stacked in a bin of 3 cm walls, the third above them. The twin knows where
its objects are, and now says so. Since 2026-12-07 the third's place says it, as it
fails (the place reads where the jaws' object went once they opened); an object placed
and then knocked out of its bin is left not confirmed, named where the twin has it.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import run_in_process
from conftest import ROOT

pytestmark = pytest.mark.heavy

#: Three reds on the MeArm v1's arc: stacked in its bin, the third stands 3 to 4.5 cm up.
REDS = (
    "- {color: red, x: 8.7, y: 15.07}\n"
    "- {color: red, x: -5.75, y: 17.69}\n"
    "- {color: red, x: 1.8, y: 17.11}\n"
)


def test_the_one_left_above_the_walls_is_named_where_it_is_by_its_place(tmp_path: Path) -> None:
    (tmp_path / "reds.yaml").write_text(REDS)
    argv = ["sort", "--config", "sim_mearm_v1_mujoco", "--scene", tmp_path / "reds.yaml",
            "--set", "task.classes.red.bin_height_cm=3"]  # fmt: skip
    out = run_in_process(argv, within_s=60, cwd=ROOT)
    assert out.code == 1, out.stderr
    lines = out.stdout.splitlines()
    assert lines[-1] == "sorted 2 of 3 objects (simulated; 1 no longer in the work area)"
    (failed,) = [ln for ln in lines if ln.startswith("place ") and " FAILED " in ln]
    assert ": released, it is over the red bin, above its 3.0 cm walls, at (" in failed, failed


def test_the_one_not_confirmed_in_its_bin_is_named_where_it_is(tmp_path: Path) -> None:
    """red1 is placed (``ok``), then knocked out of its bin while green1 is sorted."""
    (tmp_path / "two.yaml").write_text(
        "- {color: red, x: 0, y: 45}\n- {color: green, x: 5, y: 45}\n"
    )
    argv = ["sort", "--config", "sim_mujoco", "--scene", tmp_path / "two.yaml", "--quiet",
            "--set", "twin.faults=[{kind: knock_object, at_s: 3.0, object: red1}]"]  # fmt: skip
    out = run_in_process(argv, within_s=60, cwd=ROOT)
    assert out.code == 1, out.stderr
    lines = out.stdout.splitlines()
    assert lines[-1] == "sorted 1 of 2 objects (simulated; 1 not confirmed in its bin)"
    (named,) = [ln for ln in lines if ln.startswith("not confirmed in its bin (red): ")]
    assert "in the twin red1 is past the table's edge, at (" in named, named
