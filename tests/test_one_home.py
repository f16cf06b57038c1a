"""One fact, one home: a unit is defined once in the package, and imported elsewhere."""

from __future__ import annotations

import ast
import functools

import pytest
from conftest import ROOT

#: Facts that must have exactly one definition, and its module.
HOMES = {"M_PER_CM": "mearm/kinematics/chain.py", "RAD_PER_DEG": "mearm/kinematics/chain.py"}


@functools.cache
def _top_level_names() -> dict[str, list[str]]:
    """Name → every module of the package that assigns it at its top level."""
    where: dict[str, list[str]] = {}
    for path in sorted((ROOT / "mearm").rglob("*.py")):
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            targets = node.targets if isinstance(node, ast.Assign) else []
            if isinstance(node, ast.AnnAssign):
                targets = [node.target]
            for t in targets:
                if isinstance(t, ast.Name):
                    where.setdefault(t.id, []).append(path.relative_to(ROOT).as_posix())
    return where


@pytest.mark.parametrize("name", sorted(HOMES))
def test_a_unit_is_defined_once(name: str) -> None:
    assert _top_level_names().get(name) == [HOMES[name]]


def test_the_scan_sees_definitions() -> None:
    """It finds an assignment where one is and none where none is (so the test can fail)."""
    names = _top_level_names()
    assert "mearm/kinematics/chain.py" in names["M_PER_CM"]
    assert "NOT_A_NAME_ANYWHERE_IN_MEARM" not in names
