"""``mearm sort --save-mjcf PATH`` over a file already there keeps the old one as PATH.bak.

A second run, or a name shared with the user's own model, used to replace the file
silently: what was there was lost. Now the old file is kept beside it and named on stdout
(``wrote PATH.bak (the old PATH)``) before the new one, as ``--save-calibration`` does; a
run that writes the same bytes again keeps no backup (it would lose nothing, and would
replace an older ``.bak`` that still differs).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.badinput import run_in_process

pytestmark = pytest.mark.heavy  # two whole sorts (one object each)


def _sort(scene: Path, mjcf: Path) -> list[str]:
    out = run_in_process(["sort", "--quiet", "--scene", scene, "--save-mjcf", mjcf], within_s=30)
    assert out.code == 0, out.stdout + out.stderr
    return out.stdout.splitlines()


def test_save_mjcf_keeps_the_file_it_replaces(tmp_path: Path) -> None:
    """The user's own file survives as .bak; the same scene saved again adds no backup."""
    scene = tmp_path / "scene.yaml"
    scene.write_text("- {color: red, x: -10.99, y: 49.70}\n")
    mjcf = tmp_path / "scene.xml"
    mjcf.write_text("<mujoco model='mine'/>\n")
    bak = tmp_path / "scene.xml.bak"

    lines = _sort(scene, mjcf)
    assert lines[:2] == [f"wrote {bak} (the old {mjcf})", f"wrote {mjcf}"], lines
    assert lines[-1] == "sorted 1 of 1 objects (simulated)"
    assert bak.read_text() == "<mujoco model='mine'/>\n"
    new = mjcf.read_text()
    assert 'name="obj_red1"' in new

    lines = _sort(scene, mjcf)  # the same scene again: nothing to lose
    assert lines[0] == f"wrote {mjcf}", lines
    assert bak.read_text() == "<mujoco model='mine'/>\n"
    assert mjcf.read_text() == new
