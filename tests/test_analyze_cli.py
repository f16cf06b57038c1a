"""``python -m mearm.analyze``: tables, JSON, plots + report.md, damaged logs, gain sweeps."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from badinput import run_in_process

from mearm.analysis.synthetic import write_synthetic_log
from mearm.analyze import main
from mearm.exceptions import AnalysisError, RunLogError, RunLogFormatError

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("cli") / "trials.jsonl"
    write_synthetic_log(path, n_routes=240, seed=1)
    return path


def run_json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict:
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_text_output_puts_the_paper_beside_ours(log: Path, capsys) -> None:
    assert main([str(log)]) == 0
    out = capsys.readouterr().out
    for title in ("Table 8", "Weibull fit", "Table 9", "Pick success against error", "Table 6"):
        assert title in out
    assert re.search(r"^xyz .*0\.62397\s+0\.32284\s+2\.15026\s+0\.02186$", out, re.M)
    assert re.search(r"^total .*\(\d+/\d+\)\s+94\.25 %", out, re.M)


def test_json_holds_every_figure(log: Path, capsys) -> None:
    data = run_json(capsys, str(log))["analysis"]
    assert data["routes"] == 240 and data["problem"] is None
    errors = np.array(
        [
            json.loads(line)["error_cm"]
            for line in log.read_text().splitlines()
            if '"type":"route"' in line
        ]
    )
    assert data["table8"]["xyz"]["mean"] == pytest.approx(np.linalg.norm(errors, axis=1).mean())
    assert data["table8"]["x"]["std"] == pytest.approx(errors[:, 0].std(ddof=1))
    assert 1.5 < data["weibull"]["shape"] < 2.7
    assert set(data["table9"]["pick"]) == {"red", "green", "blue"}
    assert data["paper"]["table8_cm"]["xyz"]["mean"] == 0.62397
    assert set(data["table6"]) == {"all", "pick", "place"}


def test_step_selection(log: Path, capsys) -> None:
    picks = run_json(capsys, str(log), "--step", "pick")["analysis"]
    places = run_json(capsys, str(log), "--step", "place")["analysis"]
    first = run_json(capsys, str(log), "--step", "pick", "--first-attempt")["analysis"]
    assert picks["table8"]["n"] + places["table8"]["n"] == 240
    assert first["table8"]["n"] < picks["table8"]["n"]
    assert picks["step"] == "pick" and first["first_attempt"] is True


@pytest.mark.heavy
def test_out_writes_plots_and_a_report_that_links_them(log: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "report"
    data = run_json(capsys, str(log), "--out", str(out))
    report = out / "report.md"
    assert data["report"] == str(report)
    assert set(data["plots"]) == {"histogram", "success", "path3d", "joints"}
    from mearm.analyze import OUTPUT_NAMES  # what a log there must not be called

    assert {p.name for p in out.iterdir()} <= set(OUTPUT_NAMES)
    text = report.read_text()
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
    assert sorted(links) == sorted(Path(p).name for p in data["plots"].values())
    for link in links:
        png = out / link  # relative to the report
        assert png.read_bytes()[:8] == PNG_MAGIC and png.stat().st_size > 10_000
    assert "Table 8" in text and "synthetic data" in text
    assert "## Paths" in text and "solved again with PD-PIJ" in text


def test_a_torn_log_is_analysed_up_to_the_bad_line(log: Path, tmp_path: Path, capsys) -> None:
    lines = log.read_bytes().splitlines(keepends=True)
    bad = len(lines) - 7
    torn = tmp_path / "torn.jsonl"
    torn.write_bytes(b"".join(lines[: bad - 1]) + lines[bad - 1][:40])
    assert main([str(torn), "--json"]) == 0
    captured = capsys.readouterr()
    problem = json.loads(captured.out)["analysis"]["problem"]
    assert problem["line"] == bad and "torn last line" in problem["reason"]
    assert f"line {bad}: torn last line" in captured.err
    routes_before = sum(b'"type":"route"' in line for line in lines[: bad - 1])
    assert json.loads(captured.out)["analysis"]["routes"] == routes_before


def test_damaged_log_warning_on_stderr(log: Path, tmp_path: Path, capsys) -> None:
    lines = log.read_text().splitlines()
    obj = json.loads(lines[5])
    del obj["success"]
    damaged = tmp_path / "damaged.jsonl"
    damaged.write_text("\n".join([*lines[:5], json.dumps(obj), *lines[6:]]) + "\n")
    assert main([str(damaged)]) == 0
    captured = capsys.readouterr()
    assert captured.err.startswith(f"python -m mearm.analyze: warning: {damaged}: line 6: ")
    assert "field 'success' is missing" in captured.err
    assert "analysed the 5 records before it" in captured.err
    with pytest.raises(RunLogFormatError, match="line 6"):
        main([str(damaged), "--strict"])


@pytest.mark.heavy
def test_gain_sweeps(capsys, tmp_path: Path) -> None:
    """Larger kp converges in fewer iterations; the table names mode, kp and kd."""
    data = run_json(capsys, "--gains", "--mode", "paper", "--out", str(tmp_path))
    by_kp = data["gains"]["kp"]
    assert [g["kp"] for g in by_kp] == [0.01, 0.1, 0.5]
    assert all(g["status"] == "converged" and g["mode"] == "paper" for g in by_kp)
    iterations = [g["iterations"] for g in by_kp]
    assert iterations[0] > iterations[1] > iterations[2]
    assert [g["kd"] for g in data["gains"]["kd"]] == [0.0, 0.01, 0.1, 0.5]
    assert all(g["final_error_cm"] ** 2 < 1e-3 for g in by_kp)
    np.testing.assert_allclose(by_kp[0]["target_cm"], [-10.99, 49.70, 12.76])
    for name in ("gains_kp.png", "gains_kd.png"):
        assert (tmp_path / name).read_bytes()[:8] == PNG_MAGIC
    assert "## Gains" in (tmp_path / "report.md").read_text()


def test_gain_sweep_with_own_route(capsys) -> None:
    data = run_json(
        capsys,
        "--gains",
        "--kp",
        "0.2",
        "--kd",
        "0",
        "--start",
        "90,90,-120",
        "--target",
        "5,45,15",
    )
    (only_kp,) = data["gains"]["kp"]
    assert only_kp["kp"] == 0.2
    assert list(only_kp["start_joints"]) == ["base", "shoulder", "elbow", "wrist"]
    np.testing.assert_allclose(
        list(only_kp["start_joints"].values()), [90, 90, -120, 30], atol=1e-9
    )


def test_bad_gain_is_an_error() -> None:
    with pytest.raises(AnalysisError, match="kp = 0.0"):
        main(["--gains", "--kp", "0"])


def test_missing_log_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(RunLogError, match="no such run log"):
        main([str(tmp_path / "nope.jsonl")])


def test_empty_log_is_an_error(tmp_path: Path) -> None:
    empty = tmp_path / "empty.jsonl"
    empty.write_text("")
    with pytest.raises(AnalysisError, match="no routes"):
        main([str(empty)])


@pytest.mark.parametrize(
    ("argv", "pattern"),
    [
        ([], "give a run log"),
        (["x.jsonl", "--step", "drop"], "invalid choice"),
        (["--gains", "--start", "1,2"], "--start needs 3 numbers"),
    ],
)
def test_cli_errors_are_one_line_and_exit_2(argv: list[str], pattern: str) -> None:
    """In this process, through the command's guard (the test below runs a real process)."""
    out = run_in_process(["analyze", *argv])
    assert out.code == 2
    assert len(out.stderr.strip().splitlines()) == 1 and pattern in out.stderr


@pytest.mark.heavy
def test_cli_strict_damaged_log_exits_2(log: Path, tmp_path: Path) -> None:
    torn = tmp_path / "torn.jsonl"
    torn.write_bytes(log.read_bytes()[:-25])
    proc = subprocess.run(
        [sys.executable, "-m", "mearm.analyze", str(torn), "--strict"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert "torn last line" in proc.stderr


#: A format-1 header's config (the ``robot:`` layout), as format 1 wrote it.
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
    "servo": {"backend": "sim", "error_model": {"quantization": "degree"}},
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
V1_HOME = [120.0, 93.0, -132.0, 39.0]
V1_POSE = [102.4, 68.1, -95.2, 27.1]  # θ4 = −θ2 − θ3


def v1_route(object_id, color, step, attempt, target, start, end, error, ok) -> dict:
    return {
        "type": "route", "trial": 0, "object_id": object_id, "color": color, "step": step,
        "attempt": attempt, "target_cm": target, "start_joints_deg": start,
        "end_joints_deg": end, "iterations": 82, "status": "converged",
        "initial_error_cm": 24.99, "final_error_cm": 0.0305,
        "ee_cm": [t + e for t, e in zip(target, error, strict=True)], "error_cm": error,
        "success": ok, "elapsed_s": 0.05, "motion_s": 6.0,
    }  # fmt: skip


@pytest.fixture()
def v1_log(tmp_path: Path) -> Path:
    """A format-1 log written by hand: joint lists θ1..θ4 [deg], the ``robot:`` config."""
    pick, place = [-10.99, 49.7, 12.76], [-20.0, 35.0, 20.0]
    green, green_bin = [-8.31, 53.81, 12.76], [-20.0, 45.0, 20.0]
    lines = [
        {"type": "header", "format": 1, "mearm_version": "0.1.0",
         "started": "2026-01-02T03:04:05+00:00", "config": V1_CONFIG,
         "versions": {"python": "3.11.9"}, "trial": 0, "seed": 11},
        v1_route("red1", "red", "pick", 1, pick, V1_HOME, V1_POSE, [0.49, 0.2, -0.66], True),
        v1_route("red1", "red", "place", 1, place, V1_POSE, V1_HOME, [0.0, 0.5, 0.0], True),
        v1_route("green1", "green", "pick", 1, green, V1_HOME, V1_POSE, [0.0, 1.5, 0.0], False),
        v1_route("green1", "green", "pick", 2, green, V1_POSE, V1_POSE, [0.0, 0.3, 0.0], True),
        v1_route("green1", "green", "place", 1, green_bin, V1_POSE, V1_HOME, [0.1, 0, 0], True),
        {"type": "skip", "trial": 0, "object_id": "blue1", "color": "blue",
         "target_cm": None, "reason": "outside box"},
        {"type": "summary", "trial": 0, "sorted": {"red": 1, "green": 1}, "failures": 1,
         "skipped": 1, "routes": 5, "mean_iterations": 82.0, "mean_final_error_cm": 0.0305,
         "motion_s": 30.0, "ok": True},
    ]  # fmt: skip
    path = tmp_path / "v1.jsonl"
    path.write_text("".join(json.dumps(line) + "\n" for line in lines))
    return path


@pytest.mark.heavy
def test_a_format_1_log_is_analysed_end_to_end(v1_log: Path, tmp_path: Path, capsys) -> None:
    """A hand-written format-1 log: tables printed, Table 9 in its config's class order,
    and its logged joints (named joint1..joint4 on reading) solved again for the plots."""
    assert main([str(v1_log)]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    for title in ("Table 8", "Weibull fit", "Table 9", "Pick success against error", "Table 6"):
        assert title in captured.out
    assert re.search(r"^green .*\(0/1\)\s+94\.00 %", captured.out, re.M)
    assert main([str(v1_log), "--out", str(tmp_path / "report"), "--json"]) == 0
    captured = capsys.readouterr()
    assert "path plots skipped" not in captured.err
    data = json.loads(captured.out)
    a = data["analysis"]
    assert (a["trials"], a["routes"], a["skips"], a["problem"]) == (1, 5, 1, None)
    assert list(a["table9"]["pick"]) == ["red", "green", "blue"]
    assert a["table9"]["pick"]["green"] == {"successes": 0, "n": 1, "rate": 0.0}
    assert a["table8"]["xyz"]["max"] == pytest.approx(1.5)
    assert set(data["plots"]) == {"histogram", "success", "path3d", "joints"}


# --------------------------------------------------------------------------- repeated trials


@pytest.mark.heavy
def test_a_cut_off_attempt_that_was_run_again_is_left_out(log: Path, tmp_path: Path, capsys):
    """Trial 0 cut off before its summary, then run again: only the complete one counts."""
    lines = log.read_text().splitlines(keepends=True)
    first_summary = next(i for i, line in enumerate(lines) if '"type":"summary"' in line)
    rerun = tmp_path / "rerun.jsonl"
    rerun.write_text("".join(lines[:first_summary] + lines))
    assert main([str(rerun), "--json"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["analysis"]["routes"] == 240
    assert captured.err.startswith(
        "python -m mearm.analyze: note: left out 1 cut-off attempt(s) of trial(s) 0"
    )


def test_two_runs_in_one_log_are_refused(log: Path, tmp_path: Path) -> None:
    twice = tmp_path / "twice.jsonl"
    twice.write_bytes(log.read_bytes() * 2)
    with pytest.raises(RunLogError, match=r"trials 0, 1, 2, .* are complete more than once"):
        main([str(twice)])


# --------------------------------------------------------------------------- writing --out


@pytest.mark.heavy
def test_report_and_plots_replace_old_ones_through_links(log: Path, tmp_path: Path, capsys):
    """report.md linked elsewhere is written through the link (--force: it exists); no
    temp file is left."""
    out, kept = tmp_path / "report", tmp_path / "kept"
    out.mkdir()
    kept.mkdir()
    (kept / "report.md").write_text("old")
    (out / "report.md").symlink_to(kept / "report.md")
    (out / "histogram.png").write_bytes(b"old png")
    assert main([str(log), "--out", str(out), "--force"]) == 0
    capsys.readouterr()
    assert (out / "report.md").is_symlink()
    assert "histogram.png" in (kept / "report.md").read_text()
    assert (out / "histogram.png").read_bytes()[:8] == PNG_MAGIC
    assert not [p for d in (out, kept) for p in d.iterdir() if p.name.endswith(".tmp")]


@pytest.mark.parametrize("name", ["report.md", "histogram.png"])
def test_a_log_that_out_would_write_over_is_refused(log: Path, tmp_path: Path, name) -> None:
    """A run log kept as ``report/report.md`` was replaced by its own report."""
    out = tmp_path / "report"
    out.mkdir()
    kept = out / name
    kept.write_bytes(log.read_bytes())
    with pytest.raises(SystemExit) as e:
        main([str(kept), "--out", str(out)])
    assert e.value.code == 2 and kept.read_bytes() == log.read_bytes()


def test_out_that_is_a_file_is_refused(log: Path, tmp_path: Path) -> None:
    (tmp_path / "file").write_text("keep")
    with pytest.raises(SystemExit) as e:
        main([str(log), "--out", str(tmp_path / "file")])
    assert e.value.code == 2 and (tmp_path / "file").read_text() == "keep"


def test_picks_when_the_jaws_close_have_their_own_table(log: Path, tmp_path: Path, capsys):
    """``grip_ee_cm`` on the picks: their settled error in its own table; without, none."""
    assert main([str(log)]) == 0
    assert "Picks when the jaws close" not in capsys.readouterr().out
    assert run_json(capsys, str(log))["analysis"]["grip"] is None
    lines, offsets = [], []
    for k, line in enumerate(log.read_text().splitlines()):
        record = json.loads(line)
        if record["type"] == "route" and record["step"] == "pick":
            offset = [0.01 * (k % 7), -0.02, 0.03]
            record["grip_ee_cm"] = list(np.add(record["target_cm"], offset))
            offsets.append(offset)
        lines.append(json.dumps(record))
    gripped = tmp_path / "gripped.jsonl"
    gripped.write_text("\n".join(lines) + "\n")
    assert main([str(gripped)]) == 0
    assert f"Picks when the jaws close: TCP − target [cm], {len(offsets)} picks" in (
        capsys.readouterr().out
    )
    grip = run_json(capsys, str(gripped))["analysis"]["grip"]
    norms = np.linalg.norm(offsets, axis=1)
    assert grip["xyz"]["mean"] == pytest.approx(norms.mean())
    assert grip["z"]["mean"] == pytest.approx(0.03)


# ----------------------------------------------- refused before writing; written whole


def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--gains", "--start", "1,2"], "--start needs 3 numbers"),
        (["--gains", "--kp", "-1"], "greater than 0"),
    ],
)
def test_a_refused_gain_option_leaves_the_earlier_report_whole(
    log: Path, tmp_path: Path, capsys, extra: list[str], message: str
) -> None:
    """The plots of the log were written before the gains were checked: half a new run."""
    out = tmp_path / "report"
    assert main([str(log), "--out", str(out)]) == 0
    before = _files(out)
    result = run_in_process(
        ["analyze", str(log), "--step", "pick", *extra, "--out", str(out), "--force"]
    )
    assert result.code == 2 and message in result.stderr
    assert _files(out) == before
    fresh = tmp_path / "fresh"
    assert run_in_process(["analyze", str(log), *extra, "--out", str(fresh)]).code == 2
    assert not fresh.exists()


def test_an_interrupted_report_leaves_the_earlier_one_whole(
    log: Path, tmp_path: Path, capsys, monkeypatch: pytest.MonkeyPatch
) -> None:
    import mearm.analyze as analyze

    out = tmp_path / "report"
    assert main([str(log), "--out", str(out)]) == 0
    before = _files(out)

    def interrupted(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(analyze, "_path_plots", interrupted)  # the histogram is written
    with pytest.raises(KeyboardInterrupt):
        main([str(log), "--step", "pick", "--out", str(out), "--force"])
    assert _files(out) == before  # (no hidden folder left either)


@pytest.mark.parametrize("option", [["--kp", "0.1"], ["--config", "sim"], ["--mode", "paper"]])
def test_gain_options_without_gains_are_refused(log: Path, option: list[str]) -> None:
    """They were read by nothing: the run looked as if it had obeyed them."""
    out = run_in_process(["analyze", str(log), *option])
    assert out.code == 2 and len(out.stderr.strip().splitlines()) == 1
    assert f"{option[0]}: read only with --gains" in out.stderr


def test_out_below_a_file_is_refused_before_the_analysis(log: Path, tmp_path: Path) -> None:
    (tmp_path / "file").write_text("keep")
    out = run_in_process(["analyze", str(log), "--out", str(tmp_path / "file" / "sub")])
    assert out.code == 2 and "--out" in out.stderr and "is a file, not a folder" in out.stderr


def test_the_text_says_the_faults_that_stopped_trials(tmp_path: Path, capsys) -> None:
    """A log whose trial a fault stopped said only "skipped objects: 0"; the fault count
    was in --json and the report alone."""
    from mearm.config import load_config
    from mearm.runlog import RunLog

    path = tmp_path / "faulted.jsonl"
    write_synthetic_log(path, n_routes=48, seed=2)
    with RunLog(path, fsync=False) as log:
        log.header(load_config("sim"), trial=99, seed=0)
        log.fault("camera (sim): the frame is black; arm parked at home", None, trial=99)
        log.summary(trial=99, ok=False, objects={"red": 4}, left={"fault": 4})
    assert main([str(path)]) == 0
    out = capsys.readouterr().out
    assert "faults: 1 (each stopped its run or trial: the objects it left were not " \
        "attempted, and no table here counts them)" in " ".join(out.split())  # fmt: skip
