"""``mearm sort --view --hold``: the outcome is said before the view is held open.

With ``--record`` the summary waits for the dataset's ``wrote`` line, which came as the
recorder closed: after the hold, so a user looking at the view saw neither the outcome nor
the dataset until they pressed Ctrl-C. Now both come first, and the hold's own line goes
to stderr: stdout's last line stays the outcome.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

pytest.importorskip("meshcat")
pytest.importorskip("av")

#: Bounds a hang only: the two-object sort runs at the servos' pace for the view.
HANG_S = 300


def test_hold_says_the_outcome_and_names_the_dataset_before_it_waits(tmp_path: Path) -> None:
    data = tmp_path / "data"
    argv = ["sort", "--config", "sim", "--random", "2", "--seed", "3", "--view", "--hold",
            "--record", str(data), "--record-codec", "h264"]  # fmt: skip
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    proc = subprocess.Popen(
        [sys.executable, "-m", "mearm", *argv],
        cwd=ROOT, env=env, text=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
    )  # fmt: skip
    before: list[str] = []
    try:
        assert proc.stdout is not None
        for line in proc.stdout:
            if "stays open" in line:
                break
            before.append(line.rstrip("\n"))
        else:
            pytest.fail(f"the view was not held: {before}")
        proc.send_signal(signal.SIGINT)
        rest, _ = proc.communicate(timeout=HANG_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, (before, rest)
    said = "\n".join(before)
    assert f"wrote {data}/ (2 episodes" in said, said
    assert before[-1] == "sorted 2 of 2 objects (simulated)", said
    assert "sorted" not in rest and "wrote" not in rest, rest
