"""Ctrl-C while a command starts: exit 130 and one line, never a traceback.

A command spends most of its first half second importing its modules (pydantic's
schemas, OpenCV, NumPy). Three things went wrong there:

- the ``mearm`` dispatcher imported them before the guard every command runs under
  (:func:`mearm.cli.run`) was in place, so a Ctrl-C printed an 80-line traceback;
- a Ctrl-C while a C extension initialises (``import mujoco``) comes out as
  ``ImportError: initialization failed`` (pydantic-core, which builds a model's
  validators in Rust, makes a ``SchemaError`` of it), which the guard took for a crash:
  exit 1, "unexpected error", and a record in the crash log;
- CPython ends a ``python -m`` run by SIGINT (status -2, whatever the command chose)
  once a Ctrl-C has escaped an ``exec`` of a string, as while a dataclass is built.
"""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from pydantic_core import SchemaError

from mearm import cli, interrupts
from mearm.errors import MearmError

#: The line ``python -X importtime`` prints once the guard's module is imported; the
#: dispatcher runs its subcommand under the guard a fraction of a millisecond later, or
#: a tenth of a second and more on a loaded machine: until then the hook that ``import
#: mearm`` put in place says the same line (test_a_ctrl_c_before_the_dispatcher_...).
GUARD_LOADED = "| mearm.cli"


def _crash_records(state: Path) -> str:
    log = state / "crash.log"
    return log.read_text() if log.exists() else ""


@pytest.mark.parametrize(
    ("argv", "after_s"),
    [
        *(
            pytest.param(["detect", "--config", "sim", "--camera"], s, id=f"detect-{s}s")
            for s in (0.05, 0.1, 0.15, 0.2, 0.25)
        ),
        *(pytest.param(["sort", "--config", "sim"], s, id=f"sort-{s}s") for s in (0.1, 0.2)),
    ],
)
def test_ctrl_c_while_a_subcommand_starts_is_one_line_and_130(
    tmp_path: Path, argv: list[str], after_s: float
) -> None:
    """A real SIGINT ``after_s`` after the dispatcher has its guard, mostly while the
    subcommand's modules are imported: exit 130, ``mearm NAME: interrupted``, nothing in
    the crash log. The interpreter's own import trace (``-X importtime``, on stderr)
    says when the guard's module is in; its lines are left out of what is checked."""
    state = tmp_path / "state"
    env = {**os.environ, "MEARM_STATE_DIR": str(state)}
    for wait_s in (after_s, 0.0, 0.0):  # the first try late (a loaded machine): at once
        proc, said = started_past_the_guard(["mearm", *argv], tmp_path, env)
        if (err_bytes := ctrl_c_before_its_first_output(proc, wait_s)) is not None:
            break
    else:
        pytest.fail(f"mearm {argv[0]} printed its output before each of 3 Ctrl-Cs")
    err = (said + err_bytes).decode(errors="replace")
    # a note the command said before the Ctrl-C (the sort's reach note, on a slow start)
    # is what it did, not a second line of the interruption
    note = f"mearm {argv[0]}: note: "
    lines = [
        line
        for line in err.splitlines()
        if not line.startswith("import time:") and not line.startswith(note)
    ]
    assert "Traceback" not in err, err[-3000:]
    assert proc.returncode == 130, (proc.returncode, lines[-20:])
    assert len(lines) == 1, lines[-20:]
    assert lines[0].startswith(f"mearm {argv[0]}: "), lines
    assert "interrupted" in lines[0], lines
    assert _crash_records(state) == ""


@pytest.mark.parametrize(
    ("args", "dispatched", "line"),
    [
        (["detect", "--config", "sim", "--camera"], None, "mearm detect: interrupted"),
        (["detect", "--config", "sim"], ["mearm detect", "--config", "sim"],
         "mearm detect: interrupted"),
        (["help", "sort"], None, "mearm help: interrupted"),
        (["help", "sort"], ["mearm sort", "--help"], "mearm sort: interrupted"),
        (["--help"], None, "mearm: interrupted"),
    ],
)  # fmt: skip
def test_a_ctrl_c_before_the_dispatcher_runs_its_subcommand_names_it(
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    args: list[str],
    dispatched: list[str] | None,
    line: str,
) -> None:
    """``python -m mearm detect`` imports ``mearm.cli`` (``GUARD_LOADED``), then
    ``mearm.data``, then runs ``detect`` under the guard; a Ctrl-C in between goes to the
    hook that ``import mearm`` put in place, which said ``mearm: interrupted`` (the test
    above failed so at 0.1 s on a loaded machine). Now ``mearm detect`` as typed, and as
    the dispatcher names it (``dispatched``: its ``sys.argv``) once it has; exit 130."""
    monkeypatch.setattr(interrupts, "_received", [])
    monkeypatch.setattr(sys, "orig_argv", ["python", "-X", "importtime", "-m", "mearm", *args])
    monkeypatch.setattr(sys, "argv", ["-m", *args])  # while python -m imports the package
    monkeypatch.setattr(sys, "excepthook", sys.__excepthook__)
    interrupts.guard_program_start()
    hook = sys.excepthook
    monkeypatch.setattr(sys, "argv", dispatched or ["/x/mearm/__main__.py", *args])
    with pytest.raises(SystemExit) as stop:
        hook(KeyboardInterrupt, KeyboardInterrupt(), None)
    assert (stop.value.code, capsys.readouterr().err) == (130, f"{line}\n")


def started_past_the_guard(
    module_argv: list[str], cwd: Path, env: dict[str, str] | None = None
) -> tuple[subprocess.Popen[bytes], bytes]:
    """``python -u -X importtime -m MODULE ARGS`` (``module_argv``), once it has imported
    ``mearm.cli`` (its guard): the interpreter's import trace, on stderr, says when. With
    what it has said so far past that line (for the caller to check with the rest).

    Unbuffered (``-u``): what the command prints reaches the pipe as it prints it, so
    :func:`ctrl_c_before_its_first_output` sees that it has. Buffered (a pipe's default),
    ``mearm detect`` held its whole answer until the interpreter's exit: a Ctrl-C that a
    loaded machine sent after the command had done its job, while it shut down, found
    nothing on standard output, and the command rightly kept its exit 0 (a suite run).

    The trace is read in whole chunks as they come: read a byte at a time (a line reader
    on an unbuffered pipe), a loaded machine let the reader fall so far behind that the
    command had all but finished when its guard's line was read, and it ended, exit 0,
    before the Ctrl-C that was meant for its start."""
    proc = subprocess.Popen(
        [sys.executable, "-u", "-X", "importtime", "-m", *module_argv],
        cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        bufsize=0, start_new_session=True,  # unbuffered: nothing read ahead out of reach
    )  # fmt: skip
    assert proc.stderr is not None
    marker = f"{GUARD_LOADED}\n".encode()
    seen = b""
    while chunk := os.read(proc.stderr.fileno(), 1 << 16):
        seen += chunk
        if (at := seen.find(marker)) >= 0:
            return proc, seen[at + len(marker) :]
    pytest.fail(f"{' '.join(module_argv)} ended before importing mearm.cli: exit {proc.wait()}")


def ctrl_c_before_its_first_output(proc: subprocess.Popen[bytes], after_s: float) -> bytes | None:
    """Ctrl-C to ``proc``'s group ``after_s`` s from now, unless the command has printed on
    standard output by then: what it said on stderr after the Ctrl-C, or None (too late).

    A Ctrl-C is meant for the command's start, but on a loaded machine this test can be
    held up for longer than the command takes (0.4 s for ``detect``): it was sent once
    ``mearm detect`` had done its job, which ended, exit 0. So the group is stopped first
    (SIGSTOP), and while nothing has come on standard output, the Ctrl-C waits for it to go
    on (SIGCONT) and lands before its first output, whenever this test runs again.
    ``proc`` is from :func:`started_past_the_guard`; a hang (the Ctrl-C lost) is the
    failure, bounded by a generous timeout."""
    assert proc.stdout is not None
    try:
        proc.wait(timeout=after_s)
    except subprocess.TimeoutExpired:
        pass
    else:
        proc.communicate()
        return None  # it ended, and its group with it
    os.killpg(proc.pid, signal.SIGSTOP)
    deadline = time.monotonic() + 60
    while _run_state(proc.pid) not in "TZX" and time.monotonic() < deadline:
        time.sleep(0.001)
    printed, _, _ = select.select([proc.stdout], [], [], 0)
    late = proc.poll() is not None or bool(printed)
    if not late:
        os.killpg(proc.pid, signal.SIGINT)  # pending until the group goes on
    os.killpg(proc.pid, signal.SIGCONT)
    try:
        _, err = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        raise
    return None if late else err


def _run_state(pid: int) -> str:
    """The state letter of process ``pid`` (``T``: stopped, ``Z``: ended), ``X`` if gone."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return "X"
    return stat.rpartition(")")[2].split()[0]


def _ctrl_c_in_an_import() -> ImportError:
    """What pybind11 makes of a Ctrl-C while its module initialises (``import mujoco``)."""
    try:
        raise KeyboardInterrupt
    except KeyboardInterrupt as ctrl_c:
        try:
            raise ImportError("initialization failed") from ctrl_c
        except ImportError as exc:
            return exc


def _run(main, capsys: pytest.CaptureFixture[str]) -> tuple[int | str | None, list[str]]:
    with pytest.raises(SystemExit) as stop:
        cli.run(main, [])
    return stop.value.code, capsys.readouterr().err.splitlines()


def _hidden_ctrl_c(argv: object) -> int:
    raise _ctrl_c_in_an_import()


def _hidden_ctrl_c_taken_for_a_missing_package(argv: object) -> int:
    try:
        raise _ctrl_c_in_an_import()
    except ImportError:
        raise MearmError("this needs SciPy, which is not installed") from None


def _ctrl_c_in_a_pydantic_schema(argv: object) -> int:
    """The error seen when a Ctrl-C landed while ``mearm.config`` built its models."""
    raise SchemaError(
        'Error building "function-after" validator:\n  SchemaError: Field "order":\n'
        '  SchemaError: Error building "literal" validator:\n  KeyboardInterrupt: '
    )


@pytest.mark.parametrize(
    "main",
    [_hidden_ctrl_c, _hidden_ctrl_c_taken_for_a_missing_package, _ctrl_c_in_a_pydantic_schema],
)
def test_a_ctrl_c_a_library_turned_into_an_error_is_the_interrupt(
    main, capsys: pytest.CaptureFixture[str]
) -> None:
    """``ImportError: initialization failed`` from a KeyboardInterrupt, as it is or taken
    for a missing package, and pydantic-core's ``SchemaError`` that names it: exit 130 and
    ``interrupted``, not a crash (exit 1, a record in the crash log) nor "not installed"
    (exit 2)."""
    state = Path(os.environ["MEARM_STATE_DIR"])
    before = _crash_records(state)
    code, err = _run(main, capsys)
    assert (code, len(err)) == (130, 1), err
    assert err[0].endswith(": interrupted"), err
    assert _crash_records(state) == before


def test_a_sigterm_an_import_turned_into_an_error_exits_143(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A SIGTERM taken as Ctrl-C (:class:`mearm.interrupts.Terminated`) keeps its status."""
    monkeypatch.setattr(interrupts, "_received", [])

    def main(argv: object) -> int:
        interrupts.received(signal.SIGTERM)  # as the handler of stop_signals_as_ctrl_c does
        try:
            raise interrupts.Terminated(signal.SIGTERM)
        except KeyboardInterrupt as stop:
            raise ImportError("initialization failed") from stop

    code, err = _run(main, capsys)
    assert (code, len(err)) == (143, 1), err
    assert err[0].endswith(": interrupted"), err


def test_an_error_while_handling_a_ctrl_c_is_still_reported(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """A clean-up that fails after a Ctrl-C (the KeyboardInterrupt is the error's context,
    not its cause) is an error of its own: exit 1 and a crash record, not hidden behind
    "interrupted"."""
    state = Path(os.environ["MEARM_STATE_DIR"])
    before = _crash_records(state)

    def main(argv: object) -> int:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise OSError("the run log could not be closed")  # noqa: B904

    code, err = _run(main, capsys)
    assert code == 1, err
    assert "unexpected error: OSError" in err[0], err
    assert len(_crash_records(state)) > len(before)


#: A command, run as ``python -m``, that handles a Ctrl-C which escaped the ``exec`` of a
#: string: what a Ctrl-C while a dataclass is built (``dataclasses`` makes its methods so)
#: comes to.
CTRL_C_IN_EXEC = """
from mearm.cli import run


def main(argv):
    exec("raise KeyboardInterrupt")


run(main)
"""


def test_a_ctrl_c_that_escaped_an_exec_still_exits_130(tmp_path: Path) -> None:
    """Exit 130 as the guard says, not death by SIGINT (-2) after "interrupted"."""
    (tmp_path / "ctrl_c_in_exec.py").write_text(CTRL_C_IN_EXEC)
    out = subprocess.run(
        [sys.executable, "-m", "ctrl_c_in_exec"],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert (out.returncode, out.stderr.splitlines()) == (
        130,
        ["python -m ctrl_c_in_exec: interrupted"],
    ), out.stderr[-2000:]
