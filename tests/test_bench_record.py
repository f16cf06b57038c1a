"""The bench's record section: recorded walls beside the unrecorded one and the target."""

from pathlib import Path

from mearm.tools import bench
from mearm.tools.bench import BenchOptions
from mearm.tools.benchmarks import record_bench


def _fake_children(monkeypatch, walls: dict[str, float], status: int = 0) -> list[tuple[str, ...]]:
    calls: list[tuple[str, ...]] = []

    def fake_child(argv, env):
        calls.append(tuple(argv))
        kind = "h264" if "h264" in argv else "av1" if "--record" in argv else "bare"
        return 2.0 * walls[kind], walls[kind], status

    monkeypatch.setattr(record_bench, "child_seconds", fake_child)
    return calls


def test_record_rows_put_each_codec_beside_the_unrecorded_run(monkeypatch):
    """Each recorded wall over the unrecorded one, in percent, with the target; interleaved."""
    calls = _fake_children(monkeypatch, {"bare": 30.0, "av1": 75.0, "h264": 54.0})
    rows = {r.name: r for r in bench.bench_record(BenchOptions(repeat=2))}
    assert rows["recorded, AV1 over unrecorded: wall"].value == 100.0 * (75.0 / 30.0 - 1)
    h264 = rows["recorded, H.264 over unrecorded: wall"]
    assert abs(h264.value - 80.0) < 1e-9 and "target ≤ +100 %" in h264.note
    assert rows["unrecorded: CPU"].value == 60.0
    assert len(calls) == 6 and "--record" not in calls[0] and "--record" not in calls[3]
    datasets = [c[c.index("--record") + 1] for c in calls if "--record" in c]
    assert len(set(datasets)) == 4  # every recorded run into a new directory
    assert all(Path(d).name.startswith("ds-") for d in datasets)
    assert not any("EXIT STATUS" in r.note for r in rows.values())


def test_record_says_when_a_run_failed(monkeypatch):
    """A run that exits non-zero is named in its row, not hidden in a median."""
    _fake_children(monkeypatch, {"bare": 1.0, "av1": 1.0, "h264": 1.0}, status=2)
    rows = bench.bench_record(BenchOptions(repeat=1))
    assert all(
        "EXIT STATUS [2]" in r.note
        for r in rows
        if r.name.endswith(": wall") and "over" not in r.name
    )
