"""Ctrl-C that is never lost: one that a finalizer swallowed is delivered again.

Python's Ctrl-C handler raises :class:`KeyboardInterrupt` wherever the main thread is.
Where that is a weak reference's callback or a ``__del__`` (the garbage collector runs
them between any two lines), Python cannot pass the exception on: it hands it to
:func:`sys.unraisablehook`, which prints "Exception ignored in …", and carries on, so a
sort or an experiment runs on as though no one had pressed Ctrl-C (seen: a 10,000-trial
``mearm experiment`` that ran on). :func:`install` puts a hook in place that sends such a
Ctrl-C again, from another thread, so that it is raised where the finalizer returned to.
Every other unraisable exception goes to the hook that was there before.
"""

from __future__ import annotations

import _thread
import os
import signal
import sys
import time
from typing import Any

#: How long after a lost Ctrl-C it is sent again [s].
RESEND_AFTER_S = 0.02


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
