"""The soak tests stay out of ``make test`` and run when asked for (``make soak``)."""

from __future__ import annotations

import subprocess
import sys

import pytest
from conftest import ROOT

#: One fresh pytest (not this session's: its own ``-m`` and plugins) collecting
#: tests/test_soak.py once per ``-m`` expression given, each collection's last line after
#: an ``=== -m EXPR`` line.
COLLECT_EACH = """\
import sys
import pytest
for expr in sys.argv[1:]:
    print("=== -m " + expr, flush=True)
    pytest.main(["--collect-only", "-q", "-p", "no:cacheprovider", "-p", "no:xdist",
                 "tests/test_soak.py", "-m", expr])
    sys.stdout.flush()
"""


def _collect(*exprs: str) -> dict[str, str]:
    """``-m`` expression → the last line of its collection."""
    r = subprocess.run(
        [sys.executable, "-c", COLLECT_EACH, *exprs],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert r.returncode == 0, r.stdout + r.stderr
    last: dict[str, str] = {}
    expr = ""
    for line in r.stdout.splitlines():
        if line.startswith("=== -m "):
            expr = line.removeprefix("=== -m ")
        elif line.strip():
            last[expr] = line.strip()
    return last


@pytest.mark.slow  # a pytest process collecting twice: a few seconds
def test_the_soak_runs_only_when_its_marker_is_asked_for():
    """Left out by another -m expression (as by none: the same rule); collected by ``-m soak``."""
    last = _collect("not slow and not heavy", "soak")
    assert last["not slow and not heavy"].startswith("no tests collected (3 deselected)"), last
    assert last["soak"].startswith("3 tests collected"), last
