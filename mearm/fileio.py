"""Writing a file so that a crash, a signal or a full disk never leaves half of it.

:func:`write_atomic` is how mearm writes every file it replaces (configs, URDFs, reports,
plots, screenshots):

1. A symbolic link is written *through*: the file it points to gets the new contents
   and the link stays a link (a config kept elsewhere and linked into ``configs/`` stays
   where it is).
2. The target's folder is made if it is missing (as ``mkdir -p``). The data goes to a
   new, uniquely named temporary file ``.<name>.<random>.tmp`` in the target's own
   folder (the same file system, so the rename below is atomic), which is flushed and
   ``fsync``-ed.
3. It takes the old file's permission bits (a new file: ``0o666`` less the umask, as
   ``open`` would give it), then ``os.replace`` puts it in place in one step and the
   folder is ``fsync``-ed, so the rename itself survives a power cut.

A reader sees the old file or the new one, never a mixture. A path that names a device
or a pipe (``/dev/stdout``) is not replaced but written to as a stream. On any exception the
temporary file is removed and the old file is untouched. So it is on SIGTERM, SIGINT and
SIGHUP: every temporary file being written is in a registry, and a handler installed
with the first write (from the main thread) removes them before the signal takes its
usual course — the previous handler is called, or the default action (ending the
process) is taken again. Ctrl-C already unwinds through the ``except`` clause, which
removes the file; a SIGKILL or a power cut can still leave a ``.tmp`` file behind, never
a damaged target.

A command that writes several files into a folder (plots and their report, rendered
views) writes them into a hidden staging folder there first, and puts them in place
of the earlier run's only when all are written (:func:`replace_earlier_run`): a
failure, a signal or a refused option leaves the earlier run's files whole, never a
mixture of two runs.

Append-only files (the run log) are not written this way: they are only ever appended
to, one ``fsync``-ed line at a time (:class:`mearm.runlog.RunLog`).
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import signal
import stat
import tempfile
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from types import FrameType
from typing import Any, BinaryIO

from mearm import interrupts

#: The signals after which no temporary file is left behind.
CLEANUP_SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name) for name in ("SIGTERM", "SIGINT", "SIGHUP") if hasattr(signal, name)
)

#: Temporary files being written now (any thread).
_live: set[str] = set()
#: Per signal, the handler that was installed before ours.
_previous: dict[int, Any] = {}
_install_lock = threading.Lock()


def escaped(text: str) -> str:
    r"""``text`` as UTF-8 can hold it: a file name's bytes that are not UTF-8 escaped.

    Linux file names are bytes; Python holds those that are not UTF-8 as surrogates
    (byte 0xff as U+DCFF), which UTF-8 cannot encode. Such a character is written as its
    escape, ``\udcff``, as the error line on stderr and the crash log show it; every
    other character is kept.
    """
    return text.encode("utf-8", errors="backslashreplace").decode("utf-8")


def utf8(text: str) -> bytes:
    """``text`` encoded as UTF-8, a file name that is not UTF-8 in it escaped (:func:`escaped`)."""
    return text.encode("utf-8", errors="backslashreplace")


def backup_path(path: Path) -> Path:
    """Where a file a command replaces is first kept: ``<path>.bak`` beside it.

    Later backups of the same file go beside it, never over it (:func:`keep_backup`).
    """
    return path.with_name(path.name + ".bak")


def keep_backup(path: Path, new: bytes | str | None = None) -> Path | None:
    """Keep the regular file at ``path`` before it is replaced; where it went, or ``None``.

    Its bytes go to ``<path>.bak``; where that holds an earlier backup of other bytes, to
    the first of ``<path>.bak.1``, ``<path>.bak.2``, … that is free. A backup never
    replaces another: a second run (and a third) loses nothing, not the user's own file
    a first run kept. ``None``: nothing to keep: no regular file there, ``new`` (the bytes
    about to replace it) is what it holds already, or a backup holds its bytes already.

    Raises:
        OSError: the file cannot be read or the backup written (the file is as it was).
    """
    if not path.is_file():
        return None
    data = path.read_bytes()
    if new is not None and data == (utf8(new) if isinstance(new, str) else new):
        return None
    k = 0
    while True:
        backup = backup_path(path) if k == 0 else path.with_name(f"{path.name}.bak.{k}")
        if not (backup.exists() or backup.is_symlink()):
            write_atomic(backup, data)
            return backup
        with contextlib.suppress(OSError):  # (a folder or a device there: the next name)
            if backup.is_file() and backup.read_bytes() == data:
                return None  # kept already
        k += 1


def write_atomic(path: str | os.PathLike[str], data: bytes | str) -> Path:
    """Replace the file at ``path`` with ``data`` in one step (see the module docstring).

    Args:
        path: The file to write; its folder is made if missing. A symbolic link is
            followed to the file it names, which is the one replaced.
        data: The new contents; text is written as UTF-8 (:func:`utf8`: the name of a
            file that is not UTF-8, quoted in it, is written escaped).

    Returns:
        The file actually written (``path`` with its symbolic links resolved).

    Raises:
        OSError: The folder cannot be made or is not writable, the disk is full,
            ``path`` is a folder or a loop of links, ...; the old file is unchanged and no temporary
            file is left.
    """
    payload = utf8(data) if isinstance(data, str) else bytes(data)
    try:
        st: os.stat_result | None = os.stat(path)
    except FileNotFoundError:
        st = None
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), os.fspath(path))
    if st is not None and not stat.S_ISREG(st.st_mode):  # a device or a pipe: a stream
        with open(path, "wb") as stream:
            stream.write(payload)
        return Path(path)
    target = resolve_target(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    mode = _mode_for(target)
    _install_handlers()
    made: list[tuple[BinaryIO, str]] = []  # filled while the signals are held
    try:
        _make_temp(target, made)
        f, tmp = made[0]
        with f:
            f.write(payload)
            f.flush()
            _fsync(f.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, target)
        _fsync_folder(target.parent)
    except BaseException:
        for f, tmp in made:
            f.close()
            _unlink_quietly(tmp)
        raise
    finally:
        for _, tmp in made:
            _live.discard(tmp)
    return target


def file_identity(path: str | os.PathLike[str]) -> tuple[int, int] | None:
    """(device, inode) of an existing file, else ``None``: the same file by any name.

    ``./a``, a link and a hard link are all one: how a command refuses an output that is
    one of its own inputs.
    """
    try:
        info = os.stat(path)
    except (OSError, ValueError):
        return None
    return (info.st_dev, info.st_ino)


def resolve_target(path: str | os.PathLike[str]) -> Path:
    """The file a write to ``path`` should replace: ``path`` with every link followed.

    A link to a file that does not exist yet resolves to that file (it will be created).

    Raises:
        OSError: The links form a loop.
    """
    try:
        return Path(os.path.realpath(path, strict=True))
    except FileNotFoundError:
        return Path(os.path.realpath(path))


#: Whether a signal would end the process now (:func:`mearm.interrupts.signal_ends_process`:
#: its default action, also after this module's clean-up, :func:`_on_signal`).
signal_ends_process = interrupts.signal_ends_process


def live_temp_files() -> frozenset[str]:
    """The temporary files being written at this moment (for tests and diagnostics)."""
    return frozenset(_live)


# -- plumbing


def _mode_for(target: Path) -> int:
    """The permission bits the new file takes: the old file's, else 0o666 less the umask."""
    try:
        return target.stat().st_mode & 0o7777
    except FileNotFoundError:
        return 0o666 & ~_umask()


def _umask() -> int:
    # /proc tells the umask without changing it; os.umask can only read it by setting it,
    # which would briefly affect files created by other threads.
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    with _install_lock:
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


def _make_temp(target: Path, made: list[tuple[BinaryIO, str]]) -> None:
    """Create the temporary file, open it and register it, with the cleanup signals held.

    It goes into ``made``, the caller's, before the signals are let go: a Ctrl-C held
    meanwhile is raised as they are, inside the caller's ``try``, which then knows the
    file to remove (returned instead, it was left behind).
    """
    held = _hold_signals()
    try:
        fd, tmp = tempfile.mkstemp(
            prefix=f".{_short(target.name)}.", suffix=".tmp", dir=target.parent
        )
        made.append((os.fdopen(fd, "wb"), tmp))
        _live.add(tmp)
    finally:
        _release_signals(held)


#: The longest file name most file systems take, in bytes (ext4, tmpfs, APFS, NTFS).
NAME_MAX = 255


def _short(name: str) -> str:
    """``name`` cut so ``.<name>.<8 random>.tmp`` still fits :data:`NAME_MAX`.

    A target whose own name is legal (up to 255 bytes) must not fail for its temporary
    file's longer one, nor one whose name is not UTF-8 (its bytes are the file system's:
    ``os.fsencode``; those not UTF-8 are left out of the temporary name).
    """
    room = NAME_MAX - len("..") - 8 - len(".tmp")
    return os.fsencode(name)[:room].decode("utf-8", errors="ignore")


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Take SIGINT, SIGTERM and SIGHUP after the block, not inside it, in any thread.

    In the main thread by :func:`mearm.interrupts.signals_deferred`: blocking them there
    (``pthread_sigmask``) holds them back from that thread only, and while another thread
    that takes signals is alive (a dataset recorder's writer thread; NumPy's, imported
    before mearm), the kernel gives the signal to that one and Python raises
    ``KeyboardInterrupt`` in the main thread, inside the block, all the same. In another
    thread (a writer thread, a Dask worker's), where Python raises nothing and no
    handler can be set, they are blocked in that thread until the block ends, so the
    kernel gives them to a thread outside the block.
    """
    if threading.current_thread() is threading.main_thread():
        with interrupts.signals_deferred():
            yield
        return
    if not hasattr(signal, "pthread_sigmask"):  # not on Windows
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, CLEANUP_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _hold_signals() -> contextlib.ExitStack:
    """:func:`signals_held` from now until :func:`_release_signals` is given what it returns."""
    held = contextlib.ExitStack()
    held.enter_context(signals_held())
    return held


def _release_signals(held: contextlib.ExitStack) -> None:
    """Let the signals :func:`_hold_signals` held go: one that came meanwhile is taken now."""
    held.close()


def _fsync(fd: int) -> None:
    os.fsync(fd)


def _fsync_folder(folder: Path) -> None:
    """Make the rename durable; some systems cannot open or sync a folder (ignored)."""
    try:
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _unlink_quietly(path: str) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


def _install_handlers() -> None:
    """Install the cleanup handler once, from the main thread (only it may)."""
    if len(_previous) == len(CLEANUP_SIGNALS):
        return
    if threading.current_thread() is not threading.main_thread():
        return
    with _install_lock:
        for sig in CLEANUP_SIGNALS:
            if sig in _previous:
                continue
            previous = signal.getsignal(sig)
            if previous is _on_signal:  # e.g. after this module was reloaded
                continue
            signal.signal(sig, _on_signal)
            _previous[sig] = previous


def _on_signal(signum: int, frame: FrameType | None) -> None:
    """Remove the temporary files if the signal ends the process; else hand it on.

    A Python handler before ours (Python's own Ctrl-C handler raises KeyboardInterrupt)
    is called: if it raises, the write's ``except`` clause removes its file; if it
    returns, the write goes on and needs its file. An ignored signal stays ignored. A
    signal whose action was the default (end the process, no clean-up) removes every
    temporary file, then is raised again with the default action.
    """
    previous = _previous.get(signum, signal.SIG_DFL)
    if callable(previous):
        previous(signum, frame)
        return
    if previous == signal.SIG_IGN:
        return
    for tmp in list(_live):
        _unlink_quietly(tmp)
    signal.signal(signum, signal.SIG_DFL)
    if hasattr(signal, "pthread_sigmask"):  # the handler may run while it is held off
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signum})
    os.kill(os.getpid(), signum)


def _passes_on(signum: int) -> Any:
    """The handler :func:`_on_signal` hands ``signum`` on to, after its clean-up."""
    return _previous.get(signum, signal.SIG_DFL)


# read by mearm.interrupts.signal_ends_process: the handler behind this module's clean-up
_on_signal.passes_on = _passes_on  # type: ignore[attr-defined]


def existing_ancestor(path: Path) -> Path:
    """The nearest of ``path``'s folders that exists (``path`` itself excluded).

    Where a file written to ``path`` lands once the missing folders are made.
    """
    parent = path.absolute().parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    return parent


# ------------------------------------------------------------- a run's files, whole


def staging_folder(out: Path, command: str) -> Path:
    """The hidden folder in ``out`` that this process's run of ``command`` writes into first."""
    return out / f".{command}.{os.getpid()}.tmp"


def is_staging(path: Path, command: str) -> bool:
    """Whether ``path`` is a hidden folder a run of ``command`` writes into first."""
    name, prefix = path.name, f".{command}."
    number = name[len(prefix) : -len(".tmp")]
    return (
        name.startswith(prefix)
        and name.endswith(".tmp")
        and number.isdigit()
        and path.is_dir()
        and not path.is_symlink()
    )


def remove_staging_leftovers(out: Path, command: str) -> None:
    """Remove the hidden folders of runs of ``command`` that were killed (SIGKILL, a power cut)."""
    for path in sorted(out.iterdir()):
        if is_staging(path, command):
            shutil.rmtree(path, ignore_errors=True)


def replace_earlier_run(
    staging: Path, out: Path, names: list[str], is_own: Callable[[Path], bool]
) -> None:
    """Put the new run's files (``names`` in ``staging``) in ``out`` in place of an earlier run's.

    Only renames, with Ctrl-C, SIGTERM and SIGHUP taken after the last of them
    (:func:`~mearm.interrupts.signals_deferred`), so a signal leaves the earlier run or the
    new one, whole. The earlier run's files (``is_own``) are moved aside into ``staging``
    first, the stale ones (a file the new run does not write) with them; if a rename
    fails, what was moved is moved back, and the earlier run stays as it was. ``staging``
    is removed.

    Raises:
        OSError: a rename failed (the earlier run's files are as they were); its
            ``filename`` names the file.
    """
    aside = staging / "earlier"
    moved_aside: list[str] = []
    moved_in: list[str] = []
    with interrupts.signals_deferred():
        try:
            aside.mkdir()
            for path in sorted(out.iterdir()):
                if is_own(path):
                    os.rename(path, aside / path.name)
                    moved_aside.append(path.name)
            for name in names:
                os.rename(staging / name, out / name)
                moved_in.append(name)
        except OSError:
            for name in reversed(moved_in):
                os.rename(out / name, staging / name)
            for name in reversed(moved_aside):
                os.rename(aside / name, out / name)
            shutil.rmtree(staging, ignore_errors=True)
            raise
        shutil.rmtree(staging, ignore_errors=True)  # the earlier run's files, now replaced
    _fsync_folder(out)
