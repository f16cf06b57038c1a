"""The maker commands check what they are given before they start, and keep what a session
measured when the end fails: calibrate-servos' ``--output`` and ``--actuators``,
find-port's ``--port`` and ``--wait``, find-camera's ``--camera``, flash's ``--port``.

calibrate-servos' keyboard session runs as a user runs it (a process on a pty,
:class:`test_maker_calibrate.PtyCommand`, against the sim backend); the refusals run in
this process, through the bad-input check (exit 2, one line, no traceback, files kept).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import Outcome, check_bad_input, run_in_process
from conftest import CORE_H, require_file, require_tool
from test_maker_calibrate import PtyCommand, _args, operate, sim_args, sim_truth
from test_maker_tools import _fake_avrdude


def _refused(*args: object, words: tuple[str, ...], keep: tuple[Path, ...] = ()) -> Outcome:
    """``mearm ARGS`` in this process: exit 2, one line on stderr holding ``words``, no
    traceback, ``keep`` as it was (:func:`badinput.check_bad_input`)."""
    out = check_bad_input(args, keep=keep)
    for word in words:
        assert word in out.line, out.stderr
    return out


# --------------------------------------------------------------------- calibrate-servos


@pytest.mark.heavy
@pytest.mark.parametrize("where", ["folder", "under a file"])
def test_keyboard_output_that_cannot_be_written_is_refused_before_the_session(tmp_path, where):
    """An --output the end could not write is refused before the board opens, as
    --simulate does: exit 2, nothing jogged for nothing."""
    if where == "folder":
        out = tmp_path / "cal"
        out.mkdir()
        words = "a folder"
    else:
        (tmp_path / "notes.txt").write_text("x\n")
        out = tmp_path / "notes.txt" / "servos.yaml"
        words = "is a file, not a folder"
    cmd = PtyCommand(*_args(out, *sim_args()))
    try:
        assert cmd.wait() == 2
    finally:
        cmd.close()
    assert words in cmd.text and "connected" not in cmd.text, cmd.text


@pytest.mark.heavy
def test_a_failed_write_prints_the_fits_first(tmp_path):
    """The folder became unwritable during the session (here: a file now stands where the
    output's folder was to be made): the write fails, exit 2, but the fit is printed as
    --set overrides first, so the jogging is not lost."""
    out = tmp_path / "sub" / "servos.yaml"
    cmd = PtyCommand(*_args(out, *sim_args(), "--actuators", "base"))
    try:
        cmd.expect(r"connected: simulated")
        (tmp_path / "sub").write_text("in the way\n")
        operate(cmd, sim_truth(), 1)
        assert cmd.wait() == 2
    finally:
        cmd.close()
    text = cmd.text
    assert "--set 'arm.joints.base.servo" in text, text
    assert text.index("--set 'arm.joints.base.servo") < text.index("cannot write")
    assert "the fits are printed above" in text
    assert "Traceback" not in text


@pytest.mark.parametrize("names", ["base,base", "base, shoulder,base"])
def test_an_actuator_named_twice_is_refused(tmp_path, names):
    """It would be fitted twice and one fit written: exit 2, one line, nothing written."""
    out = tmp_path / "ct.yaml"
    _refused(
        "calibrate-servos", "--config", "sim_mujoco", "--simulate", "--actuators", names,
        "--output", out, words=("'base' is named twice",),
    )  # fmt: skip
    assert not out.exists()


# --------------------------------------------------------------------- find-port


@pytest.mark.parametrize("port", ["missing", "folder"])
def test_find_port_refuses_a_port_that_is_missing_or_a_folder(tmp_path, port):
    """Without --replug a --port that is not there is a typo, not "no board found": exit 2
    with one line, before any port is opened. A folder is never a port, even with
    --replug."""
    path = tmp_path / "ttyNOPE"
    if port == "folder":
        path.mkdir()
    says = "does not exist" if port == "missing" else "is a folder"
    r = _refused("find-port", "--only", "--port", path, words=(f"--port {path}", says))
    assert "serial port" not in r.stdout  # nothing listened to
    if port == "folder":  # before it asks for a terminal
        _refused("find-port", "--replug", "--only", "--port", path, words=("is a folder",))


def test_find_port_refuses_wait_without_replug():
    """--wait only means something to --replug: exit 2, one line, nothing scanned."""
    r = _refused("find-port", "--wait", "5", "--only", words=("--wait", "--replug"))
    assert r.stdout == ""


# --------------------------------------------------------------------- find-camera


@pytest.mark.parametrize(
    ("source", "words"),
    [
        ("folder", "is a folder"),
        ("text", "OpenCV cannot read a frame from it"),
        ("-1", "a camera index is 0 or more"),
        ("missing", "does not exist"),
    ],
)
def test_find_camera_refuses_a_source_that_cannot_be_a_camera(tmp_path, source, words):
    """A folder, a text file, a negative index or a missing path is bad input (exit 2, one
    line), not "no cameras found … is one plugged in" (exit 1); nothing is tried."""
    given = {"folder": str(tmp_path), "missing": str(tmp_path / "nope.avi"), "-1": "-1"}
    if source == "text":
        (tmp_path / "a.yaml").write_text("camera: {kind: device}\n")
        given["text"] = str(tmp_path / "a.yaml")
    out = tmp_path / "snaps"
    r = _refused("find-camera", "--out", out, "--camera", given[source], words=(words,),
                 keep=(tmp_path,))  # fmt: skip
    assert "trying" not in r.stdout and not out.exists()


def test_find_camera_tries_a_source_given_twice_once(tmp_path):
    """--camera X --camera X: X is tried (and listed) once."""
    video = tmp_path / "v.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 10, (64, 48))
    writer.write(np.zeros((48, 64, 3), np.uint8))
    writer.release()
    r = run_in_process(["find-camera", "--out", tmp_path / "s", "--camera", video,
                        "--camera", video])  # fmt: skip
    assert r.code == 0, r.stderr
    assert "trying 1 camera source:" in r.stdout
    assert r.stdout.count("camera: 64x48 px") == 1


# --------------------------------------------------------------------- flash


@pytest.mark.parametrize("port", ["missing", "folder"])
def test_flash_refuses_a_port_that_is_missing_or_a_folder_before_the_build(
    tmp_path, monkeypatch, port
):
    """avrdude could only fail on it, after a build: exit 2 with one line, nothing built,
    avrdude never run."""
    for tool in ("make", "avr-gcc", "avr-objcopy"):
        require_tool(tool)
    require_file(CORE_H, "arduino-core-avr")
    require_file(Path("/usr/lib/avr/include/avr/io.h"), "avr-libc")
    env, log = _fake_avrdude(tmp_path / "bin", 0)
    monkeypatch.setenv("PATH", env["PATH"])
    path = tmp_path / "ttyACM9"
    if port == "folder":
        path.mkdir()
    build = tmp_path / "build"
    says = "does not exist" if port == "missing" else "is a folder"
    _refused("flash", "--port", path, "--build-dir", build, words=(f"--port {path}", says))
    assert not build.exists() and not log.exists()
