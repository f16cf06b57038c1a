"""The vision package's public names, and the benchmark's rows (figures are not checked)."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

import mearm.vision
from mearm.tools.vision_bench import run_detection_peers, run_vision_bench

VISION = Path(mearm.vision.__file__).parent


def test_every_exported_name_exists() -> None:
    for name in mearm.vision.__all__:
        assert getattr(mearm.vision, name) is not None, name
    assert sorted(mearm.vision.__all__) == sorted(set(mearm.vision.__all__))


@pytest.mark.heavy
def test_vision_does_not_import_the_simulator() -> None:
    """Importing vision loads no part of mearm.sim (the layer above) ..."""
    code = "import sys, mearm.vision; print(sorted(m for m in sys.modules if 'mearm.sim' in m))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_no_vision_module_imports_the_simulator_at_module_level() -> None:
    """... and no vision module imports it at its top level (only inside functions)."""
    for path in sorted(VISION.glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in tree.body:
            if isinstance(node, ast.If):  # ``if TYPE_CHECKING:`` blocks are not run
                continue
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            assert not any(n == "mearm.sim" or n.startswith("mearm.sim.") for n in names), path


def test_no_colour_is_named_in_vision_or_sim() -> None:
    """Classes come from the config: no vision or sim module names a colour in code."""
    colour = re.compile(r"\b(red|green|blue|yellow|orange|purple|magenta|cyan)\b")
    for path in sorted([*VISION.glob("*.py"), *(VISION.parent / "sim").glob("*.py")]):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        docstrings = {
            id(n.body[0].value)
            for n in ast.walk(tree)
            if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef))
            and n.body
            and isinstance(n.body[0], ast.Expr)
        }
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                if id(node) in docstrings:
                    continue
                assert not colour.search(node.value.lower()), (path.name, node.value)


def test_bench_rows_have_the_shape_tools_bench_expects() -> None:
    """One round: every row is {section, name, value, unit, note}; the two recipes agree."""
    rows = run_vision_bench(repeat=1)
    assert all(set(r) == {"section", "name", "value", "unit", "note"} for r in rows)
    assert all(r["section"] == "vision" and r["value"] > 0 for r in rows)
    assert "same detections as the NumPy/SciPy recipe" in rows[0]["note"]
    assert {r["name"] for r in rows} >= {"detect, OpenCV (best)", "paper (MATLAB)"}


def test_peer_rows_time_both_recipes_on_every_object_count() -> None:
    """One round on 3 and 6 objects: both recipes, and the detector with taught colours,
    find them all; a per-object slope each."""
    rows = run_detection_peers(repeat=1, counts=(3, 6))
    assert all(set(r) == {"section", "name", "value", "unit", "note"} for r in rows)
    names = {r["name"] for r in rows}
    for n in (3, 6):
        assert {f"detect {n} objects, mearm", f"detect {n} objects, 8-bit inRange recipe"} <= names
        mine = next(r for r in rows if r["name"] == f"detect {n} objects, mearm")
        assert f"found {n} and {n} of {n}" in mine["note"]
        taught = next(r for r in rows if r["name"] == f"detect {n} objects, mearm, taught colours")
        assert f"found {n} of {n}" in taught["note"]
    assert {r["unit"] for r in rows if r["name"].endswith("per object")} == {"µs/object"}
