"""A warning or note a command says on stderr is named as its errors are: ``mearm CMD:``.

``mearm detect``'s warnings on a frame (its size, no colour), ``mearm analyze``'s on a
damaged log and ``config-docs --check``'s stale line said no command, unlike every other
line on stderr: in a pipeline or a log, which command said it was lost.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
from badinput import ROOT, run_in_process


def test_detect_names_itself_in_its_warnings(tmp_path: Path) -> None:
    grey = tmp_path / "grey.png"
    cv2.imwrite(str(grey), np.full((240, 320, 3), 128, np.uint8))
    done = subprocess.run(
        [sys.executable, "-m", "mearm", "detect", "--config", "sim", str(grey)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        check=False,
    )
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 2, done.stderr
    assert lines[0].startswith(f"mearm detect: warning: {grey} is 320x240 px"), lines
    assert lines[1].startswith(f"mearm detect: warning: {grey} has no colour"), lines


def test_config_docs_names_itself_when_the_page_is_stale(tmp_path: Path) -> None:
    stale = tmp_path / "configuration.md"
    stale.write_text("# old\n", encoding="utf-8")
    done = run_in_process(["config-docs", "--check", stale], within_s=30)
    assert done.code == 1
    assert done.stderr.splitlines() == [
        f"mearm config-docs: {stale} is stale: run mearm config-docs --output {stale} --force"
    ]
