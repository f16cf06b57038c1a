"""``--cpu-top N``: where the suite's CPU went, by test file, also across xdist's workers.

On 2 cores ``make test``'s wall time follows the suite's CPU, so this table, not the
slowest tests' wall time, says what to cut (tests/conftest.py, "where the CPU goes").
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
#: One file whose tests run ``mearm`` in child processes, and one whose tests do not.
WITH_CHILDREN = "tests/test_fk_cli.py"
IN_PROCESS = "tests/test_carry_limits.py"
#: A row of the table: total, own and children's CPU [s], the tests run, the file.
ROW = re.compile(
    r"^\s*([\d.]+) s\s+\(\s*([\d.]+) \+\s*([\d.]+) in children\)\s+(\d+) tests\s+(\S+)$"
)


def _run(*args: str) -> dict[str, tuple[float, float, float, int]]:
    """Run pytest on the two files with ``args``; the table's rows by file."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
    out = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *args,
         WITH_CHILDREN, IN_PROCESS],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    rows = {}
    for line in out.stdout.splitlines():
        if (m := ROW.match(line)) is not None:
            rows[m[5]] = (float(m[1]), float(m[2]), float(m[3]), int(m[4]))
    return rows


def _counted(path: str) -> int:
    out = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "--collect-only", "-p", "no:cacheprovider", path],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    return int(re.search(r"(\d+) tests? collected", out.stdout)[1])


@pytest.mark.heavy
@pytest.mark.parametrize("workers", [("-p", "no:xdist"), ("-n", "2")], ids=["one", "xdist"])
def test_the_table_counts_every_test_and_the_children_it_waited_for(workers):
    rows = _run(*workers, "--cpu-top", "5")
    assert set(rows) == {WITH_CHILDREN, IN_PROCESS}, rows
    for path, (total, own, kids, count) in rows.items():
        assert count == _counted(path), (path, rows)
        assert total == pytest.approx(own + kids, abs=0.11)
    # each fk run is a Python process importing mearm: tenths of a second of CPU each
    assert rows[WITH_CHILDREN][2] > 0.2, rows
    assert rows[IN_PROCESS][2] == 0.0, rows
    assert list(rows)[0] == WITH_CHILDREN  # ranked by CPU, the most first


@pytest.mark.heavy
def test_without_the_option_there_is_no_table():
    assert _run("-p", "no:xdist") == {}
