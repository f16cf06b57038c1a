"""The maker's commands with a config for a simulated board.

``calibrate-servos`` on the virtual Uno shows the simulated arm's reading beside every
actuator's pulse, the gripper's and the tool actuator's too (measured on the board's pins,
as its joints are); on the kinematic simulator, whose gripper is only open or closed, it
says there is no reading instead of leaving a blank (through a pseudo-terminal, as
``test_maker_calibrate``). ``flash`` and ``find-port`` with the virtual Uno's config say
in one line that there is nothing to do and exit 0 (in-process); given a ``--port`` they
do their job as usual.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from badinput import run_in_process
from fakeboard import FakeMearmBoard
from test_maker_calibrate import ROOT, PtyCommand
from test_virtual_uno import cache_home  # noqa: F401  (a fixture)

from mearm.config import load_config
from mearm.hardware import ServoMap

VIRTUAL_UNO = ROOT / "configs" / "virtual_uno.yaml"


def status(name: str, unit: str, pulse: int | None = None) -> str:
    """A status line's pattern up to its reading: group 1 the pulse [µs] (or ``pulse``)."""
    at = r"(\d+)" if pulse is None else f"({pulse})"
    return rf"{name}: pulse {at} µs  step \d+ µs  \[\d+, \d+\] µs  target [-\d.]+ {unit}  "


@pytest.mark.heavy
def test_calibrate_servos_on_the_virtual_uno_reads_the_gripper_and_the_tool(
    cache_home: Path,  # noqa: F811  (the fixture imported above)
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The paper arm's wrist tool actuator and gripper: each status line shows the value
    the board's measured pulse stands for (within the virtual Uno's 10 µs tolerance),
    and it follows the keys."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))  # for PtyCommand's child
    smap = ServoMap.from_arm(load_config(VIRTUAL_UNO).arm)
    cmd = PtyCommand("calibrate-servos", "--config", str(VIRTUAL_UNO), "--set",
                     "servo.ack_timeout_s=10", "--actuators", "gripper_arm,gripper",
                     "--output", str(tmp_path / "servos.yaml"))  # fmt: skip
    try:
        for name, unit in (("gripper_arm", "deg"), ("gripper", "cm")):
            a = smap[name]
            tolerance = 10.0 / a.us_per_unit
            reading = rf"simulated arm: (-?[\d.]+) {unit}"
            shown = cmd.expect(status(name, unit) + reading, timeout=120)
            pulse = int(shown.group(1))
            assert float(shown.group(2)) == pytest.approx(a.value_of(pulse), abs=tolerance)
            cmd.send("3++")  # 40 µs on: the reading moves with the pulse
            moved = cmd.expect(status(name, unit, pulse + 40) + reading)
            assert float(moved.group(2)) == pytest.approx(a.value_of(pulse + 40), abs=tolerance)
            cmd.send("s")  # skip: nothing to fit here
        assert cmd.wait(timeout=120) == 1, cmd.text[-2000:]  # nothing calibrated: no file
    finally:
        cmd.close()
    assert "no reading" not in cmd.text


@pytest.mark.heavy
def test_calibrate_servos_says_when_the_simulator_has_no_reading(tmp_path: Path) -> None:
    """The kinematic simulator's gripper is open or closed, no opening: the status line
    says there is no reading where the joints show theirs."""
    cmd = PtyCommand("calibrate-servos", "--config", str(ROOT / "configs" / "sim.yaml"),
                     "--actuators", "gripper", "--output", str(tmp_path / "s.yaml"))  # fmt: skip
    try:
        cmd.expect(
            status("gripper", "cm")
            + r"simulated arm: no reading of gripper \(not measured by this simulator\)"
        )
        cmd.send("q")
        assert cmd.wait() == 1
    finally:
        cmd.close()


NOTHING_TO_FLASH = re.compile(
    r"^flash: nothing to do: the config's board is the virtual Uno \(servo\.backend: "
    r"virtual_uno\), which runs the firmware built from .+ each time a command starts it; "
    r"--port flashes a real board$"
)
NO_PORT_TO_FIND = re.compile(
    r"^find-port: nothing to do: the config's board is the virtual Uno \(servo\.backend: "
    r"virtual_uno\), .* there is no port to find or set$"
)


@pytest.mark.parametrize("dry_run", [[], ["--dry-run"]])
def test_flash_with_the_virtual_uno_says_there_is_nothing_to_flash(tmp_path, dry_run):
    """One line on stdout, exit 0, nothing built (no build folder), nothing on stderr."""
    build = tmp_path / "build"
    out = run_in_process(["flash", "--config", "virtual_uno", "--build-dir", build, *dry_run])
    assert out.code == 0, out.stdout + out.stderr
    assert out.stdout.count("\n") == 1 and NOTHING_TO_FLASH.match(out.stdout.strip())
    assert out.stderr == "" and not build.exists()


def test_flash_with_the_virtual_uno_and_a_port_flashes_that_port(tmp_path):
    """A --port names a real board: its commands are printed as for any config."""
    out = run_in_process(["flash", "--config", "virtual_uno", "--dry-run", "--port",
                          "/dev/ttyACM3", "--build-dir", tmp_path / "b"])  # fmt: skip
    assert out.code == 0 and "nothing to do" not in out.stdout
    assert " -P /dev/ttyACM3 " in out.stdout.splitlines()[1]


@pytest.mark.parametrize("replug", [[], ["--replug"]])
def test_find_port_with_the_virtual_uno_says_there_is_no_port_to_find(replug):
    """One line on stdout, exit 0, no port listed or opened; with --replug no prompt (and
    no terminal needed)."""
    out = run_in_process(["find-port", "--config", "virtual_uno", *replug])
    assert out.code == 0, out.stdout + out.stderr
    assert out.stdout.count("\n") == 1 and NO_PORT_TO_FIND.match(out.stdout.strip())
    assert out.stderr == ""


def test_find_port_with_the_virtual_uno_and_a_port_tries_that_port():
    """A --port is tried as for any config: the fake Uno on it is named."""
    with FakeMearmBoard() as board:
        out = run_in_process(["find-port", "--config", "virtual_uno", "--only", "--port",
                              board.port, "--timeout", "5"], within_s=12)  # fmt: skip
    assert out.code == 0, out.stdout + out.stderr
    assert "mearm board: mearm_servo 2.0" in out.stdout


def test_a_board_refused_at_the_handshake_is_not_said_to_have_stopped(cache_home):  # noqa: F811
    """An arm on a channel the virtual Uno lacks: the firmware answered, the host turned
    it down; the line says why, not that the simulator stopped (with simavr's load
    message, ``Loaded 132 .data``, as its reason)."""
    out = run_in_process(
        ["sort", "--config", "virtual_uno", "--quiet",
         "--set", "arm.tool.gripper.servo.channel=5"]
    )  # fmt: skip
    assert out.code == 2, out.stdout + out.stderr
    assert "the config uses servo channel 5, the board drives channels 0..4" in out.line
    assert "stopped" not in out.line and "Loaded" not in out.line, out.line
