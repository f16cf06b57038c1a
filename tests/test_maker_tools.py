"""The maker's commands: find-port, flash, find-camera and init-config.

find-port talks to pty-backed boards with real pyserial: the fake Uno of the backend's
tests, and — when simavr and the AVR toolchain are installed — the real firmware in
simavr. Its interactive ``--replug`` is driven through a pseudo-terminal with real
keystrokes. flash is checked argument by argument against the Uno's upload settings and
the firmware's Makefile, and run for real with a stand-in avrdude. find-camera runs where
there is no camera, and on a recorded video given as the source.
"""

from __future__ import annotations

import os
import pty
import re
import select
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import ROOT, firmware_build, require_tool, simulator_build
from fakeboard import FakeMearmBoard, MearmFaults, SimavrBoard

from mearm.config import load_config
from mearm.exceptions import MearmError
from mearm.maker import find_port, flash, init_config

BOARDS_TXT = Path("/usr/share/arduino/hardware/arduino/avr/boards.txt")


def run_tool(module: str, *args: str, env: dict[str, str] | None = None, cwd: Path = ROOT):
    """``python -m mearm.maker.<module> ARGS`` as a user runs it, text output captured."""
    return subprocess.run(
        [sys.executable, "-m", f"mearm.maker.{module}", *args],
        capture_output=True, text=True, timeout=120, cwd=cwd, env=env,
    )  # fmt: skip


#: Each tool's subcommand of ``mearm``, for :func:`run_here`.
SUBCOMMAND = {
    "find_port": "find-port",
    "flash": "flash",
    "find_camera": "find-camera",
    "init_config": "init-config",
}


def run_here(
    module: str, *args: str, path: str | None = None, cwd: Path = ROOT
) -> subprocess.CompletedProcess:
    """:func:`run_tool` in this process: the command's ``main`` under the guard every
    command shares (exit code, stdout, stderr), without an interpreter start (0.6 s of CPU
    each). ``path``: the PATH the command sees. Each command keeps tests through
    :func:`run_tool` (or a terminal) for what only a process shows."""
    import contextlib

    from badinput import run_in_process

    with pytest.MonkeyPatch.context() as patch, contextlib.chdir(cwd):
        if path is not None:
            patch.setenv("PATH", path)
        out = run_in_process([SUBCOMMAND[module], *args], within_s=12)
    return subprocess.CompletedProcess([module, *args], out.code, out.stdout, out.stderr)


def one_error_line(result: subprocess.CompletedProcess, code: int = 2) -> str:
    """The single stderr line of a refused command (no traceback)."""
    assert result.returncode == code, result.stdout + result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    return lines[0]


def line_of(stdout: str, port: str) -> str:
    """The report line of ``port``."""
    found = [ln for ln in stdout.splitlines() if ln.strip().startswith(port + " ")]
    assert len(found) == 1, stdout
    return found[0]


# --------------------------------------------------------------------------- find-port


@pytest.mark.heavy
def test_find_port_names_the_fake_board_and_says_what_the_others_are():
    """The mearm board is named with its firmware; other ports say what they are."""
    with (
        FakeMearmBoard() as board,
        FakeMearmBoard(name="grbl") as other_firmware,
        FakeMearmBoard(
            MearmFaults(banner=False, boot_noise=b"Grbl 1.1h ['$' for help]\r\n")
        ) as chatty,
    ):
        silent_master, silent_slave = os.openpty()
        silent = os.ttyname(silent_slave)
        try:
            t0 = time.monotonic()
            result = run_here(
                "find_port", "--only", "--timeout", "1",
                "--port", board.port, "--port", other_firmware.port, "--port", chatty.port,
                "--port", silent,
            )  # fmt: skip
            elapsed = time.monotonic() - t0
        finally:
            os.close(silent_master)
            os.close(silent_slave)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    out = result.stdout
    assert line_of(out, board.port).endswith(
        "mearm board: mearm_servo 2.0, 5 servos, pulses 500..2500 µs"
    )
    assert "its banner names firmware 'grbl'" in line_of(out, other_firmware.port)
    assert 'not a mearm board: no mearm banner in 1 s; heard b"Grbl 1.1h' in line_of(
        out, chatty.port
    )
    assert "not a mearm board: silent for 1 s" in line_of(out, silent)
    assert f"set servo.port: {board.port} in your config" in out
    assert board.opens == 1 and board.received[-1].startswith(b"0 V*")
    assert elapsed < 20  # the ports are listened to at once, not one after the other


@pytest.mark.heavy
def test_find_port_without_a_mearm_board_exits_1():
    """Only a board without the banner: the job was not done, exit 1 with one line."""
    with FakeMearmBoard(MearmFaults(banner=False)) as board:
        result = run_here("find_port", "--only", "--timeout", "0.5", "--port", board.port)
    assert "silent for 0.5 s" in line_of(result.stdout, board.port)
    assert "no mearm board found" in one_error_line(result, code=1)


@pytest.mark.heavy
@pytest.mark.parametrize(
    ("count", "config", "words"),
    [
        (15, [], "the board reports 15 servo channels; a move to that many does not fit"),
        (3, ["--config", "lab"], "the config uses servo channel 4, the board drives channels 0..2"),
    ],
)
def test_find_port_does_not_name_a_board_the_commands_refuse(count, config, words):
    """find-port said "set servo.port" (exit 0) for a board every other command then
    refused at its handshake: too many channels for a move's line, or too few for the
    config's servos."""
    with FakeMearmBoard(servo_count=count) as board:
        args = ["--only", "--timeout", "1", "--port", board.port, *config]
        result = run_here("find_port", *args)
    line = one_error_line(result, code=1)
    assert f"can use: {board.port}: {words}" in line, line
    assert "set servo.port" not in result.stdout


@pytest.mark.heavy
def test_find_port_reports_missing_and_refused_ports():
    """A port that does not exist, or a refused URL scheme, is bad input (exit 2)."""
    missing = one_error_line(run_here("find_port", "--only", "--port", "/dev/ttyNOPE9"))
    assert "--port /dev/ttyNOPE9 does not exist" in missing
    refused = one_error_line(run_here("find_port", "--port", "spy:///tmp/log"))
    assert "spy:///tmp/log" in refused and "not allowed" in refused
    assert "--timeout" in one_error_line(run_here("find_port", "--timeout", "0"))


def test_list_serial_ports_adds_given_ports_that_exist(tmp_path):
    """--port candidates join the list while their path exists; a link counts (by-id)."""
    with FakeMearmBoard() as board:
        link = tmp_path / "ttyLINK"
        link.symlink_to(board.port)
        dangling = tmp_path / "ttyGONE"
        dangling.symlink_to(tmp_path / "nothing")
        ports = find_port.list_serial_ports(
            [board.port, str(link), str(dangling), "socket://localhost:9"], system=False
        )
    assert [p.device for p in ports] == [board.port, str(link), "socket://localhost:9"]


def test_replug_finds_the_port_that_came_back_under_a_new_name():
    """Unplug: ttyACM0 goes; replug: it comes back as ttyACM1 (the old one was held)."""
    lists = iter([{"/dev/ttyS0", "/dev/ttyACM0"}, {"/dev/ttyS0"}, {"/dev/ttyS0"},
                  {"/dev/ttyS0", "/dev/ttyACM1"}])  # fmt: skip
    prompts: list[str] = []
    result = find_port.replug(lambda: next(lists), prompts.append, wait_s=5, poll_s=0.01)
    assert result == find_port.ReplugResult(gone=("/dev/ttyACM0",), new=("/dev/ttyACM1",))
    assert [p.split(",")[0] for p in prompts] == [
        "Unplug the board's USB cable", "Plug it back in"
    ]  # fmt: skip


def test_replug_with_nothing_changing_finds_nothing():
    """No port went or came: nothing is found, after waiting the given time only."""
    t0 = time.monotonic()
    result = find_port.replug(lambda: {"/dev/ttyS0"}, lambda text: None, wait_s=0.3, poll_s=0.05)
    assert result == find_port.ReplugResult(gone=(), new=())
    assert 0.3 <= time.monotonic() - t0 < 30  # waited the given time; the bound: no hang


class Terminal:
    """A command run on a pseudo-terminal (its controlling terminal), as a person runs it."""

    def __init__(self, *args: str):
        pid, fd = pty.fork()
        if pid == 0:  # the child: becomes the command
            os.chdir(ROOT)
            os.execv(sys.executable, [sys.executable, *args])
        self.pid, self.fd = pid, fd
        self.output = ""

    def expect(self, text: str, timeout: float = 20.0) -> None:
        """Read the screen until ``text`` appears."""
        deadline = time.monotonic() + timeout
        while text not in self.output:
            left = deadline - time.monotonic()
            assert left > 0, f"{text!r} never appeared; the screen: {self.output!r}"
            ready, _, _ = select.select([self.fd], [], [], left)
            if ready:
                try:
                    chunk = os.read(self.fd, 4096)
                except OSError:  # the command ended
                    chunk = b""
                assert chunk, f"ended before {text!r}; the screen: {self.output!r}"
                self.output += chunk.decode("utf-8", "replace")

    def type(self, keys: bytes) -> None:
        """Press keys (``b"\\r"`` is Enter, ``b"\\x03"`` Ctrl-C)."""
        os.write(self.fd, keys)

    def wait(self, timeout: float = 30.0) -> int:
        """Read to the end; the exit status (a signal: 128 + its number)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            ready, _, _ = select.select([self.fd], [], [], 0.1)
            if ready:
                try:
                    chunk = os.read(self.fd, 4096)
                except OSError:
                    chunk = b""
                self.output += chunk.decode("utf-8", "replace")
            pid, status = os.waitpid(self.pid, os.WNOHANG)
            if pid:
                os.close(self.fd)
                return os.waitstatus_to_exitcode(status) % 256
        os.kill(self.pid, signal.SIGKILL)
        os.waitpid(self.pid, 0)
        os.close(self.fd)
        raise AssertionError(f"still running after {timeout} s; the screen: {self.output!r}")


@pytest.mark.heavy
def test_replug_on_a_terminal_finds_the_board_that_was_unplugged_and_replugged(tmp_path):
    """Keystrokes on a pty: unplug (the link goes), Enter, replug (a new board), Enter."""
    link = tmp_path / "ttyUSB_by_id"
    first = FakeMearmBoard()
    link.symlink_to(first.port)
    term = Terminal(
        "-m", "mearm.maker.find_port", "--replug", "--only", "--port", str(link),
        "--timeout", "2", "--wait", "5",
    )  # fmt: skip
    term.expect("Unplug the board's USB cable, then press Enter")
    first.close()
    link.unlink()
    term.type(b"\r")
    term.expect("Plug it back in, then press Enter")
    with FakeMearmBoard() as second:
        link.symlink_to(second.port)
        term.type(b"\r")
        code = term.wait()
    assert code == 0, term.output
    assert f"the board is on {link}" in term.output
    assert "mearm board: mearm_servo 2.0, 5 servos" in term.output
    assert second.opens == 1


@pytest.mark.heavy
def test_replug_on_a_terminal_reports_a_board_without_firmware_and_how_to_flash_it(tmp_path):
    """The replugged board is found even without the banner; flash is suggested."""
    link = tmp_path / "ttyACM_link"
    term = Terminal(
        "-m", "mearm.maker.find_port", "--replug", "--only", "--port", str(link),
        "--timeout", "0.5", "--wait", "5",
    )  # fmt: skip
    term.expect("Unplug")
    term.type(b"\r")
    term.expect("Plug it back in")
    with FakeMearmBoard(MearmFaults(banner=False)) as board:
        link.symlink_to(board.port)
        term.type(b"\r")
        code = term.wait()
    assert code == 0, term.output
    assert f"the board is on {link}" in term.output
    assert f"mearm flash --port {link}" in term.output


@pytest.mark.heavy
def test_replug_on_a_terminal_with_nothing_replugged_exits_1_and_ctrl_c_exits_130(tmp_path):
    """Nothing came back: exit 1 with the reason. Ctrl-C at a prompt: exit 130."""
    gone = tmp_path / "ttyGONE"
    term = Terminal(
        "-m", "mearm.maker.find_port", "--replug", "--only", "--port", str(gone), "--wait", "0.3"
    )
    term.expect("Unplug")
    term.type(b"\r")
    term.expect("Plug it back in")
    term.type(b"\r")
    assert term.wait() == 1
    assert "no board found: no port went away or came back" in term.output
    assert "Traceback" not in term.output

    term = Terminal("-m", "mearm.maker.find_port", "--replug", "--only", "--port", str(gone))
    term.expect("Unplug")
    term.type(b"\x03")
    assert term.wait() == 130
    assert "interrupted" in term.output and "Traceback" not in term.output


@pytest.mark.heavy
def test_replug_without_a_terminal_is_refused():
    """Standard input not a terminal: exit 2 before any prompt, one line saying why."""
    result = subprocess.run(
        [sys.executable, "-m", "mearm.maker.find_port", "--replug"],
        stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60, cwd=ROOT,
    )  # fmt: skip
    assert "needs a terminal" in one_error_line(result)
    assert "Unplug" not in result.stdout


# --------------------------------------------------------------------------- the real firmware


@pytest.fixture(scope="module")
def built_firmware(tmp_path_factory) -> Path:
    """The firmware built from the checkout, as flash builds it (once per test run): the
    build folder (flash finds it up to date and builds nothing more)."""
    return firmware_build(tmp_path_factory)


@pytest.mark.heavy
def test_find_port_names_the_real_firmware_in_simavr(tmp_path_factory):
    """The real firmware (simavr behind a pty): named by its banner and its V reply. (In
    this process: the replug tests run find-port as a process on a terminal.)"""
    build = simulator_build(tmp_path_factory)
    sim, elf = build / "mearm_sim", build / "mearm_servo.elf"
    with SimavrBoard(str(sim), str(elf)) as chip:
        found = run_here("find_port", "--only", "--timeout", "5", "--port", chip.port)
    assert found.returncode == 0, found.stdout + found.stderr
    assert line_of(found.stdout, chip.port).endswith(
        "mearm board: mearm_servo 2.0, 5 servos, pulses 500..2500 µs"
    )


# --------------------------------------------------------------------------- flash


def _boards_txt_uno() -> dict[str, str]:
    values = {}
    for line in BOARDS_TXT.read_text().splitlines():
        m = re.match(r"^uno\.(build\.mcu|upload\.protocol|upload\.speed)=(.+)$", line)
        if m:
            values[m.group(1)] = m.group(2).strip()
    return values


@pytest.mark.heavy
def test_flash_dry_run_prints_the_uno_upload_command_and_builds_nothing(tmp_path):
    """Every avrdude argument: the Uno's MCU, programmer, speed; the port; the hex built."""
    build = tmp_path / "build"
    result = run_here("flash", "--dry-run", "--port", "/dev/ttyACM3", "--build-dir", str(build))
    assert result.returncode == 0, result.stderr
    lines = [ln for ln in result.stdout.splitlines() if not ln.startswith("#")]
    make, avrdude = (shlex.split(ln) for ln in lines)
    source = ROOT / "tools" / "arduino"
    assert make == ["make", "-C", str(source), f"BUILD_DIR={build.resolve()}"]
    hex_file = build.resolve() / "mearm_servo.hex"
    assert avrdude == [
        "avrdude", "-p", "atmega328p", "-c", "arduino", "-P", "/dev/ttyACM3", "-b", "115200",
        "-D", "-U", f"flash:w:{hex_file}:i",
    ]  # fmt: skip
    assert not build.exists()  # nothing was built
    if BOARDS_TXT.is_file():  # the Arduino core's own settings for the Uno
        uno = _boards_txt_uno()
        assert avrdude[avrdude.index("-p") + 1] == uno["build.mcu"]
        assert avrdude[avrdude.index("-c") + 1] == uno["upload.protocol"]
        assert avrdude[avrdude.index("-b") + 1] == uno["upload.speed"]


@pytest.mark.heavy
def test_flash_dry_run_agrees_with_the_makefiles_upload_target(tmp_path):
    """``make -n upload`` of tools/arduino prints the same avrdude command."""
    require_tool("make")
    build = tmp_path / "b"
    ours = run_here("flash", "--dry-run", "--port", "/dev/ttyUSB2", "--build-dir", str(build))
    upload = shlex.split(ours.stdout.splitlines()[1])
    made = subprocess.run(
        ["make", "-n", "-C", str(ROOT / "tools" / "arduino"), "upload", "PORT=/dev/ttyUSB2",
         f"BUILD_DIR={build.resolve()}", "-o", f"{build.resolve()}/mearm_servo.hex"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    theirs = [shlex.split(ln) for ln in made.stdout.splitlines() if ln.startswith("avrdude ")]
    assert theirs == [upload]


@pytest.mark.heavy
def test_flash_dry_run_takes_the_port_from_the_config_and_the_old_bootloader_baud():
    """No --port: servo.port of the config; --upload-baud 57600 for old bootloaders."""
    result = run_here(
        "flash", "--dry-run", "--set", "servo.port=/dev/ttyUSB7", "--upload-baud", "57600"
    )
    avrdude = shlex.split(result.stdout.splitlines()[1])
    assert avrdude[avrdude.index("-P") + 1] == "/dev/ttyUSB7"
    assert avrdude[avrdude.index("-b") + 1] == "57600"
    assert "--upload-baud" in one_error_line(run_here("flash", "--upload-baud", "9600"))


@pytest.mark.heavy
def test_flash_refuses_a_port_that_is_not_a_device():
    """A URL or an option-like port cannot be an avrdude port: exit 2, one line."""
    for port in ("socket://localhost:5000", "-x"):
        line = one_error_line(run_here("flash", "--dry-run", f"--port={port}"))
        assert "--port must be the board's device path" in line


@pytest.mark.heavy
def test_flash_with_tools_missing_names_the_debian_packages(tmp_path):
    """Nothing on PATH: one line naming every missing package, exit 2, nothing built."""
    build = tmp_path / "build"
    result = run_here("flash", "--port", "/dev/ttyACM0", "--build-dir", str(build),
                      path=str(tmp_path))  # fmt: skip
    line = one_error_line(result)
    assert "sudo apt-get install make gcc-avr binutils-avr" in line and "avrdude" in line
    assert not build.exists()
    dry = run_here("flash", "--dry-run", "--build-dir", str(build), path=str(tmp_path))
    assert dry.returncode == 0 and "note: not installed: make (make)" in dry.stderr


FAKE_AVRDUDE = """#!/bin/sh
# stands in for avrdude: records its arguments and checks the image is Intel hex
printf '%s\\n' "$@" > "{log}"
for a in "$@"; do case "$a" in flash:w:*:i) f="${{a#flash:w:}}"; f="${{f%:i}}";; esac; done
head -c 1 "$f" | grep -q ':' || {{ echo "not an Intel hex file: $f" >&2; exit 1; }}
exit {code}
"""


def _fake_avrdude(folder: Path, code: int) -> tuple[dict[str, str], Path]:
    folder.mkdir()
    log = folder / "argv.txt"
    script = folder / "avrdude"
    script.write_text(FAKE_AVRDUDE.format(log=log, code=code))
    script.chmod(0o755)
    return {**os.environ, "PATH": f"{folder}:{os.environ['PATH']}"}, log


@pytest.mark.heavy
def test_flash_builds_uploads_and_checks_the_banner(built_firmware, tmp_path):
    """The build runs, avrdude gets the built hex, then the board's banner is awaited."""
    env, log = _fake_avrdude(tmp_path / "bin", 0)
    with FakeMearmBoard() as board:
        result = run_tool(
            "flash", "--port", board.port, "--build-dir", str(built_firmware), env=env
        )
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    assert log.read_text().split("\n")[:-1] == [
        "-p", "atmega328p", "-c", "arduino", "-P", board.port, "-b", "115200", "-D",
        "-U", f"flash:w:{built_firmware.resolve()}/mearm_servo.hex:i",
    ]  # fmt: skip
    assert f"the board on {board.port} runs the mearm firmware" in result.stdout
    assert board.opens == 1


@pytest.mark.heavy
def test_flash_fails_when_the_upload_fails_or_no_banner_follows(built_firmware, tmp_path):
    """avrdude failing → exit 1 with what to check; an upload without a banner → exit 1.
    In this process; ``test_flash_builds_uploads_and_checks_the_banner`` runs flash as one."""
    env, _ = _fake_avrdude(tmp_path / "bin_fail", 1)
    with FakeMearmBoard() as board:  # a port that exists (a missing one is bad input)
        failed = run_here("flash", "--port", board.port, "--build-dir", str(built_firmware),
                          path=env["PATH"])  # fmt: skip
    assert failed.returncode == 1 and "the upload failed (exit 1" in failed.stderr
    env, _ = _fake_avrdude(tmp_path / "bin_ok", 0)
    with FakeMearmBoard(MearmFaults(banner=False)) as board:
        silent = run_here("flash", "--port", board.port, "--build-dir", str(built_firmware),
                          "--set", "servo.banner_timeout_s=0.5", path=env["PATH"])  # fmt: skip
    assert silent.returncode == 1
    assert "does not print the mearm banner" in silent.stderr


@pytest.mark.heavy
@pytest.mark.parametrize(
    ("faults", "count", "words"),
    [
        (MearmFaults(v_reply=b""), 6, "printed the banner but did not answer V"),
        (MearmFaults(), 3, "the config uses servo channel 4, the board drives channels 0..2"),
    ],
)
def test_flash_does_not_name_a_board_the_config_cannot_use(
    built_firmware, tmp_path, faults, count, words
):
    """flash said "set servo.port: PORT in your config" (exit 0) for a board that printed
    the banner but did not answer V, or whose channels the config's servos do not fit:
    every command after it then refused that board at its handshake (find-port says so)."""
    env, _ = _fake_avrdude(tmp_path / "bin", 0)
    with FakeMearmBoard(faults, servo_count=count) as board:
        result = run_here("flash", "--port", board.port, "--build-dir", str(built_firmware),
                          "--config", "lab", "--set", f"servo.port={board.port}",
                          "--set", "servo.banner_timeout_s=1", path=env["PATH"])  # fmt: skip
    line = one_error_line(result, code=1)
    assert f"cannot use it: {board.port}" in line and words in line, line
    assert "set servo.port" not in result.stdout


def test_firmware_source_dir_is_the_checkouts():
    """From the checkout, the firmware is tools/arduino (Makefile and sketch)."""
    assert flash.firmware_source_dir() == ROOT / "tools" / "arduino"


def test_missing_data_is_one_line_saying_where(tmp_path, monkeypatch):
    """Without the shipped firmware or configs: a named error that says where it looked."""
    from mearm import data

    monkeypatch.setattr(data, "FIRMWARE_DIR", tmp_path / "firmware")
    monkeypatch.setattr(flash, "firmware_source_dir", data.firmware_source_dir)
    monkeypatch.setattr(data, "CONFIGS_DIR", tmp_path / "configs")
    with pytest.raises(MearmError, match="firmware source is not installed"):
        flash.firmware_source_dir()
    with pytest.raises(MearmError, match="reference configs are not installed"):
        init_config.reference_config_dir()


# --------------------------------------------------------------------------- find-camera


@pytest.mark.heavy
def test_find_camera_without_a_camera_exits_1(tmp_path):
    """Sources that are no camera (a device that is not one, an index with nothing on
    it): each says why, exit 1, no snapshot folder made. (In this process: the
    newcomer walks run find-camera as a process.)"""
    out = tmp_path / "snaps"
    result = run_here("find_camera", "--out", str(out), "--camera", "/dev/null", "--camera", "15")
    assert "no camera: cannot open it" in result.stdout
    assert "no cameras found (tried /dev/null, 15)" in one_error_line(result, code=1)
    assert not out.exists()


@pytest.mark.skipif(
    any(re.fullmatch(r"video\d+", p.name) for p in Path("/dev").glob("video*")),
    reason="this machine has cameras",
)
@pytest.mark.heavy
def test_find_camera_scan_on_a_machine_without_cameras_exits_1(tmp_path):
    """The default scan (indices 0, 1 and /dev/video*) finds nothing here: exit 1."""
    result = run_here("find_camera", "--out", str(tmp_path / "s"))
    assert "trying 2 camera sources" in result.stdout
    assert "no cameras found" in one_error_line(result, code=1)


@pytest.mark.skipif(
    any(re.fullmatch(r"video\d+", p.name) for p in Path("/dev").glob("video*")),
    reason="this machine has cameras",
)
def test_find_camera_with_nothing_to_try_exits_2(tmp_path):
    """--indices 0 on a machine without /dev/video*: nothing to try is bad input, not a
    camera not found."""
    result = run_here("find_camera", "--indices", "0", "--out", str(tmp_path / "s"))
    line = one_error_line(result, code=2)
    assert "--indices 0 and no /dev/video* device" in line and "--camera SOURCE" in line
    assert not (tmp_path / "s").exists()


@pytest.mark.heavy
def test_find_camera_saves_a_snapshot_and_prints_the_resolution(tmp_path):
    """A recorded video as the source: its size is printed and its first frame saved."""
    video = tmp_path / "table.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 10, (320, 240))
    first = np.zeros((240, 320, 3), np.uint8)
    first[:, :160] = (0, 0, 200)  # red left half, blue right half (BGR)
    first[:, 160:] = (200, 0, 0)
    writer.write(first)
    writer.write(np.full((240, 320, 3), 255, np.uint8))
    writer.release()
    out = tmp_path / "snaps"
    result = run_here("find_camera", "--out", str(out), "--camera", str(video))
    assert result.returncode == 0, result.stderr
    assert "camera: 320x240 px, snapshot" in result.stdout
    assert f"camera.kind: file, camera.path: {video}" in result.stdout
    (snap,) = out.iterdir()
    saved = cv2.imread(str(snap))
    assert saved.shape == (240, 320, 3)
    assert np.abs(saved.astype(int) - first).mean() < 8  # the first frame, not the white one


@pytest.mark.heavy
def test_find_camera_refuses_bad_input(tmp_path):
    """Too many indices, or --out naming a file: exit 2 with one line."""
    assert "--indices" in one_error_line(run_here("find_camera", "--indices", "99"))
    file = tmp_path / "f"
    file.write_text("x")
    assert "not a folder" in one_error_line(run_here("find_camera", "--out", str(file)))


# --------------------------------------------------------------------------- init-config

RIGS = init_config.RIGS
VALID = [
    (arm, rig)
    for arm in init_config.ARMS
    for rig in init_config.RIGS
    if not (arm == "desk_5dof" and rig == "uno")
]


@pytest.mark.parametrize(("arm", "rig"), VALID)
def test_init_config_writes_a_config_that_loads_with_the_reference_arm(tmp_path, arm, rig):
    """Every arm on every rig it fits: loads, has the reference's arm, drives that rig."""
    out = tmp_path / "mine.yaml"
    assert init_config.main(["--arm", arm, "--rig", rig, str(out)]) == 0
    config = load_config(out)
    choice = init_config.ARMS[arm]
    reference = load_config(ROOT / "configs" / init_config.reference_file(choice, RIGS[rig]))
    assert config.arm == reference.arm
    assert config.task == reference.task
    backend = {"sim": "sim", "sim_mujoco": "sim", "uno": "serial", "ssc32": "ssc32"}[rig]
    assert config.servo.backend == backend
    assert config.simulator == ("mujoco" if rig == "sim_mujoco" else "kinematic")
    assert config.camera.kind == ("sim" if rig.startswith("sim") else "device")
    text = out.read_text()
    assert f"--arm {arm} --rig {rig}" in text
    assert sum(ln.lstrip().startswith("#") for ln in text.splitlines()) >= 15
    if rig == "uno":
        channels = init_config._servo_channels(config)
        assert max(channels) < init_config.UNO_SERVO_COUNT
        assert "mearm flash" in text


@pytest.mark.parametrize(("arm", "rig"), [(a, r) for a, r in VALID if RIGS[r].real])
def test_init_config_says_how_tall_a_real_rigs_bins_may_be(tmp_path, arm, rig):
    """A real rig's bins are the maker's: the note's example loads, and each class's
    highest height loads where 0.1 cm more is refused."""
    out = tmp_path / "mine.yaml"
    assert init_config.main(["--arm", arm, "--rig", rig, str(out)]) == 0
    text = out.read_text()
    example = re.search(r"--set\s+(?:#\s*)?(task\.classes\.\w+\.bin_height_cm=\S+)\)", text)
    most = re.search(r"^  # At most, in cm \(.*\): (.*)\.$", text, re.M)
    assert example is not None and most is not None, text
    assert load_config(out, [example.group(1)]).task.classes[0].bin_height_cm is not None
    for item in most.group(1).split(", "):
        name, cm = item.split()
        assert load_config(out, [f"task.classes.{name}.bin_height_cm={cm}"])
        with pytest.raises(MearmError, match=f"bin_height_cm: {float(cm) + 0.1:g} cm walls"):
            load_config(out, [f"task.classes.{name}.bin_height_cm={float(cm) + 0.1:g}"])


def test_init_config_sim_is_the_reference_file_with_a_header(tmp_path):
    """On the simulated rig the reference config is copied whole, comments included."""
    out = tmp_path / "paper.yaml"
    init_config.main(["--arm", "paper", "--rig", "sim", str(out)])
    assert out.read_text().endswith((ROOT / "configs" / "sim.yaml").read_text())


def test_init_config_names_the_arm_and_how_to_change_it(tmp_path):
    """The header names the arm's file and shows a change that loads as written."""
    out = tmp_path / "mine.yaml"
    init_config.main(["--arm", "mearm_v1", "--rig", "ssc32", str(out)])
    text = out.read_text()
    assert "configs/arms/mearm_v1.yaml" in text and "  use: mearm_v1\n" in text
    example = re.search(r"^#   (arm: .*)$", text, re.M)
    assert example is not None
    changed = tmp_path / "changed.yaml"
    changed.write_text(text.replace("arm:\n  use: mearm_v1\n", example.group(1) + "\n"))
    assert load_config(changed).arm.joints[1].dh.a_cm == 8.2


@pytest.mark.parametrize("existing", ["sim_mearm_v1.yaml", None])
@pytest.mark.heavy
def test_init_config_refuses_a_folder_where_its_extends_names_another_file(tmp_path, existing):
    """The twin's starter config extends the packaged sim_mearm_v1.yaml: not beside a file
    of that name, nor under that name itself (it would extend itself)."""
    if existing:
        (tmp_path / existing).write_text("# mine\n")
    out = tmp_path / ("x.yaml" if existing else "sim_mearm_v1.yaml")
    # run in the folder, the file named relative to it: the line names the file and its
    # folder, and a long temporary path (an xdist worker's) would cut the line's advice
    line = one_error_line(
        run_here("init_config", "--arm", "mearm_v1", "--rig", "sim_mujoco", out.name, cwd=tmp_path)
    )
    assert "extends the packaged sim_mearm_v1.yaml" in line and "another folder" in line
    assert not out.exists() or out.read_text() == "# mine\n"


@pytest.mark.heavy
def test_init_config_refuses_an_arm_with_more_servos_than_the_uno_drives(tmp_path):
    """desk_5dof has six servos, the Uno firmware five: exit 2 naming the way out."""
    out = tmp_path / "desk.yaml"
    result = run_tool("init_config", "--arm", "desk_5dof", "--rig", "uno", str(out))
    line = one_error_line(result)
    assert "channels 0, 1, 2, 3, 4, 5" in line and "--rig ssc32" in line
    assert not out.exists()


@pytest.mark.heavy
def test_init_config_refuses_to_overwrite_without_force(tmp_path):
    """An existing file stays as it was unless --force; with it, it is replaced, and the
    maker's edits are kept as FILE.bak (as calibrate-servos keeps its file)."""
    out = tmp_path / "mine.yaml"
    out.write_text("# my edits\n")
    args = ("init_config", "--arm", "mearm_v1", "--rig", "ssc32", str(out))
    line = one_error_line(run_here(*args))
    assert "exists: pass --force to replace it" in line
    assert out.read_text() == "# my edits\n"
    forced = run_here(*args, "--force")
    assert forced.returncode == 0, forced.stderr
    assert load_config(out).servo.backend == "ssc32"
    assert f"mearm calibrate-servos --config {out}" in forced.stdout
    assert (tmp_path / "mine.yaml.bak").read_text() == "# my edits\n"
    again = run_here(*args, "--force")  # the file already holds what it writes
    assert again.returncode == 0, again.stderr
    assert ".bak" not in again.stdout
    assert (tmp_path / "mine.yaml.bak").read_text() == "# my edits\n"  # not lost


@pytest.mark.heavy
def test_init_config_lists_the_choices_and_refuses_missing_ones():
    """--list names every arm and rig; without --arm, --rig or a file: exit 2."""
    listed = run_here("init_config", "--list")
    assert listed.returncode == 0
    for name in [*init_config.ARMS, *init_config.RIGS]:
        assert re.search(rf"^  {name}\s", listed.stdout, re.M), name
    line = one_error_line(run_here("init_config", "--arm", "paper"))
    assert "needs FILE, --rig" in line
    assert "invalid choice" in one_error_line(run_here("init_config", "--arm", "x", "f.yaml"))


def test_uno_servo_count_is_the_firmwares():
    """The channel check uses the count the firmware is built with."""
    ino = (flash.firmware_source_dir() / "mearm_servo" / "mearm_servo.ino").read_text()
    assert f"#define SERVO_COUNT {init_config.UNO_SERVO_COUNT}\n" in ino


def test_split_blocks_cuts_every_reference_config_without_losing_a_byte():
    """Joined back, the blocks are the file; each key block starts at its comments."""
    for path in sorted((ROOT / "configs").glob("*.yaml")):
        text = path.read_text()
        blocks = init_config.split_blocks(text)
        assert "".join(b.text for b in blocks) == text, path.name
        for b in blocks[1:] if blocks[0].key == "" else blocks:
            first = next(ln for ln in b.text.splitlines() if not ln.startswith("#"))
            assert first.startswith(f"{b.key}:"), (path.name, b.key)


def test_reference_config_dir_is_the_checkouts():
    """From the checkout, the reference configs are configs/."""
    assert init_config.reference_config_dir() == ROOT / "configs"
    with pytest.raises(MearmError, match="exists"):
        init_config.main(["--arm", "paper", "--rig", "sim", str(ROOT / "configs" / "sim.yaml")])
