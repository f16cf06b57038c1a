"""``--debug`` shows the library's log; without it a command prints only its own lines.

The docs said each retried frame is logged, and a file without ``replaces`` is taken
"with a warning": no command showed the log, so neither reached the maker.
"""

from __future__ import annotations

import subprocess
import sys

from conftest import ROOT

#: A command's guard around a main that logs a warning, with the arguments given.
SCRIPT = """
import logging, sys
from mearm.cli import run

def main(argv):
    logging.getLogger("mearm.hardware.arduino").warning("try %d/%d of %r", 1, 4, "V")
    logging.getLogger("mearm.hardware.arduino").info("not a warning")
    print("done")
    return 0

run(main, sys.argv[1:])
"""


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", SCRIPT, *args],
        capture_output=True, text=True, cwd=ROOT, timeout=120, check=False,
    )  # fmt: skip


def test_debug_prints_the_log_as_it_comes():
    out = _run("--debug")
    assert out.returncode == 0 and out.stdout == "done\n"
    assert out.stderr.splitlines() == ["-c: log: WARNING mearm.hardware.arduino: try 1/4 of 'V'"], (
        out.stderr
    )


def test_without_debug_only_the_commands_own_lines():
    out = _run()
    assert out.returncode == 0 and out.stdout == "done\n" and out.stderr == ""
