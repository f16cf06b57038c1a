"""The bad-input corpus's one check: what every command promises on input it refuses.

Each case runs one ``mearm`` subcommand in-process (fast: no interpreter start per case)
and asserts, together:

- the exit code (2 for bad input found before motion, unless the case says otherwise);
- exactly one line on stderr, and no traceback anywhere in the output;
- a time bound against hangs: each case states how long the command should take
  (``within_s``, as measured on an idle machine) and fails only past
  :data:`HANG_FACTOR` times that, so a loaded 2-core machine never fails a case that
  merely ran slow, while a hang or a blow-up (an alias bomb expanded, a parse gone
  quadratic) is still cut off by a timer and fails;
- every file that existed before the run is byte-for-byte intact afterwards.

Tests that use it carry ``@pytest.mark.bad_input``; ``pytest -m bad_input
--collect-only -q`` counts the corpus. :func:`check_bad_input_subprocess` runs the same
check through a real ``python -m mearm`` process, for the cases whose harm is to the
process itself (memory, recursion, hangs in C code).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.util
import io
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parent.parent


class CaseTimeout(BaseException):  # noqa: N818 - not an Exception: the guard must not catch it
    """A case ran past its time bound."""


@dataclass
class Outcome:
    """What one run did."""

    code: int
    stdout: str
    stderr: str
    seconds: float

    @property
    def line(self) -> str:
        """The one stderr line."""
        return self.stderr.strip()


def _snapshot(paths: Iterable[Path]) -> dict[Path, bytes | None]:
    out: dict[Path, bytes | None] = {}
    for p in paths:
        p = Path(p)
        # os.walk, not rglob + is_file: a third less CPU, twice in each of ~1,000 cases
        files = sorted(Path(d, n) for d, _, ns in os.walk(p) for n in ns) if p.is_dir() else [p]
        for f in files:
            out[f] = hashlib.sha256(f.read_bytes()).digest() if f.is_file() else None
    return out


#: A case fails past this many times its stated ``within_s`` (see the module docstring).
HANG_FACTOR = 10.0

#: Promises checked and kept in this session (five per passing check); the suite's
#: summary prints it (tests/conftest.py).
KEPT = {"checks": 0, "promises": 0}


def _assert_promises(
    out: Outcome, argv: Sequence[str], code: int, within_s: float, before: dict
) -> None:
    what = f"mearm {' '.join(map(str, argv))}"
    assert out.code == code, f"{what}: exit {out.code}, expected {code}; stderr: {out.stderr!r}"
    assert "Traceback" not in out.stderr + out.stdout, f"{what}: traceback:\n{out.stderr}"
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1, f"{what}: expected one line on stderr, got {len(lines)}: {lines!r}"
    bound = within_s * HANG_FACTOR
    assert out.seconds <= bound, f"{what}: took {out.seconds:.2f} s (hang bound {bound:g} s)"
    after = _snapshot(before)
    for path, digest in before.items():
        assert after.get(path) == digest, f"{what}: {path} changed or vanished"
    KEPT["checks"] += 1
    KEPT["promises"] += 5  # exit code, one line, no traceback, time bound, files intact


def run_in_process(
    argv: Sequence[object], *, within_s: float = 5.0, cwd: Path | None = None
) -> Outcome:
    """Run ``mearm ARGV`` in this process (in folder ``cwd``, then back; ``None``: where it
    is); a run past the hang bound (+1 s) is cut off."""
    from mearm.__main__ import main

    saved_argv = sys.argv[:]
    out, err = io.StringIO(), io.StringIO()

    def on_alarm(_sig: int, _frame: object) -> None:
        raise CaseTimeout(f"still running after {within_s * HANG_FACTOR + 1:g} s")

    old = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, within_s * HANG_FACTOR + 1.0)
    t0 = time.perf_counter()
    code: int | str | None = 0
    try:
        with (
            contextlib.chdir(cwd or os.getcwd()),
            contextlib.redirect_stdout(out),
            contextlib.redirect_stderr(err),
        ):
            try:
                main([str(a) for a in argv])
            except SystemExit as exc:
                code = exc.code
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
        sys.argv = saved_argv
    elapsed = time.perf_counter() - t0
    return Outcome(int(code or 0) if not isinstance(code, str) else 1, out.getvalue(),
                   err.getvalue(), elapsed)  # fmt: skip


def refused_line(argv: Sequence[object], *, cwd: Path | None = None) -> str:
    """The one line ``mearm ARGV`` says on stderr as it refuses its input (exit 2, nothing
    on stdout, no traceback), run in this process in ``cwd``."""
    r = run_in_process(argv, cwd=cwd)
    lines = r.stderr.strip().splitlines()
    assert r.code == 2 and r.stdout == "" and len(lines) == 1, r
    assert "Traceback" not in r.stderr
    return lines[0]


def run_guarded(
    fn: Callable[..., int | None], argv: Sequence[str], capsys: pytest.CaptureFixture[str]
) -> tuple[int, str, str]:
    """Run a command's ``main`` under the guard every command shares (:func:`mearm.cli.run`).

    Returns:
        Its exit status, and what it printed on stdout and on stderr (``capsys``).
    """
    from mearm.cli import run

    with pytest.raises(SystemExit) as info:
        run(fn, list(argv))
    out, err = capsys.readouterr()
    return int(info.value.code or 0), out, err


def check_bad_input(
    argv: Sequence[object],
    *,
    code: int = 2,
    within_s: float = 5.0,
    keep: Iterable[Path] = (),
    stdin: str | None = None,
) -> Outcome:
    """Run ``mearm ARGV`` in-process and assert the promises (see the module docstring).

    Args:
        argv: Subcommand and its arguments, e.g. ``["sort", "--config", path]``.
        code: The exit code the case must end with.
        within_s: Time bound [s].
        keep: Files or directories that must be unchanged afterwards.
        stdin: Text on standard input (default: an empty, closed input, as without a
            terminal).
    """
    argv = [str(a) for a in argv]
    before = _snapshot(keep)
    saved_stdin = sys.stdin
    sys.stdin = io.StringIO(stdin or "")
    try:
        out = run_in_process(argv, within_s=within_s)
    finally:
        sys.stdin = saved_stdin
    _assert_promises(out, argv, code, within_s, before)
    return out


@functools.cache
def _startup_s() -> float:
    """The interpreter's start-up with mearm's CLI (a ``--version`` run) [s], once per
    process: against the hang bound (ten times a case's stated time) its changes under
    load do not count, and measuring it before every case doubled their processes."""
    t0 = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "mearm", "--version"], capture_output=True, check=True, cwd=ROOT
    )
    return time.perf_counter() - t0


def check_bad_input_subprocess(
    argv: Sequence[object],
    *,
    code: int = 2,
    within_s: float = 5.0,
    keep: Iterable[Path] = (),
    stdin: str | None = None,
    cwd: Path = ROOT,
) -> Outcome:
    """As :func:`check_bad_input`, through ``python -m mearm`` in a child process.

    The bound covers the command's own work: the interpreter's start-up (measured by a
    ``--version`` run) is added to it.
    """
    argv = [str(a) for a in argv]
    before = _snapshot(keep)
    cmd = [sys.executable, "-m", "mearm"]
    startup = _startup_s()
    t0 = time.perf_counter()
    proc = subprocess.run(
        [*cmd, *argv], capture_output=True, text=True, input=stdin or "",
        timeout=within_s * HANG_FACTOR + startup + 30, cwd=cwd,
    )  # fmt: skip
    elapsed = max(0.0, time.perf_counter() - t0 - startup)
    out = Outcome(proc.returncode, proc.stdout, proc.stderr, elapsed)
    _assert_promises(out, argv, code, within_s, before)
    return out


def tool_module(name: str) -> ModuleType:
    """A developer script of tools/ (not a package), imported from its file."""
    spec = importlib.util.spec_from_file_location(name, ROOT / "tools" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def exit_of(main: Callable[..., int], argv: list[str]) -> int:
    """Run ``main`` under :func:`mearm.cli.run`, as its script does: the exit status."""
    from mearm.cli import run

    with pytest.raises(SystemExit) as stop:
        run(main, argv)
    return int(stop.value.code or 0)
