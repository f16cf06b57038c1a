"""The line after an experiment counts its workers: ``1 worker``, not ``1 workers``."""

from __future__ import annotations

from pathlib import Path

import pytest

from mearm.experiment import commandline

SCENE = "- {color: red, x: -10.99, y: 49.70}\n"


def test_the_line_after_a_run_counts_one_worker_as_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--jobs 2`` with one trial left starts one worker, and says ``1 worker``."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(SCENE)
    argv = ["--scene", str(scene), "--log", str(tmp_path / "t.jsonl"), "--jobs", "2"]
    assert commandline.main([*argv, "--trials", "1"]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if " written to " in x)
    assert line.endswith(", 1 worker); 0 stopped early"), line
