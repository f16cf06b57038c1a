"""mearm.fileio.write_atomic: one-step replacement, links written through, no temp left."""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import pytest
from conftest import ROOT

from mearm import fileio
from mearm.cli import write_text_atomic
from mearm.exceptions import MearmError
from mearm.fileio import live_temp_files, write_atomic


def leftovers(folder: Path) -> list[str]:
    """Temporary files of write_atomic left in ``folder``."""
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


def test_write_creates_and_replaces(tmp_path: Path) -> None:
    path = tmp_path / "a.yaml"
    assert write_atomic(path, "one: 1\n") == path
    assert path.read_text() == "one: 1\n"
    write_atomic(path, b"two: 2\n")
    assert path.read_bytes() == b"two: 2\n"
    assert leftovers(tmp_path) == []


def test_the_temp_file_is_unique_and_beside_the_target(tmp_path: Path, monkeypatch) -> None:
    """While writing, the only temp file is .<name>.<random>.tmp in the target's folder."""
    seen: list[frozenset[str]] = []
    monkeypatch.setattr(fileio, "_fsync", lambda fd: seen.append(live_temp_files()))
    write_atomic(tmp_path / "c.yaml", "x")
    write_atomic(tmp_path / "c.yaml", "y")
    (first,), (second,) = seen
    assert first != second
    for tmp in (first, second):
        assert Path(tmp).parent == tmp_path
        assert Path(tmp).name.startswith(".c.yaml.") and tmp.endswith(".tmp")
    assert live_temp_files() == frozenset()


def test_permission_bits_of_the_old_file_are_kept(tmp_path: Path) -> None:
    path = tmp_path / "calib.yaml"
    path.write_text("old")
    path.chmod(0o640)
    write_atomic(path, "new")
    assert stat.S_IMODE(path.stat().st_mode) == 0o640


def test_a_new_file_gets_the_umask_mode(tmp_path: Path) -> None:
    """As open() would give it, not mkstemp's 0o600."""
    old = os.umask(0o027)
    try:
        write_atomic(tmp_path / "new.txt", "x")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "new.txt").stat().st_mode) == 0o640


def test_a_symlink_is_written_through_and_stays_a_link(tmp_path: Path) -> None:
    """The linked file gets the contents; the temp file is made in *its* folder."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    real = elsewhere / "lab.yaml"
    real.write_text("old")
    configs = tmp_path / "configs"
    configs.mkdir()
    link = configs / "lab.yaml"
    link.symlink_to(os.path.relpath(real, configs))
    assert write_atomic(link, "new") == real
    assert link.is_symlink() and real.read_text() == "new"
    assert not real.is_symlink()
    assert leftovers(configs) == [] and leftovers(elsewhere) == []


def test_a_chain_of_links_is_followed_to_the_end(tmp_path: Path) -> None:
    real = tmp_path / "real.yaml"
    real.write_text("old")
    (tmp_path / "mid.yaml").symlink_to(real)
    (tmp_path / "top.yaml").symlink_to(tmp_path / "mid.yaml")
    write_atomic(tmp_path / "top.yaml", "new")
    assert real.read_text() == "new"
    assert (tmp_path / "top.yaml").is_symlink() and (tmp_path / "mid.yaml").is_symlink()


def test_a_dangling_link_creates_its_target(tmp_path: Path) -> None:
    link = tmp_path / "link.yaml"
    link.symlink_to(tmp_path / "target.yaml")
    write_atomic(link, "x")
    assert link.is_symlink() and (tmp_path / "target.yaml").read_text() == "x"


def test_a_link_loop_is_an_error_and_stays(tmp_path: Path) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    a.symlink_to(b)
    b.symlink_to(a)
    with pytest.raises(OSError):
        write_atomic(a, "x")
    assert a.is_symlink() and b.is_symlink() and leftovers(tmp_path) == []


def test_a_folder_is_not_replaced(tmp_path: Path) -> None:
    folder = tmp_path / "out"
    folder.mkdir()
    (folder / "keep").write_text("k")
    with pytest.raises(IsADirectoryError):
        write_atomic(folder, "x")
    assert (folder / "keep").read_text() == "k"


def test_a_device_is_written_to_not_replaced() -> None:
    """/dev/null stays a device (a root process must not replace it with a file)."""
    write_atomic("/dev/null", b"discarded")
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_a_missing_folder_is_made(tmp_path: Path) -> None:
    """``--out calib/pose.yaml`` with no ``calib/`` yet: as ``mkdir -p``, then the file."""
    assert write_atomic(tmp_path / "calib" / "new" / "x.yaml", "x") == (
        tmp_path / "calib" / "new" / "x.yaml"
    )
    assert (tmp_path / "calib" / "new" / "x.yaml").read_text() == "x"


def test_a_folder_under_a_regular_file_is_an_error(tmp_path: Path) -> None:
    (tmp_path / "f").write_text("a file")
    with pytest.raises(OSError):
        write_atomic(tmp_path / "f" / "x.yaml", "x")
    assert (tmp_path / "f").read_text() == "a file"


@pytest.mark.parametrize("error", [OSError(28, "No space left on device"), KeyboardInterrupt()])
def test_a_failure_mid_write_keeps_the_old_file_and_no_temp(
    tmp_path: Path, monkeypatch, error: BaseException
) -> None:
    path = tmp_path / "config.yaml"
    path.write_text("old")

    def fail(fd: int) -> None:
        raise error

    monkeypatch.setattr(fileio, "_fsync", fail)
    with pytest.raises(type(error)):
        write_atomic(path, "new")
    assert path.read_text() == "old"
    assert leftovers(tmp_path) == [] and live_temp_files() == frozenset()


def test_concurrent_writes_never_mix(tmp_path: Path) -> None:
    """Eight threads replace one file; it ends as one whole version, no temp left."""
    path = tmp_path / "shared.txt"
    versions = [bytes([65 + i]) * 100_000 for i in range(8)]
    threads = [threading.Thread(target=write_atomic, args=(path, v)) for v in versions]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert path.read_bytes() in versions
    assert leftovers(tmp_path) == []


#: A child that replaces ``old`` by ``new`` but stalls in the middle of the write
#: (after the temp file is written, before the rename) until a line comes on stdin.
STALLED_WRITE = textwrap.dedent(
    """
    import signal, sys
    from pathlib import Path
    from mearm import fileio

    setup = sys.argv[2]
    if setup == "flag":
        signal.signal(signal.SIGTERM, lambda *_: print("handled", flush=True))
    elif setup == "ignore":
        signal.signal(signal.SIGTERM, signal.SIG_IGN)

    def stall(fd):
        print("ready", flush=True)
        sys.stdin.readline()

    fileio._fsync = stall
    fileio.write_atomic(Path(sys.argv[1]), "new")
    print("written", flush=True)
    """
)


def stalled_writer(path: Path, setup: str = "default") -> subprocess.Popen[str]:
    proc = subprocess.Popen(
        [sys.executable, "-c", STALLED_WRITE, str(path), setup],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    assert proc.stdout is not None
    assert proc.stdout.readline() == "ready\n"
    assert len(leftovers(path.parent)) == 1  # the temp file exists now
    return proc


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
def test_a_signal_mid_write_removes_the_temp_file(tmp_path: Path, sig: signal.Signals) -> None:
    """The process ends as the signal says; the old file is whole; no .tmp is left."""
    path = tmp_path / "calibration.yaml"
    path.write_text("old")
    proc = stalled_writer(path)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode != 0 and "written" not in out
    if sig != signal.SIGINT:  # SIGINT is KeyboardInterrupt, unwinding through except
        assert proc.returncode == -sig, err
    assert path.read_text() == "old"
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("setup", ["flag", "ignore"])
def test_a_signal_the_program_handles_lets_the_write_finish(tmp_path: Path, setup: str) -> None:
    """A handler that returns (or an ignored signal) keeps the write going to its end."""
    path = tmp_path / "calibration.yaml"
    path.write_text("old")
    proc = stalled_writer(path, setup)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate("go\n", timeout=30)  # the signal is in before the line
    assert proc.returncode == 0, err
    assert out.endswith("written\n") and ("handled" in out) == (setup == "flag")
    assert path.read_text() == "new" and leftovers(tmp_path) == []


def test_write_text_atomic_makes_the_folder_and_writes_through_links(tmp_path: Path) -> None:
    real = tmp_path / "real.urdf"
    real.write_text("old")
    link = tmp_path / "arm.urdf"
    link.symlink_to(real)
    write_text_atomic(link, "<robot/>")
    assert link.is_symlink() and real.read_text() == "<robot/>"
    write_text_atomic(tmp_path / "a" / "b" / "c.txt", "deep")
    assert (tmp_path / "a" / "b" / "c.txt").read_text() == "deep"


def test_write_text_atomic_names_the_file_it_cannot_write(tmp_path: Path) -> None:
    (tmp_path / "file").write_text("")
    with pytest.raises(MearmError, match=r"cannot write .*file/x\.txt"):
        write_text_atomic(tmp_path / "file" / "x.txt", "x")


@pytest.mark.parametrize("name", ["a" * 251 + ".txt", "é" * 125 + ".txt"])
def test_a_file_name_of_the_longest_legal_length_is_written(tmp_path: Path, name: str) -> None:
    """255 bytes is a legal name: its temporary file's longer name must not refuse it."""
    write_text_atomic(tmp_path / name, "x")
    assert (tmp_path / name).read_text() == "x"
    assert [p.name for p in tmp_path.iterdir()] == [name]  # no temporary file left


def test_a_write_error_gives_the_reason_without_errno_noise(tmp_path: Path) -> None:
    with pytest.raises(MearmError) as caught:
        write_text_atomic(tmp_path / ("a" * 300), "x")
    message = str(caught.value)
    assert message == f"cannot write {tmp_path / ('a' * 300)}: File name too long"


def test_a_ctrl_c_held_while_the_temp_file_is_made_leaves_none(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The signals are held while the temporary file is made; a Ctrl-C that came then is
    raised as they are let go. It used to be raised before the writer knew the file's
    name, which was left behind (a new-user walk found one beside a rendered view)."""
    release = fileio._release_signals

    def release_then_ctrl_c(previous):
        release(previous)
        raise KeyboardInterrupt

    monkeypatch.setattr(fileio, "_release_signals", release_then_ctrl_c)
    target = tmp_path / "out.txt"
    target.write_text("old")
    with pytest.raises(KeyboardInterrupt):
        write_atomic(target, "new")
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]
    assert live_temp_files() == frozenset()
