"""A stopped ``mearm camera-accuracy`` leaves no render-calibration staging folder in --work.

The command runs ``mearm render-calibration`` as a child; ``subprocess.run`` killed that
child outright on the parent's SIGTERM or Ctrl-C, so the child could not remove its
hidden ``.render_calibration.<pid>.tmp`` folder, left in --work until the next run.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import ROOT


def staging(work: Path) -> list[str]:
    """The render-calibration staging folders in ``work``."""
    if not work.is_dir():
        return []
    return [p.name for p in work.iterdir() if p.name.startswith(".render_calibration.")]


@pytest.mark.parametrize(("sig", "status"), [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_stop_while_rendering_leaves_no_staging_folder(
    tmp_path: Path, sig: signal.Signals, status: int
) -> None:
    """The signal, sent to camera-accuracy alone once render-calibration is writing its
    staging folder, reaches the child, which removes the folder; the command exits
    128 + the signal's number."""
    work = tmp_path / "ca"
    cmd = [sys.executable, "-m", "mearm", "camera-accuracy", "--heights", "2", "--scenes", "1",
           "--objects", "2", "--views", "6", "--work", str(work)]  # fmt: skip
    proc = subprocess.Popen(
        cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True
    )
    try:
        deadline = time.monotonic() + 120  # a safety net, not a bound the test checks
        while not staging(work) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        assert staging(work), "render-calibration never started writing"
        proc.send_signal(sig)  # the parent alone, as `kill -TERM PID` does
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == status, err.decode(errors="replace")
    assert staging(work) == []
