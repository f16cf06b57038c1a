"""The benchmark's twin section: its rows on a one-object sort (figures are not checked)."""

from __future__ import annotations

import importlib

import pytest
from conftest import ROOT

from mearm.config import load_config


def _bench():
    """The ``mearm bench`` command's module."""
    return importlib.import_module("mearm.tools.bench")


@pytest.mark.heavy
def test_twin_section_reports_physics_and_whole_sort():
    """One round on the 5-DOF twin with one object: the section's rows, with positive
    figures and the simulated time the sort covered in the notes."""
    bench = _bench()
    assert "twin" in bench.SECTIONS
    path, scene = (
        ROOT / "configs" / "sim_5dof_mujoco.yaml",
        "task.scene=[{color: red, x: 2.0, y: 22.0}]",
    )
    config = load_config(path, [scene])
    rows = bench.twin_rows({"one": config}, 1, {"one": ("--config", str(path), "--set", scene)})
    by_name = {r.name: r for r in rows}
    assert all(r.section == "twin" for r in rows)
    physics = by_name["physics (one): real-time factor"]
    assert physics.value > 0 and physics.unit == "×"
    assert "ms timestep" in physics.note and "s simulated" in physics.note
    sort = by_name["whole sort (one): wall time"]
    assert sort.value > 0 and "sorted 1 of 1" in sort.note
    assert by_name["render (one): per frame"].value > 0
    assert by_name["bare mj_step at rest (one): real-time factor"].value > 0
    process = by_name["whole process (one): real-time factor"]
    assert process.value > 0 and "EXIT STATUS" not in process.note
    assert by_name["whole process (one): real-time factor on the CPU"].value > 0
