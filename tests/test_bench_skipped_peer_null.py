"""``mearm bench --only ik``: the skipped Robotics Toolbox row has no figure, not a 0.

Without roboticstoolbox the row "RTB ik_LM (C++)" said ``"value": 0.0`` in the JSON: a
measurement that did not run read as a time of zero. It is null there and ``—`` in the
table, as every row not measured is.
"""

from __future__ import annotations

import math
import sys

from mearm.config import load_config
from mearm.tools import bench
from mearm.tools.benchmarks.bench_base import BenchOptions


def test_the_skipped_peer_row_is_null_not_zero(monkeypatch):
    monkeypatch.setitem(sys.modules, "roboticstoolbox", None)  # import raises ImportError
    rows = bench.ik_peer_rows(load_config("sim"), BenchOptions(repeat=1), n_targets=5)
    (skipped,) = [r for r in rows if r.name == "RTB ik_LM (C++)"]
    assert math.isnan(skipped.value) and skipped.note.startswith("skipped: ")
    assert bench._json_row(skipped)["value"] is None
    (line,) = [line for line in bench.table("m", rows) if "RTB ik_LM (C++)" in line]
    assert "—" in line and "skipped" in line and "0.00" not in line
    # the rows that read the peer's figures: no ratio to it, the target kept and not met
    assert bench.summary(rows).startswith("targets: 0 met, 1 not met")
