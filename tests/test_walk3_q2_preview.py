"""docs/view.md walked again: ``mearm preview`` refuses before serving what it cannot do.

A flag that works only with another (``--size`` without ``--screenshot``, ``--step-deg``
without ``--sweep``) is refused instead of dropped in silence; a --screenshot folder that
takes no file, and a ``$MEARM_CHROMIUM`` that names no browser, are refused before the
server starts and the arm is rendered, not after. A ``$MEARM_CHROMIUM`` that names
nothing is refused, never passed over for another browser on PATH.
"""

from __future__ import annotations

import os
import socket
from pathlib import Path

import pytest
from badinput import check_bad_input

from mearm.exceptions import BrowserNotFoundError
from mearm.view import find_browser

bad_input = pytest.mark.bad_input


@bad_input
@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["--size", "640x480"], "--size sizes the --screenshot PNG: use it with --screenshot"),
        (["--force"], "--force replaces the --screenshot file: use it with --screenshot"),
        (["--hold"], "--hold keeps serving after --screenshot: use it with --screenshot"),
        (["--step-deg", "2"], "--step-deg is the --sweep's step: use it with --sweep"),
        (["--rate-hz", "5", "--joints", "base=90"], "--rate-hz paces the --sweep: use it"),
        (["--sweep", "--size", "640x480"], "--size sizes the --screenshot PNG"),
    ],
)
def test_a_flag_without_the_one_it_works_with_is_refused(argv: list[str], said: str) -> None:
    """Before, the view was served with the flag ignored (until Ctrl-C: the hang bound)."""
    out = check_bad_input(["preview", "--port", "0", *argv], within_s=1)
    assert said in out.line


@bad_input
def test_a_pose_its_servo_cannot_take_is_refused_as_fk_refuses_it() -> None:
    """The MeArm v1's elbow servo turns shoulder + elbow: each within its limits, the sum
    past the servo's pulse range was drawn as a pose (exit 0) where ``mearm fk`` refused it."""
    joints = ["--joints", "shoulder=30,elbow=-150"]
    out = check_bad_input(["preview", "--config", "sim_mearm_v1", "--port", "0", *joints])
    said = "elbow's servo (shoulder + elbow) = -120 deg needs a"
    assert said in out.line and "allows elbow's servo (shoulder + elbow) in [-75, 75]" in out.line
    fk = check_bad_input(["fk", "--config", "sim_mearm_v1", "--joints", "90,30,-150"])
    assert said in fk.line


@bad_input
def test_a_screenshot_folder_that_takes_no_file_is_refused_before_the_render() -> None:
    """/proc refuses a new file to root too: said for --screenshot at once (before, after
    the server started and the browser rendered, and without naming the flag)."""
    out = check_bad_input(["preview", "--screenshot", "/proc/x.png", "--port", "0"], within_s=1)
    assert out.line.endswith(
        "error: --screenshot /proc/x.png: cannot write: the folder /proc is not writable: a "
        "new file there failed (No such file or directory)"
    )


def _fake_browser(folder: Path) -> None:
    """An executable named chromium in ``folder``: what PATH would offer instead."""
    exe = folder / "chromium"
    exe.write_text("#!/bin/sh\nexit 0\n")
    exe.chmod(0o755)


def test_a_mearm_chromium_that_names_nothing_is_refused_not_passed_over(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    _fake_browser(tmp_path)
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.setenv("MEARM_CHROMIUM", str(tmp_path / "chromium-typo"))
    with pytest.raises(BrowserNotFoundError, match=r"\$MEARM_CHROMIUM = '.*chromium-typo'"):
        find_browser()
    monkeypatch.delenv("MEARM_CHROMIUM")
    assert find_browser() == str(tmp_path / "chromium")  # unset: PATH's
    monkeypatch.setenv("MEARM_CHROMIUM", "chromium")  # a name on PATH is taken
    assert find_browser() == str(tmp_path / "chromium")


@bad_input
def test_preview_looks_for_the_browser_before_it_takes_its_port(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """The port is held by another socket: the browser's error comes first, so it was
    looked for before the server started (before, the port's error came first)."""
    monkeypatch.setenv("MEARM_CHROMIUM", str(tmp_path / "nope"))
    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        port = held.getsockname()[1]
        shot = tmp_path / "arm.png"
        out = check_bad_input(["preview", "--screenshot", shot, "--port", port], within_s=1)
    assert "$MEARM_CHROMIUM = " in out.line and "no such executable" in out.line
    assert not shot.exists() and os.listdir(tmp_path) == []
