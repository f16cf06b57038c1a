"""Ctrl-C and SIGTERM in the middle of ``mearm check-camera`` on a servo board.

The check had no Ctrl-C path of its own: the command ended with ``mearm check-camera:
interrupted`` and nothing else, the arm left wherever the signal found it (the object
perhaps in its jaws) and its pose unsaid, where the safety page promised it parked.
Parking from anywhere is no planned, checked route for the check, so it now says what
it does: nothing more is sent, the arm stays where it is, and the one line names the
last acknowledged pose. Only the board is mocked (the pty fake Uno); the command is a
real process and the signal a real one.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from conftest import QUICK_SERVOS, ROOT
from fakeboard import FakeMearmBoard

from mearm.config import config_from_dict


class _SlowUno(FakeMearmBoard):
    """The fake Uno answering each line 20 ms late: the check is mid-move for longer."""

    def _transmit(self, line: bytes) -> None:
        time.sleep(0.02)
        super()._transmit(line)


def _moves(board: FakeMearmBoard) -> int:
    return sum(1 for line in list(board.received) if b" M " in line)


@pytest.mark.parametrize(("sig", "code", "named"), [
    (signal.SIGINT, 130, "Ctrl-C"),
    (signal.SIGTERM, 143, "SIGTERM"),
])  # fmt: skip
def test_a_stop_mid_check_sends_nothing_more_and_names_the_pose(
    tmp_path: Path, sig: signal.Signals, code: int, named: str
) -> None:
    with _SlowUno() as board:
        servo = {"backend": "serial", "port": board.port, "ack_timeout_s": 5.0,
                 "banner_timeout_s": 5.0, "rate_hz": 1000.0}  # fmt: skip
        config = tmp_path / "rig.yaml"
        data = config_from_dict({"servo": servo}).model_dump(mode="json")
        config.write_text(yaml.safe_dump(data))
        proc = subprocess.Popen(
            [sys.executable, "-m", "mearm", "check-camera", "--config", str(config),
             *QUICK_SERVOS],
            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            env={**os.environ, "MEARM_STATE_DIR": str(tmp_path)},
        )  # fmt: skip
        try:
            deadline = time.monotonic() + 120  # a hang is the failure
            while _moves(board) < 6:  # the arm on its way to the object
                assert proc.poll() is None and time.monotonic() < deadline, proc.stderr
                time.sleep(0.002)
            proc.send_signal(sig)
            at_signal = _moves(board)
            _, err = proc.communicate(timeout=120)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        board.drained()
        moves = _moves(board)
    assert proc.returncode == code, err
    assert "Traceback" not in err
    (line,) = err.strip().splitlines()
    assert line.startswith(f"mearm check-camera: stopped: interrupted ({named}); "), line
    assert "the arm stays where it is, nothing more sent to the servos" in line, line
    assert "last acknowledged pose: base=" in line, line
    assert moves <= at_signal + 1, (at_signal, moves)  # only a move already on its way
