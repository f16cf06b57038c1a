"""The measuring tools' outputs: nothing replaced without --force, --work kept its owner's,
and bench's figures honest (a section once, targets met or not, no negative cost)."""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from badinput import check_bad_input, run_in_process
from built_once import built_once

from mearm.tools.bench import summary, table
from mearm.tools.benchmarks.bench_base import Row, against, difference_row
from mearm.tools.camera_accuracy import WORK_MARKER
from mearm.tools.vision_bench import per_object_row

ENV = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
#: camera-accuracy at its quickest (a few seconds): one height, one scene, 3 objects.
QUICK = ["--config", "sim_mujoco_perspective", "--heights", "1", "--scenes", "1",
         "--objects", "3", "--views", "6"]  # fmt: skip


@dataclass(frozen=True)
class QuickRun:
    """One camera-accuracy run at :data:`QUICK` (``--json ca.json --work work``)."""

    folder: Path
    """Where it ran: ``ca.json`` and ``work/`` are in it (shared: read it, copy to change)."""
    code: int
    stdout: str
    stderr: str


def camera_accuracy_once(factory: pytest.TempPathFactory) -> QuickRun:
    """:class:`QuickRun`, run once per test run in this process and shared by the workers
    (each run is three ``mearm`` processes and a render: 3 s of CPU); the tests of its
    ``--json``, its ``--work`` and its stdout read it (tests/test_output_streams_wrote.py,
    tests/test_walk3_q1_camera_accuracy.py)."""

    def build(folder: Path) -> None:
        with contextlib.chdir(folder):
            done = run_in_process(
                ["camera-accuracy", *QUICK, "--json", "ca.json", "--work", "work"], within_s=30
            )
        outcome = {"code": done.code, "stdout": done.stdout, "stderr": done.stderr}
        (folder / "outcome.json").write_text(json.dumps(outcome))

    folder = built_once(factory, "camera-accuracy-quick", build)
    return QuickRun(folder, **json.loads((folder / "outcome.json").read_text()))


def _precious(path: Path) -> Path:
    path.write_text("precious\n")
    return path


# --- item 3: an existing output is refused before any work unless --force ---------------


@pytest.mark.parametrize(
    ("argv", "flag"),
    [
        (["bench", "--only", "motion", "--repeat", "1", "--out", "{f}"], "--out"),
        (["virtual-uno-pulses", "--commands", "3", "--json", "{f}"], "--json"),
        (["servo-steps", "--degrees", "10", "--csv", "{f}"], "--csv"),
        (["servo-steps", "--degrees", "10", "--out", "{png}"], "--out"),
        (["camera-accuracy", *QUICK, "--json", "{f}"], "--json"),
    ],
)
def test_an_existing_output_is_refused_without_force(
    tmp_path: Path, argv: list[str], flag: str
) -> None:
    keep, png = _precious(tmp_path / "keep.json"), _precious(tmp_path / "keep.png")
    argv = [a.format(f=keep, png=png) for a in argv]
    out = check_bad_input(argv, keep=[keep, png])
    assert f"{flag} " in out.line and "exists; pass --force to replace it" in out.line


def test_bench_force_replaces_the_out_and_runs_a_section_named_twice_once(
    tmp_path: Path,
) -> None:
    """The real command: --force replaces --out; motion named twice runs once; the rows
    with a target say met, in the table and the JSON; the last line counts them."""
    out = _precious(tmp_path / "bench.json")
    proc = subprocess.run(
        [sys.executable, "-m", "mearm", "bench", "--only", "motion", "--only", "motion",
         "--repeat", "1", "--out", str(out), "--force"],
        capture_output=True, text=True, env=ENV, timeout=300, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    rows = [line for line in lines if line.startswith("[motion]")]
    assert len(rows) == 4, proc.stdout  # two orders, a time and a ratio each: once
    assert sum("target met" in line for line in rows) == 2
    assert lines[-1] == "targets: all 2 met"
    result = json.loads(out.read_text())
    assert len(result["rows"]) == 4
    ratios = [r for r in result["rows"] if r["target"]]
    assert [r["met"] for r in ratios] == [True, True]
    assert all(r["target"] == "≤ 0.25 (36 s)" for r in ratios)
    assert all(r["met"] is None for r in result["rows"] if not r["target"])
    assert result["targets"] == {"met": 2, "not_met": 0, "summary": "targets: all 2 met"}


# --- item 13: a missed target is said; a difference of timings is never negative --------


def test_a_missed_target_is_said_in_its_row_and_in_the_last_line() -> None:
    missed = against(
        Row("record", "recorded, AV1 over unrecorded: wall", 271.0, "%", "target ≤ +100 %"),
        "≤ +100 %",
        at_most=100.0,
    )
    met = against(Row("twin", "physics: real-time factor", 111.0, "×"), "≥ 50×", at_least=50.0)
    plain = Row("ik", "PD-PIJ paper: per route", 1.5, "ms")
    assert (missed.met, met.met, plain.met) == (False, True, None)
    lines = table("a machine", [missed, met, plain])
    assert "271.000 %  target not met  (target ≤ +100 %)" in lines[1]
    assert "111.000 ×  target met" in lines[2]
    assert "target" not in lines[3]
    last = summary([missed, met, plain])
    assert last.startswith("targets: 1 met, 1 not met ([record] recorded, AV1 over unrecorded")
    assert "exit status 0 all the same: the bench measures" in last
    assert summary([plain]) == "targets: none in these sections"
    # a failed run, or no figure, meets no target
    assert against(met, "≥ 50×", at_least=50.0, valid=False).met is False
    nan = Row("twin", "x", float("nan"), "×")
    assert against(nan, "≤ 1×", at_most=1.0).met is False


def test_a_per_object_cost_at_or_under_zero_is_no_figure() -> None:
    """One round can time 40 objects faster than 12: that is noise, not a negative cost."""
    name, value, unit, note = per_object_row("detect, mearm: per object", 300.0, 144.0, 12, 40, 1)
    assert math.isnan(value) and unit == "µs/object"
    assert note.startswith("below timing resolution: 40 objects timed no slower than 12")
    assert "best of 1 rounds; more --repeat" in note
    _, value, _, note = per_object_row("detect, mearm: per object", 100.0, 156.0, 12, 40, 50)
    assert value == pytest.approx(2.0) and note == "slope from 12 to 40 objects"
    row = Row("vision", name, value=float("nan"), unit=unit, note="below timing resolution")
    line = table("a machine", [row])[1]
    assert "—" in line and "nan" not in line
    diff = difference_row("ik", "PD-PIJ: per iteration", -0.3, "µs", "(a − b) / n", "a ≤ b")
    assert math.isnan(diff.value) and diff.note == "below timing resolution: a ≤ b; (a − b) / n"
    assert difference_row("ik", "x", 0.3, "µs", "", "a ≤ b").value == 0.3


def test_bench_json_has_null_for_a_figure_not_measured() -> None:
    from mearm.tools.bench import _json_row

    assert _json_row(Row("vision", "x", float("nan"), "µs"))["value"] is None


# --- item 4: camera-accuracy --work holds only what it wrote ----------------------------


def test_camera_accuracy_refuses_a_work_folder_of_the_users(tmp_path: Path) -> None:
    """The walk's folder: a real calibration, a sheet and a board of the user's."""
    work = tmp_path / "mycal"
    work.mkdir()
    (work / "intrinsics.yaml").write_text("my real camera calibration\n")
    (work / "sheet.png").write_text("my sheet\n")
    (work / "board_01.png").write_text("mine\n")
    out = check_bad_input(["camera-accuracy", *QUICK, "--work", work], keep=[work])
    assert f"--work {work}: holds files camera-accuracy did not write" in out.line
    assert not (work / WORK_MARKER).exists()


@pytest.mark.heavy
def test_camera_accuracy_reruns_into_its_own_work_folder_and_no_other_file(
    tmp_path: Path, tmp_path_factory: pytest.TempPathFactory
) -> None:
    """Two runs into one folder (the first the shared run's, copied); then a file of the
    user's there, or one changed, is refused before any work; after a run cut short its
    own names are accepted."""
    first = camera_accuracy_once(tmp_path_factory)
    assert first.code == 0, first.stdout + first.stderr
    work = tmp_path / "cal"
    shutil.copytree(first.folder / "work", work)
    proc = run_in_process(["camera-accuracy", *QUICK, "--work", work], within_s=30)
    assert proc.code == 0, proc.stdout + proc.stderr
    assert (work / "intrinsics.yaml.bak").is_file() and (work / WORK_MARKER).is_file()
    mark = json.loads((work / WORK_MARKER).read_text())
    assert mark["finished"] is True and "boards/board_00.png" in mark["files"]

    (work / "intrinsics.yaml").write_text("my real camera calibration\n")
    out = check_bad_input(["camera-accuracy", *QUICK, "--work", work], keep=[work])
    assert "intrinsics.yaml was changed since camera-accuracy wrote it" in out.line

    # a run cut short: its own names may have been rewritten, and are accepted (the
    # refusal that follows is --scenes', checked after --work)
    mark["finished"] = False
    (work / WORK_MARKER).write_text(json.dumps(mark))
    bad = ["camera-accuracy", *QUICK, "--scenes", "0", "--work", work]
    assert (
        "--scenes must be a whole number in 1 … 100, got 0"
        in check_bad_input(bad, keep=[work]).line
    )
    (work / "notes.txt").write_text("mine\n")
    out = check_bad_input(["camera-accuracy", *QUICK, "--work", work], keep=[work])
    assert "notes.txt was not written by camera-accuracy" in out.line
