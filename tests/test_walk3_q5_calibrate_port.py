"""``mearm calibrate-servos`` (by keyboard) on a port that does not exist: exit 2, one line.

The maker's path step 5 before the board is plugged in (or with a mistyped
``servo.port``) said ``servo fault: … cannot open …`` and exited 1, while ``mearm jog``
and ``calibrate-servos --camera`` say the same port in one line with exit 2 (bad input,
``tests/test_missing_port*.py``). On a terminal, as the command needs one.
"""

from __future__ import annotations

from pathlib import Path

from test_maker_calibrate import ROOT
from test_missing_port import NO_PORT, pty_error_line


def test_calibrate_servos_on_a_port_that_does_not_exist_is_exit_2_in_one_line(tmp_path: Path):
    out = tmp_path / "my_arm.servos.yaml"
    line = pty_error_line(
        "calibrate-servos", "--config", str(ROOT / "configs" / "sim_mearm_v1.yaml"),
        "--set", "servo.backend=serial", "--port", NO_PORT, "--output", str(out),
    )  # fmt: skip
    assert line.startswith(f"mearm calibrate-servos: error: {NO_PORT}: cannot open"), line
    assert "mearm find-port" in line and "servo fault" not in line
    assert not out.exists()
