"""tools/calibration_worth.py reuses only the kit files this run's settings would make,
and keeps a ``results.json`` already in ``--out``.

A second run with ``--reading-seed 5`` printed ``each kit's own reading seed (base 5)``
over kit files made with base 0, and every run replaced ``results.json`` silently (a
hand-written one was lost). The ``mearm`` steps are stood in for here (the refusal and the
backup are the tool's own; the steps are tested with their commands).
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path
from types import ModuleType

import pytest
from badinput import tool_module

from mearm.cli import run

SUMMARY = {
    "analysis": {
        "table8": {"xyz": {"mean": 0.5, "n": 2}},
        "table9": {"pick_total": {"successes": 2, "n": 2}},
    }
}


@pytest.fixture
def tool(monkeypatch: pytest.MonkeyPatch) -> tuple[ModuleType, list[tuple[str, ...]]]:
    """The tool with its ``mearm`` steps stood in for; the steps it ran."""
    module = tool_module("calibration_worth")
    calls: list[tuple[str, ...]] = []

    def fake(*args: str, ok: tuple[int, ...] = (0,)) -> subprocess.CompletedProcess[str]:
        calls.append(args)
        if args[0] == "calibrate-servos":
            out = Path(args[args.index("--output") + 1])
            out.write_text(f"reading seed {args[args.index('--reading-seed') + 1]}\n")
        elif args[0] == "experiment":
            Path(args[args.index("--log") + 1]).write_text("")
        return subprocess.CompletedProcess(args, 0, json.dumps(SUMMARY), "")

    monkeypatch.setattr(module, "mearm", fake)
    return module, calls


def _exit_of(module: ModuleType, argv: list[str]) -> int:
    with pytest.raises(SystemExit) as stop:
        run(module.main, argv)
    return int(stop.value.code or 0)


def test_a_kit_file_made_with_another_reading_seed_is_refused(tool, tmp_path, capsys):
    """Base 0, then base 5 into the same --out: exit 2, one line naming both seeds, and
    nothing run (it reused base 0's kit file and said base 5)."""
    module, calls = tool
    out = tmp_path / "cw"
    argv = ["--out", str(out), "--kits", "1", "--trials", "1", "--jobs", "1"]
    assert _exit_of(module, argv) == 0
    made = json.loads((out / "kit1.servos.made.json").read_text())
    assert made["reading_seed"] == module.reading_seed(0, 1)
    capsys.readouterr()
    calls.clear()
    before = (out / "results.json").read_text()

    assert _exit_of(module, [*argv, "--reading-seed", "5"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "kit1.servos.yaml was made with reading seed" in line
    assert f"{module.reading_seed(0, 1)} (base 0), not this run's" in line
    assert f"{module.reading_seed(5, 1)} (base 5)" in line and "fresh --out" in line
    assert calls == []
    assert (out / "results.json").read_text() == before


def test_a_kit_file_with_no_record_is_refused(tool, tmp_path, capsys):
    """A kit file in --out that no run of this tool recorded (an older run, a copy): its
    reading seed is unknown, so it is not passed off as this run's."""
    module, calls = tool
    out = tmp_path / "cw"
    out.mkdir()
    (out / "kit1.servos.yaml").write_text("mine\n")
    code = _exit_of(module, ["--out", str(out), "--kits", "1", "--jobs", "1"])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert "kit1.servos.yaml is there with no record of what made it" in line
    assert calls == []


def test_the_same_settings_reuse_the_kit_file_and_keep_results(tool, tmp_path, capsys):
    """A second run with the same settings reuses the kit file (no calibration run) and
    keeps the results.json it replaces, a hand-written one too, as results.json.bak."""
    module, calls = tool
    out = tmp_path / "cw"
    out.mkdir()
    (out / "results.json").write_text("my notes\n")
    argv = ["--out", str(out), "--kits", "1", "--trials", "1", "--jobs", "1"]
    assert _exit_of(module, argv) == 0
    said = capsys.readouterr().out
    assert (out / "results.json.bak").read_text() == "my notes\n"
    assert f"wrote {out / 'results.json.bak'} (the old {out / 'results.json'})" in said
    calls.clear()
    assert _exit_of(module, argv) == 0
    assert [c[0] for c in calls] == ["experiment", "analyze", "experiment", "analyze"]
    assert (out / "results.json.bak").read_text() == "my notes\n"  # same results: no .bak.1
    assert not (out / "results.json.bak.1").exists()
