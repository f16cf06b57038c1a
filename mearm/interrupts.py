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
terminal send) end a process at once, with nothing parked and nothing logged. Every
command takes them as Ctrl-C (:func:`mearm.cli.run` runs it inside
:func:`stop_signals_as_ctrl_c`): they raise :class:`Terminated`, a
:class:`KeyboardInterrupt`, so the arm parks, the log says why and temporary files go,
and the command exits 128 + the signal's number (143 for SIGTERM), as the shell reports
a process that signal ended.

Run as a program (``python -m mearm.sort``), a module imports what it needs before its
``main`` runs under the guard every command shares (:func:`mearm.cli.run`): a Ctrl-C
there is one line and exit 130 too (:func:`guard_program_start`, which ``import mearm``
calls then, and only then). A Ctrl-C while the interpreter shuts down after the command
chose its exit status does not change that status (:func:`clear_python_exit_by_signal`).
A block that must not be cut in two (renames that swap one set of files for another,
freeing a GL context) takes Ctrl-C and the stop signals after it
(:func:`signals_deferred`).

C code can swallow a Ctrl-C outright: NumPy's random generators, Cython modules that
``import numpy.random`` loads on first use, clear the KeyboardInterrupt raised while they
initialise, and the sort ran all twelve picks and exited 0 after a Ctrl-C at its start
(one run in 25 on a loaded machine). So every command counts its Ctrl-Cs
(:func:`count_ctrl_c`), and where a command is about to start work or motion it raises a
Ctrl-C that was counted but never reached mearm's code (:func:`raise_swallowed_ctrl_c`),
which loads ``numpy.random`` first, so that a command that would load it in its work
(``mearm fk``, ``ik``, ``detect``) has it loaded where a Ctrl-C it swallows is raised.
"""

from __future__ import annotations

import _thread
import atexit
import contextlib
import importlib
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from types import FrameType, TracebackType

#: What :data:`sys.excepthook` is called with: the type, the exception, its traceback.
ExceptHook = Callable[[type[BaseException], BaseException, TracebackType | None], object]

#: How long after a lost Ctrl-C it is sent again [s].
RESEND_AFTER_S = 0.02

#: The signals a command that moves the arm takes as Ctrl-C.
STOP_SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)
)
#: The signals :func:`signals_deferred` takes after its block: Ctrl-C and the stop signals.
DEFERRED_SIGNALS: tuple[signal.Signals, ...] = (signal.SIGINT, *STOP_SIGNALS)
#: The stop signals received in this process, in order.
_received: list[int] = []
#: The stop signals taken as Ctrl-C now (inside :func:`stop_signals_as_ctrl_c`).
_taken: set[int] = set()
#: Ctrl-Cs counted (:func:`count_ctrl_c`), and how many of them mearm's code has seen.
_ctrl_cs = {"counted": 0, "answered": 0}


class Terminated(KeyboardInterrupt):
    """A stop signal (:data:`STOP_SIGNALS`) taken as Ctrl-C.

    Attributes:
        signum: The signal's number.
    """

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def count_ctrl_c() -> Callable[[], None]:
    """Count every Ctrl-C from now; what puts Python's own handler back.

    The count is kept by a handler that does what Python's own does (raise
    KeyboardInterrupt) and counts first, so a Ctrl-C a library swallows is still known
    (:func:`raise_swallowed_ctrl_c`). Only in the main thread (only it may set handlers)
    and only where Python's own handler is in place: a program's own handler, or an
    ignored Ctrl-C, stays as it is (then nothing is counted, and nothing restored).
    """
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGINT) is not signal.default_int_handler
    ):
        return lambda: None
    signal.signal(signal.SIGINT, _counted_ctrl_c)

    def restore() -> None:
        if signal.getsignal(signal.SIGINT) is _counted_ctrl_c:
            signal.signal(signal.SIGINT, signal.default_int_handler)

    return restore


def _counted_ctrl_c(signum: int, frame: FrameType | None) -> None:
    _ctrl_cs["counted"] += 1
    raise KeyboardInterrupt


def answered() -> None:
    """Every Ctrl-C counted so far has reached mearm's code as a KeyboardInterrupt.

    Called where one is caught and acted on (the sorter's stop, the guard's exit), so
    that :func:`raise_swallowed_ctrl_c` does not raise it a second time.
    """
    _ctrl_cs["answered"] = _ctrl_cs["counted"]


def ctrl_c_unanswered() -> bool:
    """Whether a Ctrl-C was counted that mearm's code has not seen (C code swallowed it).

    An error that ends a command after such a Ctrl-C is taken for it, as one after a
    stop signal is (:func:`stop_signals_noted`): C code that swallows a Ctrl-C may fail
    for it too (a Cython module: "Failed to import 'zlib.decompress' - cannot initialise
    module strings").
    """
    return _ctrl_cs["counted"] > _ctrl_cs["answered"]


#: Modules known to swallow a Ctrl-C as they initialise, each loaded on first use once its
#: package is in (:func:`raise_swallowed_ctrl_c` loads them first).
SWALLOWING_MODULES = ("numpy.random",)


def raise_swallowed_ctrl_c() -> None:
    """Raise KeyboardInterrupt for a Ctrl-C that was counted and never reached mearm's code.

    Called where a command is about to start its work or move the arm: a Ctrl-C that
    C code swallowed on the way (:mod:`mearm.interrupts`) stops the command there, as it would
    have where it came. The modules known to swallow one (:data:`SWALLOWING_MODULES`)
    are imported first, if their package is: one they swallow then is raised here, not
    lost in the command's work, where ``mearm fk``, ``ik`` and ``detect`` first load
    ``numpy.random`` and had no later point to raise it before they printed their answer.

    Raises:
        KeyboardInterrupt: a Ctrl-C came since the last one mearm's code saw.
    """
    for name in SWALLOWING_MODULES:
        if name not in sys.modules and name.partition(".")[0] in sys.modules:
            importlib.import_module(name)
    if ctrl_c_unanswered():
        answered()
        raise KeyboardInterrupt


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
    """Let the process end with the status the command chose: after a Ctrl-C it handled, too.

    CPython marks a KeyboardInterrupt that escapes an ``exec``/``eval`` of a string, and a
    ``python -m`` run so marked ends by SIGINT (status -2 to a parent process, no matter
    what ``sys.exit`` said) even though the interrupt was handled afterwards.
    ``dataclasses`` and ``collections.namedtuple`` build their methods that way, so a
    Ctrl-C while a command's modules are imported often lands in one. The mark is
    cleared by the next string that is evaluated without one.

    A Ctrl-C while the interpreter then shuts down (MuJoCo's renderers and their EGL
    contexts are freed there: a tenth of a second or more after a render) would end the
    process by SIGINT too: Python puts the signal's default action back before it frees
    what is left. So it is ignored from the start of the shutdown
    (:func:`_keep_exit_status`).
    """
    eval("None")  # a constant; only evaluating a string clears the mark
    _keep_exit_status()


def _keep_exit_status() -> None:
    """Ignore Ctrl-C from when the interpreter starts to shut down, this process's work done.

    At the first of the exit functions (:mod:`atexit` calls the one registered last
    first; registered again, it is last again), not at once: a caller that goes on after
    :class:`SystemExit` (a test running a command in its own process) keeps its Ctrl-C.
    Only an ignored signal outlasts the shutdown: Python sets the default action back
    for one it handles, and a Ctrl-C then ends the process by SIGINT. A Ctrl-C while
    Python still waits for the threads to end, before the exit functions, stops that
    wait as it always did, and the status stays: the hook of :func:`install` sends it
    again :data:`RESEND_AFTER_S` later, when the exit functions have begun to ignore it.
    """
    atexit.unregister(_ignore_ctrl_c)
    atexit.register(_ignore_ctrl_c)


def _ignore_ctrl_c() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def module_run_as_program() -> str | None:
    """The module ``python -m`` is about to run, while it imports that module's packages.

    Python sets ``sys.argv[0]`` to ``"-m"`` while it locates the module (as its
    documentation of ``-m`` says) and keeps the command line as it was given in
    ``sys.orig_argv``, where the module's name comes right before the program's own
    arguments, after ``-m`` or joined to it (``-mmearm.sort``, ``-Im mearm.sort``).
    ``None`` at any other time, and in a process that is not a ``python -m`` run.
    """
    if sys.argv[:1] != ["-m"] or len(sys.orig_argv) <= len(sys.argv):
        return None
    given = sys.orig_argv[len(sys.orig_argv) - len(sys.argv)]
    return given.partition("m")[2] if given.startswith("-") else given


def script_run_as_program() -> str | None:
    """``"mearm"`` while the installed ``mearm`` command (pip's script) imports mearm.

    The script is the ``__main__`` module (a file, not a ``python -m`` module, so no
    ``__spec__``) named ``mearm`` on the command line; ``None`` in any other process.
    """
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or getattr(main, "__spec__", None) is not None or not sys.argv:
        return None
    if path is None or path != sys.argv[0] or os.path.basename(path) != "mearm":
        return None
    return "mearm"


def guard_program_start() -> None:
    """Make a Ctrl-C before ``python -m mearm.X``'s main runs one line and exit 130.

    ``python -m mearm.sort`` imports the package ``mearm`` first, then runs
    ``mearm/sort.py``, whose imports (pydantic's schemas, OpenCV, MuJoCo: its first half
    second) come before its ``main`` runs under :func:`mearm.cli.run`. A Ctrl-C there
    printed Python's traceback and ended the process by SIGINT. Called by ``import
    mearm`` while such a run imports it, this puts a hook in :data:`sys.excepthook` that
    takes a KeyboardInterrupt that no one caught, or one a library made an error of
    (:func:`hidden_in`), as :func:`mearm.cli.run` does: ``python -m mearm.sort:
    interrupted`` and exit 130. Every other error goes to the hook before. It does
    nothing when the module run is not mearm's, so a program that imports mearm keeps
    Python's own handling.

    ``python -m mearm detect`` (the dispatcher) is named ``mearm detect``, as the guard
    names it: the dispatcher imports its own modules (``mearm.cli``, ``mearm.data``)
    before that guard is in place, and a Ctrl-C there said ``mearm: interrupted`` (seen
    on a loaded machine, where a process can wait a tenth of a second between two
    lines). Its first argument is taken as the subcommand as typed (``mearm help``
    for ``mearm help detect``) until the dispatcher names it itself (:func:`_prog_now`).
    The installed ``mearm`` script (:func:`script_run_as_program`) imports the dispatcher
    before its guard as well: a Ctrl-C in its first 20-30 ms printed Python's traceback.
    """
    name = module_run_as_program() or script_run_as_program()
    if name is None or name.partition(".")[0] != "mearm":
        return
    name = name.removesuffix(".__main__")
    if name == "mearm":
        args = sys.argv[1:]  # the command line's own arguments, after "-m mearm"
        prog = f"mearm {args[0]}" if args and not args[0].startswith("-") else "mearm"
    else:
        prog = f"python -m {name}"
    sys.excepthook = _interrupted_hook(prog, sys.excepthook)
    count_ctrl_c()  # from the program's first import: its guard raises one swallowed there


def _prog_now(prog: str) -> str:
    """The command's name for its line: the dispatcher's name for its subcommand, once set.

    ``mearm``'s dispatcher names the subcommand it runs in ``sys.argv[0]`` (``mearm
    detect``, also for ``mearm help detect``), as :func:`mearm.cli.invoked_as` reads it;
    before that, ``prog``.
    """
    given = sys.argv[0] if sys.argv else ""
    return given if given.startswith("mearm ") else prog


def _interrupted_hook(prog: str, previous: ExceptHook) -> ExceptHook:
    """A :data:`sys.excepthook` that ends a Ctrl-C as :func:`mearm.cli.run` does.

    The :class:`SystemExit` it raises is the process's exit: CPython exits with the code
    of one its excepthook raises (``PyErr_PrintEx``), after the usual shutdown, not by
    SIGINT as after a KeyboardInterrupt it printed itself.
    """

    def hook(exc_type: type[BaseException], exc: BaseException, tb: TracebackType | None) -> None:
        if not (isinstance(exc, KeyboardInterrupt) or hidden_in(exc)):
            previous(exc_type, exc, tb)
            return
        if sys.stderr is not None:
            with contextlib.suppress(OSError, ValueError):  # no stderr to say it on
                print(f"{_prog_now(prog)}: interrupted", file=sys.stderr, flush=True)
        _keep_exit_status()
        raise SystemExit(exit_status())

    return hook


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


def stop_signals_noted() -> int:
    """How many stop signals this process has taken as Ctrl-C so far (:func:`received`).

    A command compares it before and after: a library may swallow the
    :class:`Terminated` its handler raised (pybind11, converting a call's arguments,
    takes it for a conversion that failed and says "incompatible function arguments"),
    and an error that ends a command after a stop signal came is that stop.
    """
    return len(_received)


def exit_status() -> int:
    """130 after Ctrl-C; 128 + N once a stop signal N was taken as Ctrl-C (143: SIGTERM)."""
    return 128 + _received[-1] if _received else 130


def signal_ends_process(sig: int) -> bool:
    """Whether ``sig`` would end the process now.

    It would with its default action, also behind a handler that only cleans up and then
    hands the signal on (one with a ``passes_on`` attribute, the handler it hands each
    signal on to: :mod:`mearm.fileio`'s); a Python handler or an ignored signal would not.
    """
    handler = signal.getsignal(sig)
    passes_on = getattr(handler, "passes_on", None)
    if passes_on is not None:
        handler = passes_on(sig)
    return bool(handler == signal.SIG_DFL)


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


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """Take Ctrl-C, SIGTERM and SIGHUP after the block, not inside it.

    For a block that a signal must not cut in two: renames that put one run's files in
    place of another's (``mearm render-calibration``), freeing a renderer's GL context
    (a Ctrl-C inside MuJoCo's ``Renderer.close`` left a context it had destroyed still
    named, and freed again at exit: an "Exception ignored ... EGL_BAD_CONTEXT" block
    after "interrupted"). Keep the block short: a Ctrl-C waits for it.

    Not by blocking the signals (``pthread_sigmask``): that holds them back from the
    main thread only, and once other threads run (a dataset's writer thread, a
    library's own that does not block signals), one of those receives the signal and
    Python raises ``KeyboardInterrupt`` in the main thread, inside the block, all the
    same. Instead a
    handler that only notes the signal stands in for each (Python runs handlers in the
    main thread, whichever thread received the signal); when the handlers before are
    back, a signal that came is raised again and takes its usual course (Ctrl-C:
    ``KeyboardInterrupt``; an ignored one stays ignored). Outside the main thread,
    which alone may set handlers and where Python raises no ``KeyboardInterrupt``, the
    block just runs.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    noted: list[int] = []

    def note(signum: int, frame: FrameType | None) -> None:
        noted.append(signum)

    previous = {sig: signal.signal(sig, note) for sig in DEFERRED_SIGNALS}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, signal.SIG_DFL if handler is None else handler)
        for signum in dict.fromkeys(noted):
            signal.raise_signal(signum)


#: How often a worker process looks whether its parent is still there [s].
PARENT_POLL_S = 0.5
#: How long an orphaned worker's work has to stop, interrupted, before it ends [s].
ORPHAN_GRACE_S = 10.0


def end_when_orphaned(parent: int, busy: Callable[[], bool] = lambda: True) -> None:
    """In a pool's worker process: end it once its parent (``parent``: its id) is gone.

    A ``concurrent.futures`` worker waits on its call queue, whose other end the
    siblings forked with it keep open, so it never sees its parent die: after a ``kill
    -9`` of the command, the workers lived on, orphans. An orphan is given to another
    parent, so its parent's id changes; a thread of this worker's looks every
    :data:`PARENT_POLL_S`. Then an idle worker ends at once (exit status 1); a ``busy``
    one has its work interrupted as by Ctrl-C (the arm parked, a recording's episode left
    whole or not at all) and ends when it is done, or after :data:`ORPHAN_GRACE_S`.
    ``parent`` is the id the parent recorded before it started the pool: one killed
    before this watch starts had already given the worker to another.

    Args:
        parent: The parent's process id, recorded before the pool started.
        busy: Whether the worker runs work now (default: always, as far as it knows).
    """

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        if busy():
            os.kill(os.getpid(), signal.SIGINT)  # as Ctrl-C: the work stops, cleans up
            deadline = time.monotonic() + ORPHAN_GRACE_S
            while busy() and time.monotonic() < deadline:
                time.sleep(0.05)
        os._exit(1)

    threading.Thread(target=watch, name="mearm-orphan-watch", daemon=True).start()


def install() -> None:
    """Let no Ctrl-C be lost in a finalizer (once; the previous hook kept for the rest)."""
    if getattr(sys.unraisablehook, "_mearm_resends_ctrl_c", False):
        return
    previous = sys.unraisablehook

    def hook(unraisable: sys.UnraisableHookArgs) -> None:
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
