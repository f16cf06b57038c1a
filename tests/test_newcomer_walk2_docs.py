"""docs/troubleshooting.md's quoted lines are what the commands print (a newcomer's walk).

The page said a config's problems came "one line per bad key" and quoted the millimetre
hint without the count the line starts with; the program puts every problem on the one
line, counted. The find-camera and find-port failures it now quotes are checked the same
way, in this process (:func:`conftest.mearm_here`: the lines are the point, not the
process); find-camera's in a process of its own, whose stderr holds OpenCV's own too.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest
from conftest import mearm_cli, mearm_here, one_stderr_line

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "troubleshooting.md"


def _quoted(start: str) -> str:
    """The page's one quoted line that starts with ``start``."""
    lines = [ln for ln in PAGE.read_text(encoding="utf-8").splitlines() if ln.startswith(start)]
    assert len(lines) == 1, (start, lines)
    return lines[0]


def test_problems_share_one_line_as_the_page_says(tmp_path):
    (tmp_path / "bad.yaml").write_text(
        "extends: sim\ncontroller:\n  kp: -1\n  max_iterations: 0\n", encoding="utf-8"
    )
    proc = mearm_here("fk", "--config", "bad.yaml", "--joints", "90,90,-90", cwd=tmp_path)
    assert one_stderr_line(proc, code=2) == _quoted("mearm fk: error: bad.yaml: 2 problems:")
    assert "one line per bad key" not in PAGE.read_text(encoding="utf-8")


@pytest.mark.heavy
def test_the_millimetre_line_is_the_sorts(tmp_path):
    (tmp_path / "mm.yaml").write_text(
        "extends: sim_mearm_v1\narm:\n  joints:\n    shoulder: {dh: {a_cm: 80}}\n"
        "    elbow: {dh: {a_cm: 80}}\n",
        encoding="utf-8",
    )
    line = one_stderr_line(mearm_here("sort", "--config", "mm.yaml", cwd=tmp_path), code=2)
    quoted = _quoted("mearm sort: error: mm.yaml: 3 problems: arm.joints:")
    assert quoted.endswith(" …") and line.startswith(quoted.removesuffix(" …")), (line, quoted)


@pytest.mark.skipif(
    any(re.fullmatch(r"video\d+", p.name) for p in Path("/dev").glob("video*")),
    reason="this machine has cameras",
)
def test_find_cameras_quoted_failure_is_its_own(tmp_path):
    proc = mearm_cli("find-camera", "--out", tmp_path / "s", cwd=tmp_path)
    line = one_stderr_line(proc, code=1)
    assert line == _quoted("mearm find-camera: error:")


def test_find_ports_quoted_failure_is_its_own(tmp_path):
    master, slave = os.openpty()  # a port that never prints the firmware's banner
    try:
        proc = mearm_here("find-port", "--only", "--port", os.ttyname(slave), "--timeout", "0.2",
                       cwd=tmp_path)  # fmt: skip
    finally:
        os.close(slave)
        os.close(master)
    line = one_stderr_line(proc, code=1)  # find-port's failure is the one error line
    assert line == _quoted("mearm find-port: error:")
    assert line.startswith("mearm find-port: error: no mearm board found"), line
    assert "not a mearm board" in proc.stdout
