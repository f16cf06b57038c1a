"""One writer per run log: an advisory lock (``flock``) held while a log is written.

Two runs appending to one log at once interleave their trials, and the log they leave
fails ``mearm analyze --strict``. A writer takes an exclusive, non-blocking ``flock`` on
the log file itself (no side file is left behind); a second writer is refused with a
:class:`RunLogLockedError` that names the process holding it (its pid and command line,
read from ``/proc/locks`` on Linux). The lock goes with the process: a writer killed by
any signal leaves no stale lock. It is advisory: readers (``mearm analyze``) do not take
it.
"""

from __future__ import annotations

import fcntl
import os
from pathlib import Path
from typing import BinaryIO

from mearm.runlog.errors import RunLogError, RunLogLockedError

#: Longest command line quoted in the message [characters].
MAX_COMMAND_CHARS = 120


def lock_holder(path: str | Path) -> tuple[int | None, str]:
    """The process holding a ``flock`` on ``path``: (pid, command line), or (None, "").

    Reads ``/proc/locks`` (Linux); elsewhere, or when the holder cannot be seen (another
    pid namespace), the pid is ``None``.
    """
    try:
        st = os.stat(path)
        with open("/proc/locks", encoding="ascii", errors="replace") as f:
            lines = f.read().splitlines()
    except OSError:
        return None, ""
    wanted = (os.major(st.st_dev), os.minor(st.st_dev), st.st_ino)
    for line in lines:
        fields = line.split()
        # "1: FLOCK  ADVISORY  WRITE 4242 08:01:131 0 EOF" ("->" marks a blocked waiter)
        if len(fields) < 6 or fields[1] != "FLOCK":
            continue
        try:
            major, minor, inode = fields[5].split(":")
            where = (int(major, 16), int(minor, 16), int(inode))
            pid = int(fields[4])
        except ValueError:
            continue
        if where == wanted and pid > 0:
            return pid, _command(pid)
    return None, ""


def _command(pid: int) -> str:
    try:
        raw = Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return ""
    text = " ".join(a.decode("utf-8", "replace") for a in raw.split(b"\0") if a)
    return text if len(text) <= MAX_COMMAND_CHARS else text[: MAX_COMMAND_CHARS - 3] + "..."


def lock_file(file: BinaryIO, path: str | Path) -> None:
    """Take the exclusive lock on an open log file, or refuse: it is held while it is open.

    Raises:
        RunLogLockedError: another process holds it.
        RunLogError: the file system does not lock (the message says so).
    """
    try:
        fcntl.flock(file.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        raise RunLogLockedError(path, *lock_holder(path)) from None
    except OSError as exc:
        raise RunLogError(path, f"cannot be locked for writing: {exc}") from None


class LogLock:
    """The lock on an existing run log, held before it is opened for writing.

    A command that reads and repairs a log before it appends to it (``mearm experiment``
    resuming) takes this first, so no other writer slips in between; it hands it to
    :class:`~mearm.runlog.RunLog` (``lock=``), which then takes no lock of its own.

    Args:
        path: The log (a regular file).

    Raises:
        RunLogLockedError: another process writes it.
        RunLogError: it cannot be opened.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        try:
            self._file: BinaryIO = self.path.open("rb")
        except OSError as exc:
            raise RunLogError(self.path, f"cannot open: {exc}") from None
        try:
            lock_file(self._file, self.path)
        except BaseException:
            self._file.close()
            raise

    def release(self) -> None:
        """Let the lock go (closing its file)."""
        self._file.close()

    def __enter__(self) -> LogLock:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.release()
