"""The bench's sort-cpu section: each line beside its peer, the ratio beside its target."""

import mearm
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
    assert rows[sort_cpu.PEER_KEY].value == 0.4
    assert "no target" in rows["sim sort CPU / the peer as a shell runs it"].note


def test_the_shell_peer_runs_without_the_thread_mearm_chose(monkeypatch):
    """The peer's child inherits the one OpenBLAS thread importing mearm set; the shell
    peer's does not, unless the user had set it before (then it is theirs, and kept)."""
    envs: dict[str, list[dict[str, str]]] = {}

    def fake_child(argv, env):
        envs.setdefault(" ".join(argv), []).append(dict(env))
        return 0.5, 1.0, 0

    monkeypatch.setattr(sort_cpu, "child_seconds", fake_child)
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "1")
    for set_here, shell_threads in ((True, None), (False, "1")):
        envs.clear()
        monkeypatch.setattr(mearm, "_OPENBLAS_THREAD_SET_HERE", set_here)
        bench.bench_sort_cpu(BenchOptions(repeat=1))
        peer = envs[" ".join(bench.DEPS_ARGV)]
        assert len(peer) == 2 * sort_cpu.SORT_CPU_RUNS  # the peer and the shell peer
        threads = [env.get("OPENBLAS_NUM_THREADS") for env in peer]
        assert threads.count("1") == sort_cpu.SORT_CPU_RUNS * (1 if set_here else 2)
        assert shell_threads in threads


def test_sort_cpu_says_when_a_run_failed(monkeypatch):
    """A child that exits non-zero is named in its row, not hidden in a median."""
    monkeypatch.setattr(sort_cpu, "child_seconds", lambda argv, env: (0.5, 1.0, 1))
    rows = bench.bench_sort_cpu(BenchOptions(repeat=1))
    assert all(
        "EXIT STATUS [1, 1, 1]" in r.note
        for r in rows
        if r.name.endswith(": CPU") and "beyond" not in r.name
    )
    shell = next(r for r in rows if r.name == "sim sort CPU / the peer as a shell runs it")
    assert shell.value != shell.value and "a run failed" in shell.note  # NaN, and why
