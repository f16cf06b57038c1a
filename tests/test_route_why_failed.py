"""A route that ran and failed says why, on its line and in the run log (``why_failed``).

The kinematic rig, made to fail as a real one does: jaws that must land within 0.01 cm
of the object miss it; a base 4° off its command with bins that take only what is
released within 1 cm of their centre drops each object beside its bin. The twin's
empty jaws over the bin: ``tests/test_twin_faults.py``.
"""

from __future__ import annotations

import json

import pytest
from badinput import run_in_process

from mearm.analysis.run_analysis import UNRECORDED, FailureCount, analyze
from mearm.analyze import main as analyze_main
from mearm.runlog import read_runlog
from mearm.sim.kinematic.servo_bus import ReleaseResult
from mearm.sort import main as sort_main
from mearm.task.pick_place import PICK_MISSED, place_failure

ONE = "task.scene=[{color: red, x: -5, y: 45}]"
LANDED = "released, it landed on the table at"
LOST = "over the bin the jaws held nothing of its class: it was lost on the way"


def _sort(tmp_path, capsys, *sets: str, log_name: str = "run.jsonl"):
    """Sort the one red object; (exit code, its route lines, its route records)."""
    log = tmp_path / log_name
    argv = ["--config", "sim", "--set", ONE, "--log", str(log)]
    for s in sets:
        argv += ["--set", s]
    code = sort_main(argv)
    out = capsys.readouterr().out
    lines = [line for line in out.splitlines() if line[:5] in ("pick ", "place")]
    (trial,) = read_runlog(log, strict=True).trials
    return code, lines, trial.routes


def test_a_missed_pick_says_the_camera_still_sees_the_object(tmp_path, capsys):
    code, lines, routes = _sort(tmp_path, capsys, "servo.grip_tolerance_cm=0.01")
    assert code == 1
    assert len(lines) == len(routes) == 3  # three tries, each missed
    assert all(line.endswith(f" ms: {PICK_MISSED}") for line in lines), lines
    assert [(r.step, r.success, r.why_failed) for r in routes] == [("pick", False, PICK_MISSED)] * 3


def test_a_place_beside_its_bin_says_where_the_object_landed(tmp_path, capsys):
    code, lines, routes = _sort(
        tmp_path, capsys, "servo.grip_tolerance_cm=5", "servo.bin_radius_cm=1",
        "servo.error_model.offset_deg={base: 4}",
    )  # fmt: skip
    assert code == 1
    place = [r for r in routes if r.step == "place"]
    assert place and not any(r.success for r in place)
    for r, line in zip(place, [line for line in lines if line.startswith("place")], strict=True):
        assert r.why_failed is not None
        assert r.why_failed.startswith(f"{LANDED} (")
        assert line.endswith(f" ms: {r.why_failed}")
    # the picks that held say nothing more than ok
    assert all(r.why_failed is None for r in routes if r.step == "pick" and r.success)


def test_analyze_counts_the_failed_routes_by_why(tmp_path, capsys):
    """Two sorts in one log: one whose objects land beside their bins, one whose grips
    miss. ``mearm analyze`` counts them by reason, the landings as one whatever the spot;
    the same log without the reasons (as written before them) counts them unrecorded."""
    _sort(tmp_path, capsys, "servo.grip_tolerance_cm=5", "servo.bin_radius_cm=1",
          "servo.error_model.offset_deg={base: 4}", log_name="landed.jsonl")  # fmt: skip
    _sort(tmp_path, capsys, "servo.grip_tolerance_cm=0.01", log_name="missed.jsonl")
    log = tmp_path / "both.jsonl"
    log.write_text("".join((tmp_path / f"{n}.jsonl").read_text() for n in ("landed", "missed")))
    got = analyze(read_runlog(log)).failures
    assert got[0] == FailureCount("pick", PICK_MISSED, 3)
    (landed,) = (f for f in got if f.step == "place")
    assert landed.why == LANDED.removesuffix(" at") and landed.routes >= 1
    assert analyze_main([str(log)]) == 0
    text = capsys.readouterr().out
    assert "Why routes failed (every attempt)" in text and PICK_MISSED in text
    # the log as written before routes said why
    old = tmp_path / "old.jsonl"
    records = [json.loads(line) for line in log.read_text().splitlines()]
    old.write_text("".join(json.dumps({k: v for k, v in r.items() if k != "why_failed"}) + "\n"
                           for r in records))  # fmt: skip
    unrecorded = {
        FailureCount("pick", UNRECORDED, 3),
        FailureCount("place", UNRECORDED, landed.routes),
    }
    assert set(analyze(read_runlog(old)).failures) == unrecorded


def test_a_sort_that_succeeds_says_no_why(tmp_path, capsys):
    code, lines, routes = _sort(tmp_path, capsys)
    assert code == 0
    assert [r.why_failed for r in routes] == [None, None]
    assert all(line.endswith(" ms") for line in lines), lines


class _Released:
    """What a simulator's bus reports after its jaws opened (``ReportsRelease``)."""

    def __init__(self, release: ReleaseResult | None):
        self.last_release = release


@pytest.mark.parametrize(
    ("held", "release", "why"),
    [
        (True, ReleaseResult("red1", "red", -20.0, 45.0), None),
        (True, None, None),  # a bus that cannot say where it went: the hold decides
        (True, ReleaseResult("red1", "green", -20.0, 35.0), "released, it fell into the green bin"),
        (True, ReleaseResult("red1", None, -18.04, 44.96), f"{LANDED} (-18.0, 45.0) cm"),
        (False, ReleaseResult("red1", "red", -20.0, 45.0), LOST),
    ],
    ids=["in its bin", "unknown", "another bin", "on the table", "not held"],
)  # fmt: skip
def test_the_place_failure_reads_the_hold_then_the_release(held, release, why):
    assert place_failure(_Released(release), "red", held=held) == why  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("why", "allowed"),
    [("x" * 1001, "at most 1000 characters"), ("a\nb", "should match pattern")],
    ids=["long", "two lines"],
)
def test_a_log_whose_reason_is_not_one_short_line_is_refused(tmp_path, capsys, why, allowed):
    """A hand-edited log: one line (no traceback), exit 2, naming the line and the field."""
    _sort(tmp_path, capsys, "servo.grip_tolerance_cm=0.01")
    log = tmp_path / "run.jsonl"
    records = [json.loads(line) for line in log.read_text().splitlines()]
    for r in records:
        if r["type"] == "route":
            r["why_failed"] = why
    log.write_text("".join(json.dumps(r) + "\n" for r in records))
    out = run_in_process(["analyze", str(log)])
    assert out.code == 2
    assert len(out.stderr.strip().splitlines()) == 1
    assert "line 2: route record: field 'why_failed'" in out.stderr and allowed in out.stderr
