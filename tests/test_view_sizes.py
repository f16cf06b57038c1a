"""Headless screenshots of any allowed size finish, and a browser that stops answering is
a named error at the screenshot's timeout, not a hang (real Chromium, real processes).

A screenshot's browser window used to be the picture's size; headless Chromium keeps 87 px
of a window's height for its toolbars, so a picture 87 px high or less had no page area,
drew no frame, and ``Page.captureScreenshot`` never answered (``--size 64x64`` hung).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import ROOT, browser_or_skip, processes_under

#: Bounds every run here: a hang is the failure.
HANG_S = 120

#: A page that looks like a viewer holding its scene but never draws a frame (its
#: requestAnimationFrame drops the callback), so waiting for two frames never ends.
NEVER_DRAWS = """<!doctype html><script>
window.viewer = {connection: {readyState: 1}, num_messages_received: 1,
                 scene_tree: {children: {}}};
window.requestAnimationFrame = () => 0;
</script>
"""

#: A command that takes one screenshot through mearm's own error handling, in a browser
#: started first (its start, slow on a loaded machine, is not the deadline under test).
SHOOT = """
import sys
from mearm.cli import run
from mearm.view import HeadlessBrowser, find_browser, screenshot

def main(argv):
    with HeadlessBrowser(find_browser(), timeout_s=60) as session:
        screenshot(argv[0], argv[1], timeout_s=float(argv[2]), session=session)
    return 0

run(main, sys.argv[1:])
"""


@pytest.fixture
def browser_tmp() -> Iterator[Path]:
    """A short $TMPDIR for the run (the browser's profile, its sockets: at most 107 bytes);
    on leaving, whatever the run left running there is killed (only what this test
    started) and the folder removed."""
    browser_or_skip()
    tmp = Path(tempfile.mkdtemp(prefix="mearm-sizes-"))
    try:
        yield tmp
    finally:
        for pid in processes_under(tmp):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        shutil.rmtree(tmp, ignore_errors=True)


def _run(args: list[str], tmp: Path) -> subprocess.CompletedProcess:
    """``python ARGS`` with $TMPDIR ``tmp``, failing (not hanging) after :data:`HANG_S`."""
    env = {**os.environ, "TMPDIR": str(tmp), "PYTHONPATH": str(ROOT)}
    try:
        return subprocess.run(
            [sys.executable, *args],
            cwd=ROOT,
            env=env,
            capture_output=True,
            text=True,
            timeout=HANG_S,
            start_new_session=True,
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"still running after {HANG_S} s: {args}")


@pytest.mark.heavy
@pytest.mark.parametrize(
    ("size", "arm_seen"),
    [
        ((64, 64), True),  # the size that hung (87 px high or less: no page at all)
        ((1600, 1000), True),  # larger than the browser's window
    ],
    ids=["64x64", "1600x1000"],
)
def test_preview_screenshot_of_any_allowed_size_is_written(size, arm_seen, browser_tmp, tmp_path):
    """`mearm preview --screenshot --size WxH` writes a W×H PNG and exits 0, making its
    folder where it is missing, as every command that writes does."""
    w, h = size
    out = tmp_path / "shots" / f"{w}x{h}" / "arm.png"
    args = ["-m", "mearm", "preview", "--screenshot", str(out), "--size", f"{w}x{h}"]
    proc = _run(args, browser_tmp)
    assert proc.returncode == 0, proc.stderr
    assert f"wrote {out}" in proc.stdout
    img = cv2.imread(str(out))
    assert img.shape == (h, w, 3)
    if arm_seen:  # the arm's orange links are drawn, not just the background
        hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
        orange = (hsv[..., 0] >= 10) & (hsv[..., 0] <= 22) & (hsv[..., 1] >= 150)
        assert np.count_nonzero(orange) > 0
    assert processes_under(browser_tmp) == [], "browser processes are left"


@pytest.mark.slow
def test_a_browser_that_never_draws_is_a_named_error_at_the_timeout(browser_tmp, tmp_path):
    """A page that never draws a frame ends the screenshot at its timeout_s with exit 1 (a
    failure of the run, not bad input) and one line naming the step the browser did not
    finish; no PNG, no browser left, and not the PNG's missing folder either."""
    page = tmp_path / "never_draws.html"
    page.write_text(NEVER_DRAWS)
    out = tmp_path / "shots" / "view.png"
    proc = _run(["-c", SHOOT, page.as_uri(), str(out), "8"], browser_tmp)  # the page alone
    assert proc.returncode == 1, proc.stderr
    err = proc.stderr.strip()
    assert len(err.splitlines()) == 1, err
    assert "Traceback" not in err
    assert "the browser did not draw two frames of the view at file://" in err
    assert "Runtime.evaluate got no answer" in err
    assert not out.parent.exists()
    assert processes_under(browser_tmp) == [], "browser processes are left"
    assert list(browser_tmp.iterdir()) == [], "the profile folder is left"
