"""``mearm calibrate-servos``: a servo fault's line starts a line of its own on the terminal.

The live status line is written with a carriage return and no newline; a board lost in
the middle of a session printed the fault's one line on the end of it (``… target 65
degmearm calibrate-servos: servo fault: …``), where the maker reads the status line.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from fakeboard import FakeMearmBoard, MearmFaults
from test_maker_calibrate import PtyCommand, _args, serial_args


@pytest.mark.heavy
def test_a_fault_mid_session_is_said_on_a_line_of_its_own(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    popen = subprocess.Popen

    def as_a_user_runs_it(*args, env, **kwargs):  # noqa: ANN001, ANN002, ANN003, ANN202
        """Without MEARM_DEBUG, whose log line of the fault would come first."""
        return popen(*args, env={k: v for k, v in env.items() if k != "MEARM_DEBUG"}, **kwargs)

    monkeypatch.setattr(subprocess, "Popen", as_a_user_runs_it)
    out = tmp_path / "servos.yaml"
    with FakeMearmBoard(MearmFaults(drop_at_move=6)) as board:
        cmd = PtyCommand(*_args(out, *serial_args(board.port)))
        try:
            cmd.expect(r"base: pulse (\d+) µs")
            cmd.send("\x1b[C" * 12)  # jog the base until the board is gone
            assert cmd.wait() == 1, cmd.text[-2000:]
        finally:
            cmd.close()
    [line] = [ln for ln in cmd.text.splitlines() if "servo fault" in ln]
    assert line.startswith("mearm calibrate-servos: servo fault: "), line
    assert not out.exists()
