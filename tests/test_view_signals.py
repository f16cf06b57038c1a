"""A headless screenshot leaves nothing behind when a signal ends it: no browser process,
no profile folder (a real SIGTERM to a real process)."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
from conftest import ROOT, browser_or_skip, processes_under

from mearm.fileio import signal_ends_process

#: The screenshot of a page that never draws a view waits for it until its timeout: the
#: signal comes in the middle of it.
SHOOT = """
import sys
from mearm.view import screenshot
screenshot("about:blank", sys.argv[1], timeout_s=120, browser=sys.argv[2])
"""


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM], ids=["SIGTERM"])  # SIGHUP: the same path
def test_a_signal_mid_screenshot_ends_the_browser_and_removes_its_profile(tmp_path, sig):
    """The signal ends the process as it would have (killed by it), after the browser's
    whole process group has ended and its temporary profile folder is gone."""
    browser = browser_or_skip()
    # the browser's sockets in its profile need a short path (at most 107 bytes)
    tmp = Path(tempfile.mkdtemp(prefix="mearm-signal-"))
    env = {**os.environ, "TMPDIR": str(tmp), "PYTHONPATH": str(ROOT)}
    said = tmp_path / "stderr.txt"  # what the child said, for a failure to show
    with said.open("w") as stderr:
        child = subprocess.Popen(
            [sys.executable, "-c", SHOOT, str(tmp_path / "view.png"), browser],
            env=env,
            stderr=stderr,
            start_new_session=True,
        )
    try:
        deadline = time.monotonic() + 60
        while not list(tmp.glob("mearm-chromium-*/DevToolsActivePort")):
            assert child.poll() is None, f"ended before the browser was up: {said.read_text()}"
            assert time.monotonic() < deadline, "the browser did not start"
            time.sleep(0.05)
        assert processes_under(tmp)  # the browser runs, with its profile in there
        child.send_signal(sig)
        assert child.wait(timeout=60) == -sig, said.read_text()
        assert list(tmp.iterdir()) == [], "the profile folder is left"
        assert processes_under(tmp) == [], "browser processes are left"
        assert not (tmp_path / "view.png").exists()
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
        for pid in processes_under(tmp):  # only what this test started
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        shutil.rmtree(tmp, ignore_errors=True)


def test_which_signals_end_the_process():
    """The default action ends it; a Python handler or an ignored signal does not."""
    sig = signal.SIGUSR1
    previous = signal.getsignal(sig)
    try:
        signal.signal(sig, signal.SIG_DFL)
        assert signal_ends_process(sig)
        signal.signal(sig, signal.SIG_IGN)
        assert not signal_ends_process(sig)
        signal.signal(sig, lambda *_: None)
        assert not signal_ends_process(sig)
    finally:
        signal.signal(sig, previous)
