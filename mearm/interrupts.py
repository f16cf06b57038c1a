"""Ctrl-C that is never lost: one that a finalizer swallowed is delivered again.

Python's Ctrl-C handler raises :class:`KeyboardInterrupt` wherever the main thread is.
Where that is a weak reference's callback or a ``__del__`` (the garbage collector runs
them between any two lines), Python cannot pass the exception on: it hands it to
:func:`sys.unraisablehook`, which prints "Exception ignored in …", and carries on, so a
sort or an experiment runs on as though no one had pressed Ctrl-C (seen: a 10,000-trial
``mearm experiment`` that ran on). :func:`install` puts a hook in place that sends such a
Ctrl-C again, from another thread, so that it is raised where the finalizer returned to.
Every other unraisable exception goes to the hook that was there before.

SIGTERM and SIGHUP (what ``timeout``, ``systemctl stop``, ``docker stop`` and a closed
terminal send) end a process at once, with nothing parked and nothing logged. A command
that moves the arm takes them as Ctrl-C inside :func:`stop_signals_as_ctrl_c`: they raise
:class:`Terminated`, a :class:`KeyboardInterrupt`, so the arm parks and the log says why,
and the command exits 128 + the signal's number (143 for SIGTERM), as the shell reports
a process that signal ended.
"""

from __future__ import annotations

import _thread
import contextlib
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from types import FrameType
from typing import Any

#: How long after a lost Ctrl-C it is sent again [s].
RESEND_AFTER_S = 0.02

#: The signals a command that moves the arm takes as Ctrl-C.
STOP_SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)
)
#: The stop signals received in this process, in order.
_received: list[int] = []
#: The stop signals taken as Ctrl-C now (inside :func:`stop_signals_as_ctrl_c`).
_taken: set[int] = set()


class Terminated(KeyboardInterrupt):
    """A stop signal (:data:`STOP_SIGNALS`) taken as Ctrl-C.

    Attributes:
        signum: The signal's number.
    """

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def named(exc: KeyboardInterrupt) -> str:
    """What stopped the run, for a message: ``Ctrl-C``, or the signal's name (``SIGTERM``)."""
    return signal.Signals(exc.signum).name if isinstance(exc, Terminated) else "Ctrl-C"


def hidden_in(exc: BaseException) -> bool:
    """Whether ``exc`` is a Ctrl-C (or a stop signal taken as one) a library made an error of.

    Two libraries do so while a command starts: a C extension that initialises (``import
    mujoco``, pybind11) raises ``ImportError: initialization failed`` *from* the
    KeyboardInterrupt, and pydantic-core, which builds a model's validators in Rust,
    keeps only its name in the text of a ``SchemaError`` ("... KeyboardInterrupt: ").
    Code that takes such an ImportError for a missing package (``raise MearmError("...
    not installed") from None``) keeps it as its context. So every exception on the
    chain, causes and contexts alike, is looked at for a KeyboardInterrupt as its
    *cause* or in its text. An error that only happened while a Ctrl-C was being handled
    (a clean-up that failed: the KeyboardInterrupt is its context, not its cause) is
    not one: it is an error of its own.
    """
    seen: set[int] = set()
    chain: list[BaseException] = [exc]
    while chain:
        link = chain.pop()
        if id(link) in seen:
            continue
        seen.add(id(link))
        if isinstance(link.__cause__, KeyboardInterrupt):
            return True
        if not isinstance(link, KeyboardInterrupt) and "KeyboardInterrupt" in str(link):
            return True
        chain.extend(e for e in (link.__cause__, link.__context__) if e is not None)
    return False


def clear_python_exit_by_signal() -> None:
    """Let the process end with the status the command chose, after a Ctrl-C it handled.

    CPython marks a KeyboardInterrupt that escapes an ``exec``/``eval`` of a string, and a
    ``python -m`` run so marked ends by SIGINT (status -2 to a parent process, no matter
    what ``sys.exit`` said) even though the interrupt was handled afterwards.
    ``dataclasses`` and ``collections.namedtuple`` build their methods that way, so a
    Ctrl-C while a command's modules are imported often lands in one. The mark is
    cleared by the next string that is evaluated without one.
    """
    eval("None")  # a constant; only evaluating a string clears the mark


def taken_as_ctrl_c() -> tuple[int, ...]:
    """The stop signals taken as Ctrl-C now: a handler of Ctrl-C of its own takes them too."""
    return tuple(sorted(_taken))


def received(signum: int) -> str:
    """Note a stop signal a handler of its own took (for :func:`exit_status`); its name.

    SIGINT is not noted (it is Ctrl-C): ``"Ctrl-C"``.
    """
    if signum == signal.SIGINT:
        return "Ctrl-C"
    _received.append(signum)
    return signal.Signals(signum).name


def stopped_by() -> str:
    """What stopped the run, for a message: the last stop signal noted, else ``Ctrl-C``."""
    return signal.Signals(_received[-1]).name if _received else "Ctrl-C"


def exit_status() -> int:
    """130 after Ctrl-C; 128 + N once a stop signal N was taken as Ctrl-C (143: SIGTERM)."""
    return 128 + _received[-1] if _received else 130


@contextlib.contextmanager
def stop_signals_as_ctrl_c() -> Iterator[None]:
    """Inside the block SIGTERM and SIGHUP raise :class:`Terminated`, as Ctrl-C raises.

    Only a signal that would end the process is taken (an ignored one, under ``nohup``,
    stays ignored), and only in the main thread (only it may install handlers); on
    leaving, the handlers before are put back. A temporary file being written when one
    arrives is removed as the exception unwinds (:func:`mearm.fileio.write_atomic`).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    from mearm.fileio import signal_ends_process  # noqa: PLC0415

    def handler(signum: int, frame: FrameType | None) -> None:
        received(signum)
        raise Terminated(signum)

    previous = {}
    for sig in STOP_SIGNALS:
        if signal_ends_process(sig):
            previous[sig] = signal.signal(sig, handler)
            _taken.add(sig)
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)
            _taken.discard(sig)


def install() -> None:
    """Let no Ctrl-C be lost in a finalizer (once; the previous hook kept for the rest)."""
    if getattr(sys.unraisablehook, "_mearm_resends_ctrl_c", False):
        return
    previous = sys.unraisablehook

    def hook(unraisable: Any) -> None:
        if unraisable.exc_type is not None and issubclass(unraisable.exc_type, KeyboardInterrupt):
            resend_ctrl_c()
            return
        previous(unraisable)

    hook._mearm_resends_ctrl_c = True  # type: ignore[attr-defined]
    sys.unraisablehook = hook


def resend_ctrl_c() -> None:
    """Send this process SIGINT again, :data:`RESEND_AFTER_S` from now, from another thread.

    Not from the main thread: a signal it sends itself is handled at once, inside the
    hook, and lost again. Nor with :class:`threading.Thread`, whose ``start`` waits for
    the thread, and the signal could arrive while the main thread waits there. The main
    thread is back where the finalizer ran from by then (a finalizer that is still
    running swallows it again, and it is sent again).
    """
    _thread.start_new_thread(_kill_later, (os.getpid(),))


def _kill_later(pid: int) -> None:
    time.sleep(RESEND_AFTER_S)
    os.kill(pid, signal.SIGINT)
