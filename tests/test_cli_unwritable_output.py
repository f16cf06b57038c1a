"""Standard output that cannot be written (``> /dev/full``, a full disk): one line, exit 1.

The failure comes where the output is written: in the command when Python writes each
print through (``PYTHONUNBUFFERED``) or its buffer fills, at the run's end when it flushes
what was buffered, or after argparse's ``--help`` (which drops write errors and used to
exit 0). Each way ends the same: one line on stderr naming standard output and the
reason, exit 1, no traceback and nothing in the crash log. A closed pipe stays quiet
(tests/test_closed_output.py).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

FULL = Path("/dev/full")

pytestmark = [
    pytest.mark.heavy,  # a child process each
    pytest.mark.skipif(not FULL.exists(), reason="needs /dev/full (Linux)"),
]


@pytest.mark.parametrize("unbuffered", [True, False], ids=["unbuffered", "buffered"])
@pytest.mark.parametrize(
    ("argv", "prog"),
    [
        (["fk", "--joints", "120,93,-132"], "mearm fk"),
        (["fk", "--help"], "mearm fk"),
        (["--help"], "mearm"),
    ],
)
def test_output_to_a_full_device_fails_in_one_line(argv, prog, unbuffered):
    state = Path(os.environ["MEARM_STATE_DIR"])
    log = state / "crash.log"
    before = log.read_bytes() if log.exists() else b""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    if unbuffered:
        env["PYTHONUNBUFFERED"] = "1"
    with FULL.open("wb") as full:
        proc = subprocess.run(
            [sys.executable, "-m", "mearm", *argv], stdout=full, stderr=subprocess.PIPE,
            text=True, env=env, cwd=ROOT, timeout=120,
        )  # fmt: skip
    assert proc.returncode == 1, proc.stderr
    assert proc.stderr == f"{prog}: error: cannot write standard output: No space left on device\n"
    assert (log.read_bytes() if log.exists() else b"") == before


class _FillsUp:
    """Standard output on a disk that fills after ``room`` lines: ENOSPC from then on."""

    def __init__(self, fd: int, room: int):
        self._fd, self.room, self.written = fd, room, ""

    def write(self, text: str) -> int:
        if self.written.count("\n") >= self.room:
            raise OSError(28, "No space left on device")
        self.written += text
        return len(text)

    def flush(self) -> None:
        pass

    def fileno(self) -> int:
        return self._fd


def test_a_long_run_whose_output_fills_up_finishes_its_job_then_exits_1(
    tmp_path, monkeypatch, capsys
):
    """A report line that cannot be written mid-job (a sort's, :func:`echo_line`) does not
    stop the job, as a closed pipe does not: the rest goes nowhere, and the run ends
    with exit 1 and one line saying so (it used to stop where the disk filled)."""
    from mearm import cli

    done = []

    def main(argv):
        for k in range(5):
            cli.echo_line(f"route {k}")
            done.append(k)
        return 0

    with (tmp_path / "out.txt").open("w") as f:
        out = _FillsUp(f.fileno(), room=2)
        monkeypatch.setattr(sys, "stdout", out)
        monkeypatch.setattr(cli, "_OUTPUT_LOST", "")
        with pytest.raises(SystemExit) as stop:
            cli.run(main, [])
    assert stop.value.code == 1
    assert done == [0, 1, 2, 3, 4]  # the job went on to its end
    assert out.written == "route 0\nroute 1\n"
    err = capsys.readouterr().err
    assert err.endswith("error: cannot write standard output: No space left on device\n")
    assert len(err.splitlines()) == 1
