"""Ctrl-C before a command's main runs under :func:`mearm.cli.run`: one line and exit 130.

Two holes were left after the guard of ``mearm SUBCOMMAND`` (``tests/test_ctrl_c_at_start.py``):

- ``python -m mearm.sort`` imports its modules (its first half second) before its
  ``main`` runs under the guard: a Ctrl-C there printed Python's traceback and the
  process ended by SIGINT. ``import mearm``, which such a run does first, now puts a hook
  in place for it (:func:`mearm.interrupts.guard_program_start`), and only for it;
- ``mearm analyze`` printed "not installed" and exited 2 for an ``ImportError`` that a
  Ctrl-C had made while a C extension initialised (:func:`mearm.interrupts.hidden_in`).
"""

from __future__ import annotations

import signal
import subprocess
import sys
from collections.abc import Sequence
from importlib.machinery import ModuleSpec
from pathlib import Path

import pytest
from conftest import interrupted
from test_ctrl_c_at_start import _ctrl_c_in_an_import, started_past_the_guard

from mearm import analyze, cli, interrupts


def test_ctrl_c_while_python_m_imports_its_modules_is_one_line_and_130(tmp_path: Path) -> None:
    """A real SIGINT once ``python -m mearm.sort`` has imported ``mearm.cli``, before its
    main runs: exit 130 and ``python -m mearm.sort: interrupted``, not Python's traceback
    and death by SIGINT (-2). ``-X importtime`` (on stderr) says when to send it; its lines
    are left out of what is checked."""
    proc, said = started_past_the_guard(["mearm.sort", "--config", "sim"], tmp_path)
    _, err_bytes = interrupted(proc)  # a hang (the Ctrl-C lost) is the failure
    err = (said + err_bytes).decode(errors="replace")
    lines = [line for line in err.splitlines() if not line.startswith("import time:")]
    assert "Traceback" not in err, err[-3000:]
    assert (proc.returncode, lines) == (130, ["python -m mearm.sort: interrupted"]), lines[-20:]


@pytest.mark.parametrize(
    ("orig_argv", "argv", "module"),
    [
        (
            ["python", "-m", "mearm.sort", "--config", "sim"],
            ["-m", "--config", "sim"],
            "mearm.sort",
        ),
        (["python", "-X", "importtime", "-Im", "mearm.fk"], ["-m"], "mearm.fk"),
        (["python", "-mmearm.sort", "-m"], ["-m", "-m"], "mearm.sort"),
        (["python", "-Bmmearm", "x"], ["-m", "x"], "mearm"),
        (["python", "-c", "import mearm", "-m"], ["-c", "-m"], None),
        (["python", "run.py", "-m"], ["run.py", "-m"], None),
        (["python", "-m", "mearm.sort"], ["/x/mearm/sort.py"], None),  # the module runs now
    ],
)
def test_the_module_python_m_runs_is_read_off_its_command_line(
    monkeypatch: pytest.MonkeyPatch, orig_argv: list[str], argv: list[str], module: str | None
) -> None:
    """Only while ``python -m`` imports the module's packages (``sys.argv[0]`` is ``-m``),
    its name after ``-m`` or joined to it."""
    monkeypatch.setattr(sys, "orig_argv", orig_argv)
    monkeypatch.setattr(sys, "argv", argv)
    assert interrupts.module_run_as_program() == module


def _hook_when_running(monkeypatch: pytest.MonkeyPatch, module: str) -> interrupts.ExceptHook:
    """The excepthook after ``import mearm`` ran :func:`guard_program_start` as it does
    while ``python -m MODULE`` imports the package: the one before when nothing was put."""
    monkeypatch.setattr(sys, "orig_argv", ["python", "-m", module])
    monkeypatch.setattr(sys, "argv", ["-m"])
    monkeypatch.setattr(sys, "excepthook", sys.__excepthook__)
    interrupts.guard_program_start()
    return sys.excepthook


def test_a_program_that_imports_mearm_keeps_pythons_own_handling(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``python -m tool.main`` whose package imports mearm: no hook of mearm's."""
    assert _hook_when_running(monkeypatch, "tool.main") is sys.__excepthook__
    assert _hook_when_running(monkeypatch, "mearmish.main") is sys.__excepthook__


@pytest.mark.parametrize("error", [KeyboardInterrupt(), _ctrl_c_in_an_import()])
def test_the_hook_ends_a_ctrl_c_as_the_guard_does(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], error: BaseException
) -> None:
    """A Ctrl-C no one caught, or one a library made an error of: the line, exit 130; any
    other error goes to the hook before (Python's traceback)."""
    monkeypatch.setattr(interrupts, "_received", [])
    hook = _hook_when_running(monkeypatch, "mearm.tools.render_calibration")
    with pytest.raises(SystemExit) as stop:
        hook(type(error), error, None)
    assert stop.value.code == 130
    assert capsys.readouterr().err == "python -m mearm.tools.render_calibration: interrupted\n"
    other = ValueError("a bug")
    hook(ValueError, other, None)
    assert capsys.readouterr().err == "ValueError: a bug\n"


class _CtrlCWhileScipyInitialises:
    """A finder that makes ``import scipy`` fail as a Ctrl-C inside a C extension does."""

    def find_spec(
        self, name: str, path: Sequence[str] | None, target: object = None
    ) -> ModuleSpec | None:
        if name == "scipy":
            raise _ctrl_c_in_an_import()
        return None  # every other module: the next finder


def test_analyze_takes_a_ctrl_c_in_import_scipy_for_the_interrupt(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Exit 130 and ``interrupted``, not "scipy is not installed" and exit 2."""
    monkeypatch.delitem(sys.modules, "scipy", raising=False)
    monkeypatch.setattr(sys, "meta_path", [_CtrlCWhileScipyInitialises(), *sys.meta_path])
    with pytest.raises(SystemExit) as stop:
        cli.run(analyze.main, [str(tmp_path / "trials.jsonl")])
    err = capsys.readouterr().err.splitlines()
    assert (stop.value.code, len(err)) == (130, 1), err
    assert err[0].endswith(": interrupted"), err


#: The installed ``mearm`` script as pip writes it, with a real Ctrl-C sent to itself as
#: the dispatcher imports ``mearm.cli`` (an audit hook: the same place every time), after
#: ``import mearm`` and before the guard of :func:`mearm.cli.run` is in place.
INSTALLED_SCRIPT = """\
import os, signal, sys, time

signal.signal(signal.SIGINT, signal.default_int_handler)  # as a shell starts it

def ctrl_c_while_the_dispatcher_imports(event, args):
    if event == "import" and args[0] == "mearm.cli":
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(5)  # the handler's KeyboardInterrupt ends the wait at once

sys.addaudithook(ctrl_c_while_the_dispatcher_imports)
from mearm.__main__ import main
if __name__ == '__main__':
    sys.argv[0] = sys.argv[0].removesuffix('.exe')
    sys.exit(main())
"""


@pytest.mark.parametrize("name", ["mearm", "not-mearm"])
def test_ctrl_c_while_the_installed_script_starts_is_one_line_and_130(
    tmp_path: Path, name: str
) -> None:
    """The installed ``mearm`` imports the dispatcher before any guard: a Ctrl-C there (its
    first 20-30 ms) printed Python's traceback and ended the process by SIGINT (-2). Now
    ``import mearm`` puts the hook in place for it, as for ``python -m``: ``mearm sort:
    interrupted``, 130. A script of another name that imports mearm keeps Python's own
    handling."""
    script = tmp_path / name
    script.write_text(INSTALLED_SCRIPT)
    proc = subprocess.run(
        [sys.executable, str(script), "sort", "--config", "sim"],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    if name == "mearm":
        assert (proc.returncode, proc.stderr) == (130, "mearm sort: interrupted\n"), proc.stderr
    else:
        assert proc.returncode == -signal.SIGINT and "KeyboardInterrupt" in proc.stderr
    assert proc.stdout == ""


def test_only_the_script_named_mearm_is_the_program(monkeypatch: pytest.MonkeyPatch) -> None:
    """The ``__main__`` module a file named ``mearm`` on the command line; not a ``-m``
    module, not another script, not an interactive session."""
    script = type(sys)("__main__")
    script.__file__, script.__spec__ = "/venv/bin/mearm", None
    monkeypatch.setitem(sys.modules, "__main__", script)
    monkeypatch.setattr(sys, "argv", ["/venv/bin/mearm", "sort"])
    assert interrupts.script_run_as_program() == "mearm"
    monkeypatch.setattr(sys, "argv", ["/venv/bin/other", "sort"])
    assert interrupts.script_run_as_program() is None
    monkeypatch.setattr(script, "__file__", "/venv/bin/mearm-tool")
    monkeypatch.setattr(sys, "argv", ["/venv/bin/mearm-tool"])
    assert interrupts.script_run_as_program() is None
    monkeypatch.setattr(script, "__file__", "/x/mearm")
    monkeypatch.setattr(script, "__spec__", ModuleSpec("mearm", None))
    monkeypatch.setattr(sys, "argv", ["/x/mearm"])
    assert interrupts.script_run_as_program() is None
    monkeypatch.delattr(script, "__file__")
    monkeypatch.setattr(script, "__spec__", None)
    assert interrupts.script_run_as_program() is None
