"""The project's benchmarks: timings, measured in one run, printed (never asserted).

    mearm bench [--only SECTION ...] [--repeat N] [--json] [--out FILE [--force]]

Each part of the project registers a section with ``@section("name")``: a function that
takes the parsed :class:`BenchOptions` and returns :class:`Row` s. ``--only`` runs the
named sections (each once, in the order given); without it every section runs. Timings
are the best of ``--repeat`` rounds (the least disturbed by other processes), and the
sections being compared are measured interleaved within each round so that a busy
machine slows all of them alike. An existing ``--out`` is refused before any section
runs unless ``--force``; the file written is named before the last line (``wrote FILE``;
with ``--json``, as the key ``out`` of the JSON printed).

A row held to a target says ``target met`` or ``target not met`` after its figure (in
the JSON: ``target`` and ``met``), and the run ends with one line counting the targets
met and missed. A missed target does not change the exit status (0): the bench measures,
it does not test; the last line says so.

Sections:
    ik: the peers on the same 500 seeded reachable targets, each held to |e| < 0.01 cm
        from home: Robotics Toolbox's C++ ``ik_LM`` on the same 3-joint kinematics
        (skipped, in one line, without the ``bench`` extra), the fastest solve mearm
        ships for the arm (:func:`mearm.ik.fastest_solver`) from home (the peer's start,
        beside its target ≤ 0.25×) and from a new start each call, the batch solve
        (:func:`mearm.ik.batch.solve_batch`), the generic solve,
        PD-PIJ (µs per iteration and fixed cost per solve) and the NumPy port of the
        paper's loop (:mod:`mearm.ik.paper_port`), with ratios. Then PD-PIJ per iteration
        and per route (``paper`` and ``coupled`` modes) on the paper's 24 demo routes,
        next to the NumPy port and the mink cross-check.
    vision: ms per 640x480 frame with 12 objects, OpenCV detector next to a plain
        NumPy/SciPy port of the same recipe (:mod:`mearm.tools.vision_bench`) and the paper's
        0.263 s; the detector at 12 and 40 objects beside the plain 8-bit ``inRange``
        OpenCV recipe, and each one's cost per object; detection accuracy on rendered
        scenes; calibration recovery.
    sort-cpu: CPU time (user + sys, median of 3) of the 12-object simulated sort as a
        child process, interpreter start included, with and without the bytecode cache,
        beside its peer, importing its dependencies (numpy, cv2, pinocchio, yaml,
        pydantic) with the one OpenBLAS thread importing mearm sets, and the ratio with its
        target (≤ 2×), the sort's own target (≤ 1 s); the same import as a shell runs it
        (OpenBLAS's own threads, which mearm does not start) and the ratio to it, no target;
        the sort's imports, a bare interpreter and the 5-DOF arm's sort (its start-up
        check solves in a batch); the shares beyond the imports (none made of a failed run).
    motion: the predicted motion time of the paper's 12-object scene (servo speed limits,
        gripper settings and settling) in the paper's colour order and nearest-first,
        beside the paper's ≈ 144 s.
    twin: the MuJoCo physical twin's real-time factor (simulated seconds per wall
        second) on ``configs/sim_mujoco.yaml`` and ``configs/sim_5dof_mujoco.yaml``: its
        physics alone during a whole sort, MuJoCo's bare stepping at rest, and the whole
        sort with the rendered camera, in this process and as a whole
        ``python -m mearm.sort`` process. A sort takes seconds: at most
        :data:`TWIN_ROUNDS` rounds.
    record: a 3-trial twin experiment unrecorded, recorded as AV1 and as H.264, as fast
        as the twin runs: walls, CPU and the recorded runs' wall over the unrecorded one's,
        beside the target (≤ +100 %).

Each section lives in its own module of :mod:`mearm.tools.benchmarks`.
"""

from __future__ import annotations

import json
import math
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path

from mearm.cli import (
    ArgumentParser,
    existing_ancestor,
    plain_int,
    refuse_to_replace,
    run,
    write_text_atomic,
)
from mearm.tools.benchmarks.bench_base import (
    SECTIONS,
    BenchOptions,
    Row,
    Section,
    best_seconds,
    child_seconds,
    machine,
    section,
)

# isort: off
# The sections register on import, in the order a run without --only measures them.
from mearm.tools.benchmarks.ik_bench import bench_ik
from mearm.tools.benchmarks.ik_peers import (
    PEER_SEED,
    PEER_TARGETS,
    PEER_TOLERANCE_CM,
    PORT_TARGETS,
    ik_peer_rows,
    reachable_targets,
    rtb_ets,
)
from mearm.tools.benchmarks.detector_bench import bench_vision
from mearm.tools.benchmarks.sort_cpu import (
    DEPS_ARGV,
    SORT_ARGV,
    SORT_CPU_RUNS,
    SORT_OVER_DEPS_TARGET,
    bench_sort_cpu,
)
from mearm.tools.benchmarks.collision_bench import bench_collision, collision_routes
from mearm.tools.benchmarks.motion import PAPER_MOTION_S, bench_motion
from mearm.tools.benchmarks.twin_bench import (
    BARE_STEPS,
    TWIN_CONFIGS,
    TWIN_ROUNDS,
    TwinSort,
    bare_step_seconds,
    bench_twin,
    twin_process_seconds,
    twin_rows,
    twin_sort,
)
from mearm.tools.benchmarks.record_bench import bench_record
# isort: on

__all__ = [
    "BARE_STEPS",
    "DEPS_ARGV",
    "PAPER_MOTION_S",
    "PEER_SEED",
    "PEER_TARGETS",
    "PEER_TOLERANCE_CM",
    "PORT_TARGETS",
    "SECTIONS",
    "SORT_ARGV",
    "SORT_CPU_RUNS",
    "SORT_OVER_DEPS_TARGET",
    "TWIN_CONFIGS",
    "TWIN_ROUNDS",
    "BenchOptions",
    "Row",
    "Section",
    "TwinSort",
    "bare_step_seconds",
    "bench_collision",
    "bench_ik",
    "bench_motion",
    "bench_record",
    "bench_sort_cpu",
    "bench_twin",
    "bench_vision",
    "best_seconds",
    "child_seconds",
    "collision_routes",
    "ik_peer_rows",
    "machine",
    "main",
    "reachable_targets",
    "rtb_ets",
    "section",
    "summary",
    "table",
    "twin_process_seconds",
    "twin_rows",
    "twin_sort",
]


def main(argv: Sequence[str] | None = None) -> int:
    """Run the chosen sections and print their rows; 0 on success."""
    parser = ArgumentParser(
        description="The project's benchmarks. A row held to a target says 'target met' or "
        "'target not met', and the last line counts them; a missed target still exits 0 "
        "(the bench measures, it does not test)."
    )
    parser.add_argument(
        "--only",
        action="append",
        choices=sorted(SECTIONS),
        help="run only this section (repeatable; each runs once); default: all",
    )
    parser.add_argument(
        "--repeat", type=plain_int, default=5, help="rounds; the best is kept (default 5)"
    )
    parser.add_argument("--json", action="store_true", help="print JSON instead of the table")
    parser.add_argument(
        "--out", type=Path, metavar="FILE", help="also write the rows as JSON to FILE"
    )
    parser.add_argument("--force", action="store_true", help="replace an existing --out")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error(f"--repeat must be at least 1, got {args.repeat}")
    if args.out is not None:  # checked before the sections run, not after minutes of work
        folder = existing_ancestor(args.out)  # missing folders are made under it
        if not folder.is_dir():
            parser.error(f"--out {args.out}: {str(folder)!r} is a file, not a directory")
        if args.out.is_dir():
            parser.error(f"--out {args.out}: is a directory; give a file name, e.g. bench.json")
        try:  # a file can be made there (root passes os.access where nothing can be made)
            tempfile.TemporaryFile(dir=folder).close()
        except OSError as exc:
            parser.error(f"--out {args.out}: directory {str(folder)!r} is not writable ({exc})")
        refuse_to_replace(args.out, "--out", args.force)
    options = BenchOptions(repeat=args.repeat)
    rows: list[Row] = []
    for name in dict.fromkeys(args.only or SECTIONS):  # a section named twice runs once
        rows += SECTIONS[name](options)
    machine_text = machine()
    last_line = summary(rows)
    result = {
        "machine": machine_text,
        "rows": [_json_row(r) for r in rows],
        "targets": {
            "met": sum(r.met is True for r in rows),
            "not_met": sum(r.met is False for r in rows),
            "summary": last_line,
        },
    }
    if args.out is not None:  # whole or not at all: a run cut short leaves the old file
        write_text_atomic(args.out, json.dumps(result, indent=1) + "\n")
    if args.json:  # stdout stays JSON: the file it wrote is named in it, as "out"
        shown = result if args.out is None else {**result, "out": str(args.out)}
        json.dump(shown, sys.stdout, indent=1)
        print()
        print(last_line, file=sys.stderr)
        return 0
    print("\n".join(table(machine_text, rows)))
    if args.out is not None:
        print(f"wrote {args.out}")
    print(last_line)
    return 0


def _json_row(row: Row) -> dict[str, object]:
    """A row as JSON: a figure that is not a number (none measured) is ``null``."""
    out = asdict(row)
    if not math.isfinite(row.value):
        out["value"] = None
    return out


def summary(rows: Sequence[Row]) -> str:
    """The bench's last line: the targets met and missed, and what a miss means for the exit."""
    held = [r for r in rows if r.met is not None]
    if not held:
        return "targets: none in these sections"
    missed = [f"[{r.section}] {r.name}" for r in held if not r.met]
    met = len(held) - len(missed)
    if not missed:
        return f"targets: all {met} met"
    return (
        f"targets: {met} met, {len(missed)} not met ({'; '.join(missed)}); exit status 0 "
        "all the same: the bench measures, it does not test"
    )


def table(machine_text: str, rows: Sequence[Row]) -> list[str]:
    """The bench's printed lines: the machine, then one line per row.

    A row with a target says ``target met`` or ``target not met`` after its figure.
    """
    lines = [f"machine: {machine_text}"]
    for row in rows:
        if not math.isfinite(row.value):
            value = f"{'—':>12} {row.unit}"  # not measured: the note says why
        elif row.unit:
            value = f"{row.value:12.3f} {row.unit}"
        else:
            value = f"{row.value:12.2f}"
        if row.unit == "" and row.value == 0.0:
            value = ""
        if row.met is not None:
            value += "  target met" if row.met else "  target not met"
        note = f"  ({row.note})" if row.note else ""
        lines.append(f"[{row.section}] {row.name:<58} {value}{note}")
    return lines


if __name__ == "__main__":
    run(main)
