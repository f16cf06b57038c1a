"""Ctrl-C that arrives while a finalizer runs is not lost (``mearm.interrupts``).

Python's own handler raises KeyboardInterrupt inside a weak reference's callback or a
``__del__``, where it is printed as "Exception ignored" and dropped: a 10,000-trial
experiment once ran on after its Ctrl-C. Each child below runs a command under
:func:`mearm.cli.run` whose Ctrl-C is handled inside such a finalizer; it must end 130.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest
from conftest import ROOT

#: A command that presses Ctrl-C on itself from inside a finalizer, then works on for a
#: while (the signal is handled at the finalizer's next loop) and ends 0 if never stopped.
CHILD = textwrap.dedent(
    """
    import os, signal, sys, time, weakref
    from mearm.cli import run

    class Thing:
        pass

    class Dying:
        def __del__(self):
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(100_000):
                pass

    def in_weakref_callback():
        things = weakref.WeakKeyDictionary()
        key = Thing()
        things[key] = 1
        def callback(_ref):
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(100_000):
                pass

        ref = weakref.ref(key, callback)
        del key

    def in_del():
        Dying()

    def main(argv):
        {where}()
        end = time.monotonic() + 20
        while time.monotonic() < end:
            time.sleep(0.01)
        return 0

    run(main)
    """
)


@pytest.mark.parametrize("where", ["in_weakref_callback", "in_del"])
def test_ctrl_c_inside_a_finalizer_still_stops_the_command(where: str) -> None:
    """Exit 130 ("interrupted"), not 0 after the command ran its course."""
    out = subprocess.run(
        [sys.executable, "-c", CHILD.replace("{where}", where)],
        cwd=ROOT, capture_output=True, text=True, timeout=120,  # a hang is the failure
    )  # fmt: skip
    assert out.returncode == 130, (out.returncode, out.stderr[-2000:])
    assert "interrupted" in out.stderr
