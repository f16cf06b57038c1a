"""The soak tests stay out of ``make test`` and run when asked for (``make soak``)."""

from __future__ import annotations

import subprocess
import sys

import pytest
from conftest import ROOT


def _collect(*args: str) -> str:
    r = subprocess.run(
        [sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider",
         "-p", "no:xdist", "tests/test_soak.py", *args],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    return r.stdout.strip().splitlines()[-1]


@pytest.mark.slow  # two pytest processes collecting: a few seconds
def test_the_soak_runs_only_when_its_marker_is_asked_for():
    """Left out by another -m expression (as by none: the same rule); collected by ``-m soak``."""
    assert _collect("-m", "not slow and not heavy").startswith("no tests collected (3 deselected)")
    assert _collect("-m", "soak").startswith("3 tests collected")
