"""The ``record`` section: a twin experiment recorded as fast as the twin runs, beside it bare.

The same :data:`RECORD_TRIALS`-trial experiment of the MuJoCo twin (seed
:data:`RECORD_SEED`) runs unrecorded, recorded as AV1 (the default) and as H.264
(``--record-codec h264``), interleaved, each in its own interpreter; the walls are
compared with the target of issue 41 (:data:`RECORD_OVER_TARGET_PCT`). The CPU columns
count the encoder's process too (it is the experiment's child, waited for).
"""

from __future__ import annotations

import os
import statistics
import tempfile
from pathlib import Path

from mearm.tools.benchmarks.bench_base import BenchOptions, Row, against, child_seconds, section

#: Trials of the recorded experiment (12 objects each in ``sim_mujoco``).
RECORD_TRIALS = 3
#: The experiment's base seed (docs/datasets.md measures 20 trials of it).
RECORD_SEED = 101
#: Most rounds of the three runs, whatever ``--repeat`` says (about a minute each).
RECORD_ROUNDS = 2
#: A recorded run's wall over the unrecorded one's must stay at or below this [%].
RECORD_OVER_TARGET_PCT = 100.0
#: The runs: the experiment's arguments after ``--log``, by name.
RECORD_RUNS: dict[str, tuple[str, ...]] = {
    "unrecorded": (),
    "recorded, AV1": ("--record", "{dataset}"),
    "recorded, H.264": ("--record", "{dataset}", "--record-codec", "h264"),
}


def record_argv(name: str, folder: Path, round_: int) -> tuple[str, ...]:
    """``python`` arguments of run ``name`` (:data:`RECORD_RUNS`), writing under ``folder``."""
    tag = f"{round_}-{name.split(',')[-1].strip().replace('.', '').lower()}"
    extra = (a.format(dataset=folder / f"ds-{tag}") for a in RECORD_RUNS[name])
    return (
        "-m", "mearm", "experiment", "--config", "sim_mujoco", "--trials", str(RECORD_TRIALS),
        "--seed", str(RECORD_SEED), "--log", str(folder / f"log-{tag}.jsonl"), *extra,
    )  # fmt: skip


@section("record")
def bench_record(options: BenchOptions) -> list[Row]:
    """Wall and CPU of the twin experiment unrecorded and recorded (AV1, H.264), same run.

    Each run is a whole ``mearm experiment`` of :data:`RECORD_TRIALS` trials; the rounds
    (``--repeat``, at most :data:`RECORD_ROUNDS`) interleave the three; medians reported.
    """
    rounds = max(1, min(options.repeat, RECORD_ROUNDS))
    runs: dict[str, list[tuple[float, float, int]]] = {name: [] for name in RECORD_RUNS}
    with tempfile.TemporaryDirectory(prefix="mearm-bench-record-") as tmp:
        for round_ in range(rounds):
            for name in RECORD_RUNS:
                runs[name].append(
                    child_seconds(record_argv(name, Path(tmp), round_), os.environ.copy())
                )
    note = f"{RECORD_TRIALS} trials of sim_mujoco, seed {RECORD_SEED}; median of {rounds}"
    rows: list[Row] = []
    wall: dict[str, float] = {}
    for name, measured in runs.items():
        failed = [r[2] for r in measured if r[2] != 0]
        extra = f"; EXIT STATUS {failed}" if failed else ""
        wall[name] = statistics.median(r[1] for r in measured)
        cpu = statistics.median(r[0] for r in measured)
        rows.append(Row("record", f"{name}: wall", wall[name], "s", f"{note}{extra}"))
        rows.append(Row("record", f"{name}: CPU", cpu, "s", "the experiment and its encoder"))
    ran = {name: all(r[2] == 0 for r in measured) for name, measured in runs.items()}
    for name in list(RECORD_RUNS)[1:]:
        over = 100.0 * (wall[name] / wall["unrecorded"] - 1.0)
        target = f"≤ +{RECORD_OVER_TARGET_PCT:g} %"
        note = f"same run; target {target}"
        row = Row("record", f"{name} over unrecorded: wall", over, "%", note)
        valid = ran[name] and ran["unrecorded"]  # a failed run measures nothing
        rows.append(against(row, target, at_most=RECORD_OVER_TARGET_PCT, valid=valid))
    return rows
