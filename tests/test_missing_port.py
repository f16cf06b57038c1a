"""A servo port that cannot be opened is found as the rig opens: exit 2, one line.

As for a camera that cannot be opened: the sort never starts (no summary of objects
"never seen by the camera", no note on servos never calibrated), and its run log records
the fault as before the sort started. ``mearm jog`` says the same in one line.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from badinput import check_bad_input
from test_maker_calibrate import ROOT, PtyCommand

SIM = ROOT / "configs" / "sim.yaml"
NO_PORT = "/dev/ttyNOPE-mearm-test"
#: The sim config on a serial board whose port does not exist.
ON_NO_PORT = ["--config", str(SIM), "--set", "servo.backend=serial"]


@pytest.mark.bad_input
@pytest.mark.heavy
def test_sort_on_a_port_that_does_not_exist_is_exit_2_before_the_sort(tmp_path: Path):
    """One line naming the port and find-port; the log's fault is before the sort started."""
    log = tmp_path / "run.jsonl"
    out = check_bad_input(
        ["sort", *ON_NO_PORT, "--set", f"servo.port={NO_PORT}", "--log", log], within_s=10.0
    )
    assert out.line.startswith(f"mearm sort: error: {NO_PORT}: cannot open"), out.stderr
    assert "mearm find-port" in out.line
    assert "never seen" not in out.stdout + out.stderr
    records = [json.loads(line) for line in log.read_text().splitlines()]
    assert [r["type"] for r in records] == ["header", "fault", "summary"]
    assert records[1]["reason"].startswith(f"before the sort started: {NO_PORT}: cannot open")
    assert records[2]["ok"] is False and records[2]["objects"] == {}


@pytest.mark.heavy
def test_jog_on_a_port_that_does_not_exist_is_exit_2_in_one_line():
    """On a terminal, before the keys are taken: exit 2, one line naming the port."""
    line = pty_error_line("jog", *ON_NO_PORT, "--port", NO_PORT)
    assert line.startswith(f"mearm jog: error: {NO_PORT}: cannot open"), line
    assert "mearm find-port" in line


def pty_error_line(*argv: str) -> str:
    """``mearm ARGV`` on a terminal: exit 2, and the one line it printed."""
    cmd = PtyCommand(*argv)
    try:
        assert cmd.wait() == 2, cmd.text
    finally:
        cmd.close()
    lines = cmd.text.strip().splitlines()
    assert len(lines) == 1, cmd.text
    return lines[0]
