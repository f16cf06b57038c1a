"""A Ctrl-C that C code swallows still stops the command: counted, and raised before motion.

NumPy's random generators are Cython modules that ``import numpy.random`` initialises on
first use, in the middle of a sort's start; a Ctrl-C that lands there can be cleared by
their initialisation, and the sort ran its twelve picks and exited 0 (one run in 25 on
a loaded machine, ``tests/test_ctrl_c_at_start.py``). Here a library that swallows the
Ctrl-C stands at a module the sort imports while it runs (an audit hook on its import:
the same place, every time): the interpreter, the signal and the sort are real.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import pytest

from mearm import interrupts
from mearm.cli import run

#: A module the kinematic sort imports while it runs, after its guard is in place.
IMPORTED_IN_THE_RUN = "mearm.sim.kinematic.table_camera"

#: ``mearm sort --config sim`` (the console script's way: the dispatcher in this
#: process) with a library that swallows a real Ctrl-C as that module is imported, then
#: either goes on (``swallow``) or fails for it, as a Cython module's initialisation can
#: ("Failed to import 'zlib.decompress' - cannot initialise module strings").
PROGRAM = textwrap.dedent(
    """
    import os, signal, sys, time

    HOW, MODULE, COMMAND = sys.argv[1], sys.argv[2], sys.argv[3:]
    done = []

    def library(event, args):
        if event != "import" or args[0] != MODULE or done:
            return
        done.append(MODULE)
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)  # the handler's KeyboardInterrupt ends the wait at once
        except KeyboardInterrupt:
            if HOW == "fail":
                raise ImportError("Failed to import 'zlib.decompress'") from None
        print("the library swallowed a Ctrl-C", file=sys.stderr, flush=True)

    sys.addaudithook(library)
    sys.argv = ["mearm", *COMMAND]
    from mearm.__main__ import main
    main()
    """
)


def _run(
    how: str,
    tmp_path: Path,
    command: tuple[str, ...] = ("sort", "--config", "sim"),
    module: str = IMPORTED_IN_THE_RUN,
) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "MEARM_STATE_DIR": str(tmp_path / "state")}
    return subprocess.run(
        [sys.executable, "-c", PROGRAM, how, module, *command],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def test_a_ctrl_c_a_library_swallows_at_the_start_stops_the_sort_before_any_pick(tmp_path):
    """Counted when it came, raised where the sorter starts: exit 130, no pick made."""
    proc = _run("swallow", tmp_path)
    assert "the library swallowed a Ctrl-C" in proc.stderr, proc.stderr
    assert proc.returncode == 130, (proc.returncode, proc.stdout[-2000:], proc.stderr[-2000:])
    assert "interrupted (Ctrl-C)" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr
    picks = [line for line in proc.stdout.splitlines() if line.startswith(("pick", "place"))]
    assert picks == [], picks
    assert not (tmp_path / "state" / "crash.log").exists()


def test_a_ctrl_c_swallowed_before_a_command_prints_its_answer_stops_it(tmp_path):
    """``mearm detect`` has no sorter to stop at: swallowed as it opens its camera, the
    Ctrl-C is raised as it is about to print (exit 130, one line), not after the answer
    it printed in full (exit 0, as when ``import numpy.random`` swallowed one there:
    ``tests/test_ctrl_c_at_start.py``, 10 runs in 1,680 on a loaded machine)."""
    proc = _run("swallow", tmp_path, ("detect", "--config", "sim", "--camera"))
    assert "the library swallowed a Ctrl-C" in proc.stderr, proc.stderr
    assert (proc.returncode, proc.stdout) == (130, ""), (proc.returncode, proc.stdout[-2000:])
    assert proc.stderr.strip().splitlines()[-1] == "mearm detect: interrupted", proc.stderr
    assert not (tmp_path / "state" / "crash.log").exists()


@pytest.mark.parametrize(
    "command",
    [("fk", "--config", "sim", "--joints", "120,93,-132"),
     ("ik", "--config", "sim", "--target", "-10.99,49.70,12.76")],
    ids=["fk", "ik"],
)  # fmt: skip
def test_a_ctrl_c_numpy_random_swallows_as_it_loads_stops_the_command(tmp_path, command):
    """``numpy.random`` is loaded where a swallowed Ctrl-C is looked for, before the
    command's work: one it swallows as it initialises stops ``mearm fk`` and ``ik``, which
    loaded it in their work and then printed their answer and exited 0."""
    proc = _run("swallow", tmp_path, command, module="numpy.random._generator")
    assert "the library swallowed a Ctrl-C" in proc.stderr, proc.stderr
    assert (proc.returncode, proc.stdout) == (130, ""), (proc.returncode, proc.stdout[-2000:])
    assert proc.stderr.strip().splitlines()[-1] == f"mearm {command[0]}: interrupted"
    assert not (tmp_path / "state" / "crash.log").exists()


def test_an_error_c_code_makes_of_a_swallowed_ctrl_c_is_that_ctrl_c(tmp_path):
    """The library fails for the Ctrl-C it swallowed: interrupted, 130, no crash record."""
    proc = _run("fail", tmp_path)
    assert proc.returncode == 130, (proc.returncode, proc.stderr[-2000:])
    assert proc.stderr.strip().splitlines()[-1] == "mearm sort: interrupted", proc.stderr
    assert "unexpected error" not in proc.stderr
    assert not (tmp_path / "state" / "crash.log").exists()


def test_a_counted_ctrl_c_is_raised_once_where_it_was_swallowed():
    """In this process: a real SIGINT eaten by a library is raised by the check, once;
    one that reached mearm's code (answered) is not raised again; the handler goes back."""
    before = signal.getsignal(signal.SIGINT)  # a test runner's worker may ignore Ctrl-C
    signal.signal(signal.SIGINT, signal.default_int_handler)
    restore = interrupts.count_ctrl_c()
    try:
        interrupts.raise_swallowed_ctrl_c()  # nothing counted yet: nothing raised
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)  # the handler's KeyboardInterrupt ends the wait at once
            pytest.fail("the Ctrl-C did not raise KeyboardInterrupt")
        except KeyboardInterrupt:
            pass  # swallowed, as a library would
        with pytest.raises(KeyboardInterrupt):
            interrupts.raise_swallowed_ctrl_c()
        interrupts.raise_swallowed_ctrl_c()  # raised once: not again
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)
        interrupts.answered()  # this one reached its catcher
        interrupts.raise_swallowed_ctrl_c()
        restore()
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        restore()
        signal.signal(signal.SIGINT, before)


def _swallowing_command(answer: bool) -> Callable[[Sequence[str] | None], int]:
    """A command whose work ends with C code swallowing a real Ctrl-C, after its checks.

    ``answer``: mearm's own code caught it and acted on it (``interrupts.answered``), as
    ``mearm sort --hold`` does with the Ctrl-C that closes its view.
    """

    def main(argv: Sequence[str] | None = None) -> int:
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)  # the handler's KeyboardInterrupt ends the wait at once
            pytest.fail("the Ctrl-C did not raise KeyboardInterrupt")
        except KeyboardInterrupt:
            if answer:
                interrupts.answered()
        print("the answer")
        return 0

    return main


@pytest.mark.parametrize(("answered", "status"), [(False, 130), (True, 0)])
def test_a_ctrl_c_swallowed_after_the_commands_last_check_is_its_exit(capsys, answered, status):
    """Swallowed after the last place a command looks for one (its work done, its
    answer printed), the Ctrl-C still makes the exit: 130 and "interrupted", not 0 as
    if none had come; one mearm's code answered leaves the command's own exit."""
    before = signal.getsignal(signal.SIGINT)  # a test runner's worker may ignore Ctrl-C
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(SystemExit) as stop:
            run(_swallowing_command(answered), [])
    finally:
        signal.signal(signal.SIGINT, before)
    out, err = capsys.readouterr()
    assert (stop.value.code, out) == (status, "the answer\n"), (stop.value.code, out, err)
    assert err.strip().splitlines() == ([] if answered else [f"{_prog()}: interrupted"]), err
    assert not interrupts.ctrl_c_unanswered()


def _prog() -> str:
    """The program name the command-line guard prints (this test runner's)."""
    from mearm.cli import _program_name  # noqa: PLC0415

    return _program_name()
