"""``python -m mearm.analyze``: tables, JSON, plots + report.md, damaged logs, gain sweeps."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

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


def test_out_writes_plots_and_a_report_that_links_them(log: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "report"
    data = run_json(capsys, str(log), "--out", str(out))
    report = out / "report.md"
    assert data["report"] == str(report)
    assert set(data["plots"]) == {"histogram", "success", "path3d", "joints"}
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
    assert captured.err.startswith(f"warning: {damaged}: line 6: ")
    assert "field 'success' is missing" in captured.err
    assert "analysed the 5 records before it" in captured.err
    with pytest.raises(RunLogFormatError, match="line 6"):
        main([str(damaged), "--strict"])


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
    np.testing.assert_allclose(only_kp["start_joints_deg"], [90, 90, -120, 30], atol=1e-9)


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
def test_cli_errors_are_one_line_and_exit_2(argv: list[str], pattern: str, tmp_path: Path) -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "mearm.analyze", *argv], capture_output=True, text=True, cwd=tmp_path
    )
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1 and pattern in proc.stderr


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
