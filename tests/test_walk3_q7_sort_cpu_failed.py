"""The sort-cpu section's shares of the CPU: no figure made of a run that failed."""

import math

from mearm.tools import bench
from mearm.tools.bench import BenchOptions
from mearm.tools.benchmarks import sort_cpu

SHARES = (
    "import mearm.sort beyond its dependencies: CPU",
    "import mearm.config beyond its dependencies: CPU",
    "the sort beyond its imports: CPU",
)


def _rows_with_failing(monkeypatch, failing: tuple[str, ...], cpu_s: float) -> dict:
    """The section's rows when the command ``failing`` exits 1 after ``cpu_s`` of CPU."""

    def fake_child(argv, env):
        if tuple(argv) == failing:
            return cpu_s, 1.0, 1
        return (
            {bench.DEPS_ARGV: 0.3, ("-c", "import mearm.sort"): 0.5}.get(tuple(argv), 0.4),
            1.0,
            0,
        )

    monkeypatch.setattr(sort_cpu, "child_seconds", fake_child)
    return {r.name: r for r in bench.bench_sort_cpu(BenchOptions(repeat=1))}


def test_a_sort_that_failed_has_no_cost_beyond_its_imports(monkeypatch):
    """A sort that exits 1 late (more CPU than its imports) is no cost of sorting."""
    rows = _rows_with_failing(monkeypatch, bench.SORT_ARGV, 0.9)
    share = rows["the sort beyond its imports: CPU"]
    assert math.isnan(share.value)
    assert "a run failed" in share.note and "'sim sort, 12 objects: CPU'" in share.note
    # the imports' shares came from runs that did their work: still figures
    assert rows["import mearm.sort beyond its dependencies: CPU"].value == 0.5 - 0.3


def test_a_failed_import_of_the_dependencies_is_no_noise(monkeypatch):
    """The peer failing early is said so, not called the timings' noise or a figure."""
    rows = _rows_with_failing(monkeypatch, bench.DEPS_ARGV, 0.05)
    for name in SHARES[:2]:
        assert math.isnan(rows[name].value), name
        assert "a run failed" in rows[name].note, name
        assert "below timing resolution" not in rows[name].note, name
    # the sort (0.4 s) and its imports (0.5 s) both ran: their difference is noise
    assert "below timing resolution" in rows["the sort beyond its imports: CPU"].note
