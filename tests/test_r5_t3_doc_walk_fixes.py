"""Small fixes the round-5 doc walks found: where a note goes, what a refusal says.

- The sort's note that part of the camera's view is out of the arm's reach went to stdout
  (echoed with the routes), though stderr carries the notes (docs/getting-started.md, the
  output paragraph) and the servo-calibration note already went there as ``mearm sort:
  note: …``.
- ``--random N`` past what the table holds said only "ask for fewer": it now says how many
  fit (with the same seed, that many are placed), and the help says the bound is the
  table's.
- A board of another protocol was told to take "this checkout's firmware", which a wheel
  install has none of: the firmware the package ships, where ``mearm flash`` builds it.
- ``find-port`` whose only board runs protocol 1 ended "no mearm board found: flash one",
  under a line saying to reflash it: the remedy is to reflash that board.
- A ``socket://`` or ``rfc2217://`` port passed the config check and failed as it opened
  with pyserial's mangled message (``'debug|info|warning|error'``, ``'<=' not supported
  …``): host, TCP port and options are checked when the config loads.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from badinput import run_in_process
from conftest import ROOT
from fakeboard import FakeMearmBoard, MearmFaults

import mearm
from mearm import sort
from mearm.config import load_config
from mearm.config.errors import SerialPortError
from mearm.config.port import check_port
from mearm.data import FIRMWARE_DIR
from mearm.errors import MearmError
from mearm.hardware.errors import FirmwareVersionError
from mearm.task import random_scene

# ------------------------------------------------------------------ the reach note

V1 = ["--config", "sim_mearm_v1", "--random", "1", "--seed", "0"]


def test_the_reach_note_goes_to_stderr_as_the_sorts_note(capsys):
    """One ``mearm sort: note: …`` line on stderr, none on stdout, which ends on the outcome."""
    assert sort.main(V1) == 0
    out, err = capsys.readouterr()
    assert "note:" not in out, out
    notes = [ln for ln in err.splitlines() if "note:" in ln]
    assert len(notes) == 1 and notes[0].startswith(
        "mearm sort: note: 80% of the camera's view of the table"
    ), err
    assert "out of the arm's reach at the pick height 1.00 cm" in notes[0]
    assert out.splitlines()[-1] == "sorted 1 of 1 objects (simulated)"


def test_quiet_says_no_reach_note(capsys):
    """``--quiet``: as the servo-calibration note, not said at all."""
    assert sort.main([*V1, "--quiet"]) == 0
    out, err = capsys.readouterr()
    assert "note:" not in out + err, out + err


# ------------------------------------------------------------------ --random N past the table


def test_a_random_table_too_full_says_how_many_fit_and_that_many_do():
    config = load_config(ROOT / "configs" / "sim.yaml")
    with pytest.raises(MearmError) as err:  # (200 would grow a bin's walls into the arm)
        random_scene(config, 70, seed=0, max_tries=2000)
    found = re.search(r"could not place 70 objects .*: at most (\d+) fit .*; ask for \1 or "
                      r"fewer$", str(err.value))  # fmt: skip
    assert found is not None, str(err.value)
    most = int(found.group(1))
    assert 10 < most < 70
    assert len(random_scene(config, most, seed=0, max_tries=2000)) == most


def test_the_random_help_says_the_table_bounds_it():
    text = " ".join(sort._parser().format_help().split())
    assert "N random objects (1 to 500, as many as fit where the camera sees and the arm " \
        "reaches" in text  # fmt: skip


# ------------------------------------------------------------------ the firmware to reflash


def test_a_board_of_another_protocol_is_told_the_firmware_the_package_ships():
    """No "checkout" (a wheel install has none): the package's own folder, which exists."""
    message = str(FirmwareVersionError("/dev/ttyACM0", "mearm_servo 1.0", 1, 2))
    assert "checkout" not in message
    assert "mearm flash --port /dev/ttyACM0" in message and "mearm/data/firmware" in message
    package = Path(mearm.__file__).parent
    assert FIRMWARE_DIR == package / "data" / "firmware" and FIRMWARE_DIR.is_dir()


def test_find_port_with_only_a_protocol_1_board_says_reflash_it():
    banner = b"READY mearm_servo 1.0 5*25\n"  # before the CRC-16, as it printed it
    with FakeMearmBoard(MearmFaults(banner=False, boot_noise=b"\r\n" + banner)) as board:
        out = run_in_process(["find-port", "--only", "--port", board.port, "--timeout", "5"],
                             within_s=30)  # fmt: skip
    assert out.code == 1, out.stdout + out.stderr
    assert "mearm board of another protocol" in out.stdout
    assert "\n" not in out.line and "flash one" not in out.line, out.line
    assert out.line == (
        "mearm find-port: error: no mearm board found that speaks protocol 2: reflash the "
        f"one of another protocol on {board.port} (mearm flash --port {board.port})"
    )


# ------------------------------------------------------------------ network serial URLs


@pytest.mark.bad_input
@pytest.mark.parametrize(
    ("port", "reason"),
    [("socket://localhost:99999", "its TCP port '99999' is not 1 to 65535"),
     ("socket://localhost:0", "its TCP port '0' is not 1 to 65535"),
     ("socket://localhost:x", "its TCP port 'x' is not 1 to 65535"),
     ("socket://localhost", "names no TCP port"), ("socket://", "names no host"),
     ("SOCKET://:7000", "names no host"), ("rfc2217://[::1", "is not a URL"),
     ("rfc2217://host:70000", "is not 1 to 65535 (rfc2217://HOST:PORT)"),
     ("socket://host:7000?poll_modem", "the option 'poll_modem' is not one of socket://'s"),
     ("socket://host:7000?logging=loud", "logging='loud' is not one of debug, info"),
     ("rfc2217://host:2217?timeout=nan", "timeout='nan' is not a number of seconds")],
)  # fmt: skip
def test_a_network_port_is_checked_whole(port: str, reason: str):
    with pytest.raises(SerialPortError) as err:
        check_port(port)
    assert reason in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    "port",
    [
        "socket://localhost:1",
        "socket://[::1]:65535",
        "SOCKET://10.0.0.2:23?logging=debug",
        "rfc2217://host:2217?timeout=1.5&poll_modem&ign_set_control",
        "loop://",
    ],
)
def test_a_network_port_pyserial_opens_passes(port: str):
    assert check_port(port) == port


@pytest.mark.bad_input
@pytest.mark.parametrize(
    ("port", "says"),
    [("socket://localhost:99999", "its TCP port '99999' is not 1 to 65535"),
     ("socket://", "names no host")],
)  # fmt: skip
def test_a_bad_network_port_is_refused_when_the_config_loads(port: str, says: str):
    """One line, exit 2, naming the field and the form: not pyserial's mangled message."""
    out = run_in_process(["sort", "--set", "servo.backend=serial", "--set",
                          f"servo.port={port}"], within_s=10)  # fmt: skip
    assert out.code == 2, out.stderr
    assert out.line.startswith("mearm sort: error: --set: servo.port: "), out.line
    assert says in out.line and "HOST:PORT" in out.line and "\n" not in out.line
    assert "debug|info" not in out.line and "not supported" not in out.line
