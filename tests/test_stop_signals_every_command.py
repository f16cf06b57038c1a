"""SIGTERM and SIGHUP stop every command as Ctrl-C does (:func:`mearm.cli.run`).

Only ``sort``, ``experiment``, ``jog``, ``calibrate-servos`` and a few more took them; any
other command died of the signal at once: no "interrupted" line, status -15, and none of
what its Ctrl-C path does (the arm held by ``check-camera``, a temporary file removed, a
browser ended). ``mearm preview`` serves until stopped, so the signal reaches it waiting.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
from conftest import ROOT

pytestmark = pytest.mark.heavy


@pytest.mark.parametrize(("sig", "code"), [(signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_a_stop_signal_ends_a_command_that_serves_as_ctrl_c(tmp_path, sig, code):
    """``mearm preview`` serving its view: the signal ends it with 128 + the signal and
    its one "interrupted" line, as Ctrl-C ends it with 130."""
    out, err = tmp_path / "stdout.txt", tmp_path / "stderr.txt"
    cmd = [sys.executable, "-m", "mearm", "preview", "--config", "sim", "--port", "0"]
    with out.open("w") as stdout, err.open("w") as stderr:
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=stdout, stderr=stderr,
                                env={**os.environ, "MUJOCO_GL": "egl"})  # fmt: skip
    try:
        deadline = time.monotonic() + 120  # a hang (never serving) is the failure
        while "meshcat view: http://" not in out.read_text() and time.monotonic() < deadline:
            assert proc.poll() is None, err.read_text()
            time.sleep(0.05)
        proc.send_signal(sig)
        assert proc.wait(timeout=120) == code, err.read_text()
        assert err.read_text().splitlines() == ["mearm preview: interrupted"]
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


#: A command whose library swallows the stop signal's exception and fails with an error
#: of its own, as pybind11 does converting a call's arguments ("incompatible function
#: arguments", a TypeError with no trace of the signal): it must still end as stopped.
SWALLOWED = """
import os, signal, time
from mearm.cli import run

def main(argv):
    try:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(30)  # the handler raises here
    except KeyboardInterrupt:
        pass  # swallowed, as a C extension's argument conversion does
    raise TypeError("(): incompatible function arguments")

run(main)
"""


def test_a_stop_signal_a_library_swallowed_still_ends_the_command_as_stopped():
    """render-calibration, SIGTERM mid-run: MuJoCo's spec setter (pybind11) swallowed it
    and raised a TypeError: 'unexpected error' and exit 1, where it was stopped (143)."""
    proc = subprocess.run([sys.executable, "-c", SWALLOWED], cwd=ROOT, capture_output=True,
                          text=True, timeout=120)  # fmt: skip
    assert proc.returncode == 143, proc.stderr
    assert proc.stderr.strip().splitlines() == ["-c: interrupted"], proc.stderr
