"""The bench's sort-cpu section: each line beside its peer, the ratio beside its target."""

from mearm.tools import bench
from mearm.tools.bench import BenchOptions
from mearm.tools.benchmarks import sort_cpu


def test_sort_cpu_rows_put_the_sort_beside_its_dependencies(monkeypatch):
    """The ratio is the sort's median CPU over the dependencies' import, with the target."""
    seconds = {
        bench.SORT_ARGV: [0.9, 0.8, 1.0],
        bench.DEPS_ARGV: [0.4, 0.5, 0.3],
        ("-c", "import mearm.sort"): [0.6, 0.6, 0.6],
        ("-c", f"{bench.DEPS_ARGV[1]}; import mearm.config"): [0.5, 0.5, 0.5],
    }
    calls: list[tuple[str, ...]] = []

    def fake_child(argv, env):
        calls.append(tuple(argv))
        times = seconds.get(tuple(argv), [0.05])
        return times[sum(1 for c in calls if c == tuple(argv)) % len(times)], 1.0, 0

    monkeypatch.setattr(sort_cpu, "child_seconds", fake_child)
    rows = {r.name: r for r in bench.bench_sort_cpu(BenchOptions(repeat=1))}
    ratio = rows["sim sort CPU / its dependencies' import CPU"]
    assert ratio.value == 0.9 / 0.4 and "target ≤ 2×" in ratio.note
    assert rows["import mearm.sort beyond its dependencies: CPU"].value == 0.6 - 0.4
    assert rows["the sort beyond its imports: CPU"].value == 0.9 - 0.6
    assert rows["import mearm.config beyond its dependencies: CPU"].value == 0.5 - 0.4
    assert any("sim_5dof" in c for c in calls)
    assert not any("EXIT STATUS" in r.note for r in rows.values())


def test_sort_cpu_says_when_a_run_failed(monkeypatch):
    """A child that exits non-zero is named in its row, not hidden in a median."""
    monkeypatch.setattr(sort_cpu, "child_seconds", lambda argv, env: (0.5, 1.0, 1))
    rows = bench.bench_sort_cpu(BenchOptions(repeat=1))
    assert all(
        "EXIT STATUS [1, 1, 1]" in r.note
        for r in rows
        if r.name.endswith(": CPU") and "beyond" not in r.name
    )
