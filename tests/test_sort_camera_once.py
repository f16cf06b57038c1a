"""``mearm sort`` opens a real camera once.

Its note on servos never calibrated is said only of a rig whose camera opened; it was
checked by opening the camera, closing it and letting the rig open it again, which some
webcams take slowly or refuse. Now the rig's own opening decides. The USB camera is the
one part mocked (``cv2.VideoCapture``, counting its opens); the config, the sort, the
run log and the servo link are real (a fake Uno on a pty, or a port no machine has).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from badinput import run_in_process
from fakeboard import FakeMearmBoard, MearmFaults

from mearm import sort
from mearm.vision import camera

ROOT = Path(__file__).resolve().parent.parent
#: The real rig's servos on a port no machine has: found as the rig opens.
LAB = ["--config", str(ROOT / "configs" / "lab.yaml"), "--set", "servo.port=/nonexistent/tty"]
NOTE = "mearm sort: note: the servos on the serial board have never been calibrated"


class CountingCapture:
    """A USB camera that counts how often it is opened; ``plugged``: whether it is there."""

    opens = 0
    plugged = True

    def __init__(self, target: object) -> None:
        type(self).opens += 1

    def isOpened(self) -> bool:  # noqa: N802  (cv2's name)
        return self.plugged

    def set(self, prop: int, value: float) -> bool:
        return True

    def read(self) -> tuple[bool, np.ndarray]:
        return True, np.zeros((480, 640, 3), np.uint8)  # an empty black table

    def release(self) -> None:
        pass


@pytest.fixture
def capture(monkeypatch):
    monkeypatch.setattr(CountingCapture, "opens", 0)
    monkeypatch.setattr(camera.cv2, "VideoCapture", CountingCapture)
    return CountingCapture


def test_the_note_is_said_with_the_camera_opened_once(capture, capsys, tmp_path):
    """The camera is there: the note is the first line on stderr, the camera opened once."""
    with FakeMearmBoard(MearmFaults(silent_from_move=1)) as board:
        argv = [*LAB, "--set", f"servo.port={board.port}", "--set", "servo.ack_timeout_s=0.5"]
        code = sort.main([*argv, "--log", str(tmp_path / "run.jsonl")])
    err = capsys.readouterr().err
    assert code == 1, err  # the board answers no move: the sort stops, exit 1
    assert err.splitlines()[0].startswith(NOTE), err
    assert capture.opens == 1


def test_a_camera_not_there_is_tried_once_and_said_alone(capture, monkeypatch):
    """The camera is not there: one line, the error (exit 2), no note; one try to open it."""
    monkeypatch.setattr(CountingCapture, "plugged", False)
    out = run_in_process(["sort", *LAB])  # said by the guard every command runs under
    lines = out.stderr.splitlines()
    assert out.code == 2
    assert len(lines) == 1 and lines[0].startswith("mearm sort: error: camera (device 0)"), lines
    assert capture.opens == 1
