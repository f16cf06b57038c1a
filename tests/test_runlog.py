"""The run log: what is written reads back; bad lines stop the reader and are reported.

Format 2 is what is written; format-1 logs (joint lists, the ``robot:`` config) read into
the same records.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mearm.config import Config
from mearm.exceptions import RunLogError, RunLogFormatError
from mearm.runlog import (
    FORMAT_VERSION,
    MAX_LINE_BYTES,
    FaultRecord,
    HeaderRecord,
    RepeatedTrialError,
    RouteRecord,
    RunLog,
    SkipRecord,
    SummaryRecord,
    end_line,
    find_torn_end,
    library_versions,
    parse_record,
    read_runlog,
    set_aside_torn_end,
    upgrade_v1_record,
)

ARM = Config().arm
JOINTS = [j.name for j in ARM.joints]


def named(values: list[float]) -> dict[str, object]:
    """Joint values of the default arm by name, as numpy scalars (the writer takes them)."""
    return {n: np.float64(v) for n, v in zip(JOINTS, values, strict=True)}


def route_fields(**over: object) -> dict[str, object]:
    fields: dict[str, object] = dict(
        object_id="red1",
        color="red",
        step="pick",
        attempt=1,
        target_cm=np.array([-10.99, 49.70, 12.76]),
        start_joints=named([120.0, 93.0, -132.0, 39.0]),
        end_joints=named([102.4, 68.1, -95.2, 27.1]),
        iterations=np.int64(82),
        status="converged",
        initial_error_cm=24.99,
        final_error_cm=0.0305,
        ee_cm=np.array([-10.5, 49.9, 12.1]),
        success=np.bool_(True),
        elapsed_s=0.05,
        motion_s=6.0,
    )
    fields.update(over)
    return fields


def write_trial(log: RunLog, trial: int | None, n_routes: int = 2) -> None:
    log.header(Config(), trial=trial, seed=7)
    for i in range(n_routes):
        step = "pick" if i % 2 == 0 else "place"
        log.route(**route_fields(step=step, object_id=f"red{i // 2 + 1}"))
    log.skip(object_id="blue9", color="blue", target_cm=[70.0, 50.0, 12.76], reason="unreachable")
    log.summary()


def test_round_trip_keeps_every_field(tmp_path: Path) -> None:
    """Records written by RunLog read back equal, numpy values included."""
    path = tmp_path / "run.jsonl"
    with RunLog(path) as log:
        header = log.header(Config(), trial=None, seed=None, argv=["--seed", "0"])
        route = log.route(**route_fields())
        fault = log.fault("servo link dropped", last_joints=named([30.0, 90, -90, 0]))
        summary = log.summary()
    contents = read_runlog(path)
    assert contents.complete and contents.problem is None
    assert contents.records == (header, route, fault, summary)
    assert header.format == FORMAT_VERSION == 2
    assert header.versions["python"] and "numpy" in header.versions
    assert header.model_extra == {"argv": ["--seed", "0"]}
    assert header.load_config() == Config()
    np.testing.assert_allclose(route.error_cm, np.subtract(route.ee_cm, route.target_cm))
    assert list(route.start_joints) == JOINTS and route.end_joints[JOINTS[1]] == 68.1
    assert fault.last_joints == {n: float(v) for n, v in named([30.0, 90, -90, 0]).items()}
    assert route.error_norm_cm == pytest.approx(np.linalg.norm(route.error_cm))
    assert fault.trial is None
    assert summary.ok is False  # a fault was written in this trial


def test_every_line_is_one_json_object_with_a_type(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    with RunLog(path) as log:
        write_trial(log, trial=0)
    lines = path.read_text().splitlines()
    assert [json.loads(line)["type"] for line in lines] == [
        "header", "route", "route", "skip", "summary"
    ]  # fmt: skip


def test_summary_fills_in_counts_and_means(tmp_path: Path) -> None:
    with RunLog(tmp_path / "run.jsonl") as log:
        log.header(Config(), trial=3)
        log.route(**route_fields(iterations=80, final_error_cm=0.03, motion_s=5.0))
        log.route(**route_fields(step="place", iterations=90, final_error_cm=0.02, motion_s=6.5))
        log.route(**route_fields(object_id="green1", color="green", success=False, iterations=70))
        log.skip(object_id="blue1", color="blue", target_cm=None, reason="outside box")
        summary = log.summary(ok=True)
    assert isinstance(summary, SummaryRecord)
    assert summary.trial == 3
    assert summary.sorted == {"red": 1, "green": 0}
    assert (summary.failures, summary.skipped, summary.routes) == (1, 1, 3)
    assert summary.mean_iterations == pytest.approx(80.0)
    assert summary.mean_final_error_cm == pytest.approx((0.03 + 0.02 + 0.0305) / 3)
    assert summary.motion_s == pytest.approx(5.0 + 6.5 + 6.0)
    assert summary.ok is True


def test_several_trials_group_by_header(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    with RunLog(path) as log:
        for trial in range(3):
            write_trial(log, trial=trial, n_routes=2 + trial)
    contents = read_runlog(path)
    assert [t.number for t in contents.trials] == [0, 1, 2]
    assert [len(t.routes) for t in contents.trials] == [2, 3, 4]
    assert [t.line for t in contents.trials] == [1, 6, 12]
    assert all(t.summary is not None and len(t.skips) == 1 for t in contents.trials)
    assert len(contents.routes) == 9 and len(contents.skips) == 3


def test_opening_an_existing_log_appends(tmp_path: Path) -> None:
    """A second run keeps the first one's records and adds its own header."""
    path = tmp_path / "run.jsonl"
    with RunLog(path) as log:
        write_trial(log, trial=None)
    before = path.read_bytes()
    with RunLog(path) as log:
        write_trial(log, trial=None)
    assert path.read_bytes().startswith(before)
    contents = read_runlog(path)
    assert contents.complete and len(contents.trials) == 2


def test_exclusive_refuses_an_existing_log(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    path.write_text("keep me\n")
    with pytest.raises(RunLogError, match="exists") as info:
        RunLog(path, exclusive=True)
    assert info.value.path == str(path)
    assert path.read_text() == "keep me\n"


def test_a_torn_log_is_not_appended_to(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    with RunLog(path) as log:
        write_trial(log, trial=None)
    with path.open("ab") as f:
        f.write(b'{"type":"route","tri')
    before = path.read_bytes()
    with pytest.raises(RunLogError, match="middle of a line"):
        RunLog(path)
    assert path.read_bytes() == before


@pytest.mark.parametrize(
    "text",
    [
        b"# My notes\n\nSome prose.\n",  # a --log typo that named a user's file
        b"not json\n",
        b'{"type":"route","trial":0}\n',  # JSON lines, but no run log's header first
        b"\xff\xfe\n",
    ],
)
def test_a_file_that_is_no_run_log_is_not_appended_to(tmp_path: Path, text: bytes) -> None:
    """``sort --log README.md`` appended JSON records to the README; it is refused."""
    path = tmp_path / "notes.md"
    path.write_bytes(text)
    with pytest.raises(RunLogError, match="is not a run log"):
        RunLog(path)
    assert path.read_bytes() == text


def test_opening_for_append_never_truncates(tmp_path: Path) -> None:
    """Opening and closing an existing log, with or without writing, keeps every byte."""
    path = tmp_path / "run.jsonl"
    with RunLog(path) as log:
        write_trial(log, trial=0)
    before = path.read_bytes()
    RunLog(path).close()
    assert path.read_bytes() == before
    with pytest.raises(RunLogError, match="exists"):
        RunLog(path, exclusive=True)
    assert path.read_bytes() == before


def test_a_symlinked_log_is_appended_through_the_link(tmp_path: Path) -> None:
    real = tmp_path / "real.jsonl"
    with RunLog(real) as log:
        write_trial(log, trial=0)
    link = tmp_path / "link.jsonl"
    link.symlink_to(real)
    with RunLog(link) as log:
        write_trial(log, trial=1)
    assert link.is_symlink() and len(read_runlog(real).trials) == 2


@pytest.mark.parametrize("kind", ["folder", "device"])
def test_a_path_that_is_not_a_file_is_refused(tmp_path: Path, kind: str) -> None:
    path = tmp_path / "logs" if kind == "folder" else Path("/dev/null")
    if kind == "folder":
        path.mkdir()
    with pytest.raises(RunLogError, match="not a regular file"):
        RunLog(path)


def test_records_need_a_header_first(tmp_path: Path) -> None:
    with RunLog(tmp_path / "run.jsonl") as log, pytest.raises(RunLogError, match="before a header"):
        log.route(**route_fields())


def test_writer_refuses_a_record_of_another_trial(tmp_path: Path) -> None:
    with RunLog(tmp_path / "run.jsonl") as log:
        log.header(Config(), trial=1)
        with pytest.raises(RunLogError, match="trial 2 under the header of trial 1"):
            log.route(**route_fields(trial=2))


def test_writer_refuses_records_after_the_summary(tmp_path: Path) -> None:
    with RunLog(tmp_path / "run.jsonl") as log:
        log.header(Config(), trial=0)
        log.summary()
        with pytest.raises(RunLogError, match="already has its summary"):
            log.route(**route_fields())
        log.header(Config(), trial=1)
        log.route(**route_fields())


def test_writer_validates_like_the_reader(tmp_path: Path) -> None:
    """A bad record is refused before it reaches the file, with the field named."""
    path = tmp_path / "run.jsonl"
    with RunLog(path) as log:
        log.header(Config())
        with pytest.raises(RunLogError, match="field 'step'"):
            log.route(**route_fields(step="drop"))
        with pytest.raises(RunLogError, match="field 'iterations' is missing"):
            log.route(**{k: v for k, v in route_fields().items() if k != "iterations"})
        with pytest.raises(RunLogError, match="not ee_cm − target_cm"):
            log.route(**route_fields(error_cm=[1.0, 0.0, 0.0]))
        with pytest.raises(RunLogError, match="JSON"):
            log.route(**route_fields(final_error_cm=float("nan")))
    assert len(path.read_text().splitlines()) == 1


def test_closed_log_refuses_writes(tmp_path: Path) -> None:
    log = RunLog(tmp_path / "run.jsonl")
    log.header(Config())
    log.close()
    assert log.closed
    with pytest.raises(RunLogError, match="closed"):
        log.route(**route_fields())


def test_each_record_is_on_disk_before_the_next_call(tmp_path: Path) -> None:
    """Flushed per record: another reader sees it while the log is still open."""
    path = tmp_path / "run.jsonl"
    with RunLog(path) as log:
        log.header(Config(), trial=0)
        log.route(**route_fields())
        contents = read_runlog(path)
        assert contents.complete and len(contents.routes) == 1


def test_versions_name_the_main_libraries() -> None:
    versions = library_versions()
    for key in ("python", "numpy", "pinocchio", "mink", "mujoco", "opencv"):
        assert versions[key], key


# --------------------------------------------------------------------------- bad logs


@pytest.fixture()
def good_log(tmp_path: Path) -> Path:
    path = tmp_path / "run.jsonl"
    with RunLog(path) as log:
        write_trial(log, trial=0, n_routes=4)
    return path


def corrupt(path: Path, line_no: int, new: str | bytes | None, *, newline: bool = True) -> Path:
    """Replace line ``line_no`` (from 1) with ``new``; drop everything after it if no newline."""
    lines = path.read_bytes().splitlines(keepends=True)
    if new is not None:
        data = new if isinstance(new, bytes) else new.encode()
        lines[line_no - 1] = data + (b"\n" if newline else b"")
    if not newline:
        lines = lines[:line_no]
    path.write_bytes(b"".join(lines))
    return path


def edited(path: Path, line_no: int, **changes: object) -> str:
    obj = json.loads(path.read_text().splitlines()[line_no - 1])
    for key, value in changes.items():
        if value is KeyError:
            del obj[key]
        else:
            obj[key] = value
    return json.dumps(obj)


def expect_problem(path: Path, line_no: int, pattern: str) -> RunLogFormatError:
    contents = read_runlog(path)
    problem = contents.problem
    assert isinstance(problem, RunLogFormatError), "the bad line was not reported"
    assert problem.line == line_no
    assert pattern in problem.reason, problem.reason
    assert str(path) in str(problem) and f"line {line_no}" in str(problem)
    assert len(contents.records) == line_no - 1, "records before the bad line were lost"
    assert contents.lines_read == line_no - 1
    return problem


def test_crash_mid_line_keeps_everything_before(good_log: Path) -> None:
    text = good_log.read_text().splitlines()[3]
    corrupt(good_log, 4, text[: len(text) // 2], newline=False)
    problem = expect_problem(good_log, 4, "torn last line")
    assert problem.text == text[: len(text) // 2][:80]
    assert len(read_runlog(good_log).routes) == 2


def test_missing_field_is_named(good_log: Path) -> None:
    corrupt(good_log, 3, edited(good_log, 3, iterations=KeyError))
    expect_problem(good_log, 3, "route record: field 'iterations' is missing")


def test_wrong_type_is_named(good_log: Path) -> None:
    corrupt(good_log, 2, edited(good_log, 2, iterations="82"))
    expect_problem(good_log, 2, "field 'iterations'")
    corrupt(good_log, 2, edited(good_log, 2, iterations=82, success=1))
    expect_problem(good_log, 2, "field 'success'")
    corrupt(good_log, 2, edited(good_log, 2, success=True, target_cm=[1.0, 2.0]))
    expect_problem(good_log, 2, "field 'target_cm.2' is missing")


def test_garbage_lines(good_log: Path) -> None:
    corrupt(good_log, 5, "not json at all")
    expect_problem(good_log, 5, "not valid JSON")
    corrupt(good_log, 5, "[1, 2, 3]")
    expect_problem(good_log, 5, "must be a JSON object, got list")
    corrupt(good_log, 5, '{"type": "teleport"}')
    expect_problem(good_log, 5, "unknown record type 'teleport'")
    corrupt(good_log, 5, b"\xff\xfe{}")
    expect_problem(good_log, 5, "not UTF-8")


def test_unsupported_format(good_log: Path) -> None:
    corrupt(good_log, 1, edited(good_log, 1, format=99))
    expect_problem(good_log, 1, "format 99 is not supported")


def test_record_before_any_header(good_log: Path) -> None:
    corrupt(good_log, 1, good_log.read_text().splitlines()[1])
    expect_problem(good_log, 1, "route record before any header")


def test_record_of_another_trial(good_log: Path) -> None:
    corrupt(good_log, 3, edited(good_log, 3, trial=5))
    expect_problem(good_log, 3, "route record of trial 5 under the header of trial 0")


def test_record_after_summary(good_log: Path) -> None:
    with good_log.open("a") as f:
        f.write(good_log.read_text().splitlines()[1] + "\n")
    expect_problem(good_log, 8, "after the summary of trial 0")


def test_strict_reading_raises(good_log: Path) -> None:
    corrupt(good_log, 2, "{")
    with pytest.raises(RunLogFormatError) as info:
        read_runlog(good_log, strict=True)
    assert info.value.line == 2


def test_blank_lines_are_ignored(good_log: Path) -> None:
    lines = good_log.read_text().splitlines()
    good_log.write_text("\n".join([lines[0], "", *lines[1:]]) + "\n\n")
    contents = read_runlog(good_log)
    assert contents.complete and len(contents.records) == 7


def test_a_line_longer_than_the_limit_is_not_read_whole(good_log: Path) -> None:
    with good_log.open("ab") as f:
        f.write(b'{"type": "' + b"x" * (MAX_LINE_BYTES + 10) + b'"}\n')
    expect_problem(good_log, 8, "longer than 4 MiB")


def test_deeply_nested_json_is_a_bad_line(good_log: Path) -> None:
    with good_log.open("ab") as f:
        f.write(b"[" * 100_000 + b"]" * 100_000 + b"\n")
    expect_problem(good_log, 8, "nested too deeply")


def test_missing_file_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(RunLogError, match="no such run log"):
        read_runlog(tmp_path / "nope.jsonl")


def test_header_model_rejects_bad_time() -> None:
    text = json.dumps(
        {"type": "header", "format": 1, "mearm_version": "0", "started": "yesterday",
         "config": {}, "versions": {}, "trial": None, "seed": None}
    )  # fmt: skip
    with pytest.raises(ValueError, match="ISO 8601"):
        HeaderRecord.model_validate_json(text)


def test_route_model_is_strict_about_booleans() -> None:
    fields = {k: (v.tolist() if hasattr(v, "tolist") else v) for k, v in route_fields().items()}
    fields.update(type="route", trial=None, success=1, error_cm=[0.49, 0.2, -0.66])
    with pytest.raises(ValueError, match="success"):
        RouteRecord.model_validate_json(json.dumps(fields))


# --------------------------------------------------------------------------- format 2 joints


def test_route_joints_must_be_a_mapping(good_log: Path) -> None:
    """A route whose start_joints is a list (format 1's shape) names the line and field."""
    corrupt(good_log, 2, edited(good_log, 2, start_joints=[120.0, 93.0, -132.0, 39.0]))
    expect_problem(good_log, 2, "route record: field 'start_joints': Input should be an object")


def test_non_finite_joint_value_is_named(good_log: Path) -> None:
    line = edited(good_log, 3, end_joints={**named([1.0, 2.0, 3.0, 4.0]), JOINTS[2]: 0.0})
    corrupt(good_log, 3, line.replace('"' + JOINTS[2] + '": 0.0', '"' + JOINTS[2] + '": NaN'))
    expect_problem(good_log, 3, f"field 'end_joints.{JOINTS[2]}': Input should be a finite number")


def test_joint_names_must_be_the_header_arms(good_log: Path) -> None:
    """Every joint of the header's arm, and no other, in each joint mapping."""
    values = {n: 0.0 for n in JOINTS[:-1]}
    corrupt(good_log, 4, edited(good_log, 4, start_joints={**values, "gripper_arm": 1.0}))
    problem = expect_problem(good_log, 4, "field 'start_joints' names")
    assert f"missing ['{JOINTS[-1]}'], unknown ['gripper_arm']" in problem.reason


def test_empty_joint_mapping_is_refused(good_log: Path) -> None:
    corrupt(good_log, 2, edited(good_log, 2, end_joints={}))
    expect_problem(good_log, 2, "field 'end_joints': Dictionary should have at least 1 item")


def test_empty_colour_is_refused(good_log: Path) -> None:
    corrupt(good_log, 6, edited(good_log, 6, color=""))
    expect_problem(good_log, 6, "skip record: field 'color'")


def test_format_1_route_under_a_format_2_header(good_log: Path) -> None:
    """A line is read in its header's format: a joint list under format 2 is an error."""
    line = edited(good_log, 2, start_joints=KeyError, start_joints_deg=[120.0, 93.0, -132.0, 39.0])
    corrupt(good_log, 2, line)
    expect_problem(good_log, 2, "route record: field 'start_joints' is missing")


def test_writer_refuses_joints_of_another_arm(tmp_path: Path) -> None:
    """The writer runs the reader's checks: joint names must be the header's arm's."""
    path = tmp_path / "run.jsonl"
    with RunLog(path) as log:
        log.header(Config())
        actuated = {n: 1.0 for n in JOINTS[:-1]}
        with pytest.raises(RunLogError, match=f"missing \\['{JOINTS[-1]}'\\]"):
            log.route(**route_fields(end_joints=actuated))
        with pytest.raises(RunLogError, match="field 'last_joints'"):
            log.fault("stop", last_joints=[1.0, 2.0, 3.0, 4.0])
        with pytest.raises(RunLogError, match="field 'last_joints' names"):
            log.fault("stop", last_joints=actuated)
        log.fault("stop", last_joints=None)
    assert len(path.read_text().splitlines()) == 2


def test_joints_are_not_checked_without_an_arm_in_the_header(tmp_path: Path) -> None:
    """A header whose config leaves the arm out gives no names to check against."""
    path = tmp_path / "run.jsonl"
    with RunLog(path) as log:
        log.header({})
        log.route(**route_fields(start_joints={"a": 1.0}, end_joints={"b": 2.0}))
    assert read_runlog(path).complete


# --------------------------------------------------------------------------- format 1

V1_CONFIG = {
    "robot": {
        "dh": [
            {"a_cm": 3.0, "alpha_deg": 90.0, "d_cm": 17.5},
            {"a_cm": 22.3, "alpha_deg": 0.0, "d_cm": 0.0},
            {"a_cm": 31.5, "alpha_deg": 0.0, "d_cm": 0.0},
            {"a_cm": 14.0, "alpha_deg": 0.0, "d_cm": 0.0},
        ],
        "joint_limits_deg": {
            "joint1": {"min": 20.0, "max": 160.0},
            "joint2": {"min": 30.0, "max": 135.0},
            "joint3": {"min": -160.0, "max": -20.0},
        },
        "home_deg": [120.0, 93.0, -132.0],
        "gripper": {"a4_cm": 9.0, "a5_cm": 10.0, "pick_height_cm": 12.76},
    },
    "vision": {"preset": "default", "bands": None, "object_diameter_cm": 2.0},
    "servo": {
        "backend": "sim",
        "gripper": {"channel": 4, "open_us": 1000, "closed_us": 1900},
        "error_model": {"quantization": "degree", "offset_deg": [0.5, 0.0, -0.25]},
    },
    "task": {
        "color_order": ["red", "green", "blue"],
        "bins_cm": {
            "red": [-20.0, 35.0, 20.0],
            "green": [-20.0, 45.0, 20.0],
            "blue": [-20.0, 55.0, 20.0],
        },
        "scene": [{"color": "red", "x": -10.99, "y": 49.7}],
    },
}

V1_ROUTE = {
    "type": "route", "trial": 4, "object_id": "red1", "color": "red", "step": "pick",
    "attempt": 1, "target_cm": [-10.99, 49.7, 12.76],
    "start_joints_deg": [120.0, 93.0, -132.0, 39.0],
    "end_joints_deg": [102.4, 68.1, -95.2, 27.1],
    "iterations": 82, "status": "converged", "initial_error_cm": 24.99,
    "final_error_cm": 0.0305, "ee_cm": [-10.5, 49.9, 12.1], "error_cm": [0.49, 0.2, -0.66],
    "success": True, "elapsed_s": 0.05, "motion_s": 6.0,
}  # fmt: skip


def v1_log(path: Path, *, route: dict[str, object] | None = None) -> Path:
    """A format-1 log as format 1 wrote it: header, 2 routes, skip, fault, summary."""
    lines: list[dict[str, object]] = [
        {"type": "header", "format": 1, "mearm_version": "0.1.0",
         "started": "2026-01-02T03:04:05+00:00", "config": V1_CONFIG,
         "versions": {"python": "3.11.9"}, "trial": 4, "seed": 11, "argv": ["--seed", "11"]},
        route or V1_ROUTE,
        {**V1_ROUTE, "step": "place", "target_cm": [-20.0, 35.0, 20.0],
         "start_joints_deg": [102.4, 68.1, -95.2, 27.1],
         "end_joints_deg": [120.0, 93.0, -132.0, 39.0],
         "ee_cm": [-20.0, 35.5, 20.0], "error_cm": [0.0, 0.5, 0.0]},
        {"type": "skip", "trial": 4, "object_id": "blue1", "color": "blue",
         "target_cm": None, "reason": "outside box"},
        {"type": "fault", "trial": 4, "reason": "servo link dropped",
         "last_joints_deg": [120.0, 93.0, -132.0, 39.0]},
        {"type": "summary", "trial": 4, "sorted": {"red": 1}, "failures": 0, "skipped": 1,
         "routes": 2, "mean_iterations": 82.0, "mean_final_error_cm": 0.0305,
         "motion_s": 12.0, "ok": False},
    ]  # fmt: skip
    path.write_text("".join(json.dumps(line) + "\n" for line in lines))
    return path


def test_format_1_log_reads_as_format_2_records(tmp_path: Path) -> None:
    """Every line of a format-1 log comes back as the format-2 record it stands for."""
    contents = read_runlog(v1_log(tmp_path / "old.jsonl"), strict=True)
    header, pick, place, skip, fault, summary = contents.records
    assert isinstance(header, HeaderRecord) and header.format == 1
    assert header.model_extra == {"argv": ["--seed", "11"]}
    assert isinstance(pick, RouteRecord) and isinstance(place, RouteRecord)
    v1_names = ["joint1", "joint2", "joint3", "joint4"]
    assert pick.start_joints == dict(zip(v1_names, [120.0, 93.0, -132.0, 39.0], strict=True))
    assert pick.end_joints == dict(zip(v1_names, [102.4, 68.1, -95.2, 27.1], strict=True))
    assert place.start_joints == pick.end_joints and place.step == "place"
    assert "start_joints_deg" not in (pick.model_extra or {})
    assert isinstance(skip, SkipRecord) and skip.color == "blue"
    assert isinstance(fault, FaultRecord)
    assert fault.last_joints == dict(zip(v1_names, [120.0, 93.0, -132.0, 39.0], strict=True))
    assert isinstance(summary, SummaryRecord) and summary.sorted == {"red": 1}
    assert [t.number for t in contents.trials] == [4] and len(contents.routes) == 2


def test_format_1_header_config_loads(tmp_path: Path) -> None:
    """load_config works on a format-1 header, and its arm agrees with the routes' joints."""
    contents = read_runlog(v1_log(tmp_path / "old.jsonl"), strict=True)
    config = contents.trials[0].header.load_config()
    assert [j.name for j in config.arm.joints] == ["joint1", "joint2", "joint3", "joint4"]
    assert config.task.class_names == ["red", "green", "blue"]
    assert config.servo.error_model.offset_deg == {"joint1": 0.5, "joint2": 0.0, "joint3": -0.25}
    assert config.servo.error_model.quantization == "degree"
    home = contents.routes[0].start_joints
    np.testing.assert_allclose(config.arm.tcp_cm(home), ARM.tcp_cm(ARM.full_values(ARM.home())))
    np.testing.assert_allclose(config.arm.tcp_cm(home), [-20.16, 34.91, 19.95], atol=0.01)


def test_format_2_trial_appended_to_a_format_1_log(tmp_path: Path) -> None:
    """Appending to an old log starts a format-2 trial; each trial reads in its format."""
    path = v1_log(tmp_path / "old.jsonl")
    with RunLog(path) as log:
        write_trial(log, trial=5)
    contents = read_runlog(path, strict=True)
    assert [t.header.format for t in contents.trials] == [1, 2]
    assert list(contents.trials[0].routes[0].start_joints) == [
        "joint1",
        "joint2",
        "joint3",
        "joint4",
    ]
    assert list(contents.trials[1].routes[0].start_joints) == JOINTS


def test_upgrade_v1_record_is_explicit() -> None:
    """The conversion renames the joint lists to name-keyed mappings and nothing else."""
    route = upgrade_v1_record(V1_ROUTE)
    assert set(route) == set(V1_ROUTE) - {"start_joints_deg", "end_joints_deg"} | {
        "start_joints", "end_joints"
    }  # fmt: skip
    assert route["end_joints"] == {"joint1": 102.4, "joint2": 68.1, "joint3": -95.2, "joint4": 27.1}
    fault = upgrade_v1_record({"type": "fault", "reason": "x", "last_joints_deg": None})
    assert fault == {"type": "fault", "reason": "x", "last_joints": None}
    skip = {"type": "skip", "trial": None, "object_id": "a", "color": "red", "reason": "r"}
    assert upgrade_v1_record(skip) == skip
    header = upgrade_v1_record({"type": "header", "format": 1, "config": V1_CONFIG})
    assert header["format"] == 1 and "arm" in header["config"] and "robot" not in header["config"]
    assert V1_ROUTE["start_joints_deg"] == [120.0, 93.0, -132.0, 39.0], "input left as it was"


def test_parse_record_reads_a_line_in_its_trials_format() -> None:
    text = json.dumps(V1_ROUTE)
    route = parse_record(text, trial_format=1)
    assert isinstance(route, RouteRecord) and route.start_joints["joint4"] == 39.0
    with pytest.raises(ValueError, match="field 'start_joints' is missing"):
        parse_record(text)
    with pytest.raises(ValueError, match="route record before any header"):
        parse_record(text, trial_format=None)


def test_bad_format_1_joint_list_is_named(tmp_path: Path) -> None:
    path = v1_log(tmp_path / "old.jsonl", route={**V1_ROUTE, "end_joints_deg": [1.0, 2.0, 3.0]})
    problem = expect_problem(path, 2, "route record (format 1, read as format 2): ")
    assert "field 'end_joints_deg' must be a list of 4 joint angles" in problem.reason


def test_missing_format_1_joint_list_is_named(tmp_path: Path) -> None:
    route = {k: v for k, v in V1_ROUTE.items() if k != "start_joints_deg"}
    expect_problem(
        v1_log(tmp_path / "old.jsonl", route=route), 2, "field 'start_joints_deg' is missing"
    )


def test_bad_format_1_value_is_named_in_the_converted_field(tmp_path: Path) -> None:
    route = {**V1_ROUTE, "start_joints_deg": [120.0, "93", -132.0, 39.0]}
    path = v1_log(tmp_path / "old.jsonl", route=route)
    expect_problem(path, 2, "(format 1, read as format 2): field 'start_joints.joint2'")


def test_format_1_header_whose_config_cannot_migrate(tmp_path: Path) -> None:
    path = v1_log(tmp_path / "old.jsonl")
    lines = path.read_text().splitlines()
    header = json.loads(lines[0])
    header["config"]["servo"]["gripper"] = {"channel": 4, "open_us": 1500, "closed_us": 1500}
    path.write_text("\n".join([json.dumps(header), *lines[1:]]) + "\n")
    problem = expect_problem(path, 1, "header record (format 1, read as format 2): field 'config'")
    assert "open_us and closed_us are both 1500" in problem.reason


def test_format_1_record_before_any_header(tmp_path: Path) -> None:
    """Today's rule: nothing but a header may come first, whatever its layout."""
    path = tmp_path / "old.jsonl"
    path.write_text(json.dumps(V1_ROUTE) + "\n")
    expect_problem(path, 1, "route record before any header")


# --------------------------------------------------------------------------- torn ends


def test_a_torn_end_is_found_with_its_line(good_log: Path) -> None:
    assert find_torn_end(good_log) is None
    size = good_log.stat().st_size
    with good_log.open("ab") as f:
        f.write(b'{"type":"rou')
    torn = find_torn_end(good_log)
    assert torn is not None
    assert (torn.offset, torn.line, torn.data) == (size, 8, b'{"type":"rou')


def test_setting_a_torn_end_aside_keeps_its_bytes_and_the_log_appendable(good_log: Path) -> None:
    """The fragment moves to a side file; the log is its whole lines again; nothing lost."""
    whole = good_log.read_bytes()
    with good_log.open("ab") as f:
        f.write(b'{"type":"route","tri\xff')
    torn = find_torn_end(good_log)
    assert torn is not None
    side = set_aside_torn_end(good_log, torn)
    assert side == good_log.with_name(f"run.jsonl.torn-{len(whole)}")
    assert side.read_bytes() == b'{"type":"route","tri\xff'
    assert good_log.read_bytes() == whole
    with RunLog(good_log) as log:  # appendable again
        write_trial(log, trial=1)
    assert read_runlog(good_log).complete


def test_a_side_file_name_in_use_is_not_overwritten(good_log: Path) -> None:
    with good_log.open("ab") as f:
        f.write(b"partial")
    torn = find_torn_end(good_log)
    assert torn is not None
    taken = good_log.with_name(f"run.jsonl.torn-{torn.offset}")
    taken.write_bytes(b"something else")
    side = set_aside_torn_end(good_log, torn)
    assert side.name.endswith("-2") and side.read_bytes() == b"partial"
    assert taken.read_bytes() == b"something else"


def test_a_log_changed_meanwhile_is_not_cut(good_log: Path) -> None:
    with good_log.open("ab") as f:
        f.write(b"partial")
    torn = find_torn_end(good_log)
    assert torn is not None
    with good_log.open("ab") as f:
        f.write(b" and more")
    before = good_log.read_bytes()
    with pytest.raises(RunLogError, match="changed"):
        set_aside_torn_end(good_log, torn)
    assert good_log.read_bytes() == before


def test_end_line_completes_a_whole_last_record(good_log: Path) -> None:
    good_log.write_bytes(good_log.read_bytes()[:-1])
    assert read_runlog(good_log).complete  # a whole record without its newline reads
    end_line(good_log)
    assert find_torn_end(good_log) is None and read_runlog(good_log).complete


# --------------------------------------------------------------------------- repeated trials


def test_a_cut_off_attempt_is_superseded_by_the_complete_one(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    with RunLog(path) as log:
        write_trial(log, trial=0)
        log.header(Config(), trial=1, seed=7)  # cut off: no summary
        log.route(**route_fields(trial=1))
        log.header(Config(), trial=1, seed=7)  # cut off again
        write_trial(log, trial=1)
    contents = read_runlog(path)
    assert [t.number for t in contents.trials] == [0, 1, 1, 1]
    assert [t.line for t in contents.superseded] == [6, 8]
    latest = contents.latest()
    assert [(t.number, t.complete) for t in latest.trials] == [(0, True), (1, True)]
    assert len(latest.routes) == 4 and len(latest.records) == 10
    assert all(r.trial in (0, 1) for r in latest.records)


def test_without_a_complete_attempt_the_last_one_is_kept(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    with RunLog(path) as log:
        for _ in range(2):
            log.header(Config(), trial=3, seed=7)
            log.route(**route_fields(trial=3))
    latest = read_runlog(path).latest()
    assert [t.line for t in latest.trials] == [3] and len(latest.routes) == 1


def test_sort_runs_are_never_superseded(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    with RunLog(path) as log:
        write_trial(log, trial=None)
        write_trial(log, trial=None)
    contents = read_runlog(path)
    assert contents.superseded == () and contents.latest() is contents


def test_a_trial_complete_twice_is_refused_naming_it(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    with RunLog(path) as log:
        for trial in (0, 1, 0, 1, 2):
            write_trial(log, trial=trial)
    with pytest.raises(RepeatedTrialError, match=r"trials 0, 1 are complete more than once") as e:
        read_runlog(path).latest()
    assert e.value.lines == {0: (1, 11), 1: (6, 16)}
    assert "trial 0 at lines 1 and 11" in str(e.value)
