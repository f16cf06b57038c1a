"""The vision package's public names, and the benchmark's rows (figures are not checked)."""

from __future__ import annotations

import mearm.vision
from mearm.vision.bench import run_vision_bench


def test_every_exported_name_exists() -> None:
    for name in mearm.vision.__all__:
        assert getattr(mearm.vision, name) is not None, name
    assert sorted(mearm.vision.__all__) == sorted(set(mearm.vision.__all__))


def test_bench_rows_have_the_shape_tools_bench_expects() -> None:
    """One round: every row is {section, name, value, unit, note}; the two recipes agree."""
    rows = run_vision_bench(repeat=1)
    assert all(set(r) == {"section", "name", "value", "unit", "note"} for r in rows)
    assert all(r["section"] == "vision" and r["value"] > 0 for r in rows)
    assert "same detections as the NumPy/SciPy recipe" in rows[0]["note"]
    assert {r["name"] for r in rows} >= {"detect, OpenCV (best)", "paper (MATLAB)"}
