"""The sort's start-up pauses the garbage collector for its imports only when run as a program."""

from __future__ import annotations

import subprocess
import sys


def _python(code: str) -> str:
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return done.stdout.split()[-1]


def test_importing_the_sort_leaves_the_collector_alone() -> None:
    """Imported as a library, mearm.sort neither switches the collector off nor freezes."""
    code = "import gc; import mearm.sort; print(f'{gc.isenabled()},{gc.get_freeze_count()}')"
    assert _python(code) == "True,0"


def test_run_as_a_program_the_sort_sets_its_imports_aside_and_collects_again() -> None:
    """Run as ``python -m mearm.sort``, its imports end frozen and the collector back on."""
    code = (
        "import gc, runpy, sys\n"
        "sys.argv = ['mearm.sort', '--help']\n"
        "try:\n"
        "    runpy.run_module('mearm.sort', run_name='__main__', alter_sys=True)\n"
        "except SystemExit:\n"
        "    pass\n"
        "print(f'{gc.isenabled()},{gc.get_freeze_count() > 10000}')"
    )
    assert _python(code) == "True,True"


def test_the_mearm_command_sets_a_subcommands_imports_aside_and_collects_again() -> None:
    """``mearm sort`` (the dispatcher imports mearm.sort as a module): the same pause."""
    code = (
        "import gc, sys\n"
        "from mearm.__main__ import _load\n"
        "main = _load('mearm.sort')\n"
        "print(f'{gc.isenabled()},{gc.get_freeze_count() > 10000}')"
    )
    assert _python(code) == "True,True"
