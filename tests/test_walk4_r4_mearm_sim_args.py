"""``mearm_sim`` run by hand (tools/arduino/PROTOCOL.md) with a wrong file or option.

Exit 2 and one line naming what was wrong. The ``.hex`` beside the ``.elf`` (the build's
main output, the one a user would reach for) used to be loaded and run as garbage until
the simulated chip stopped: exit 1, "the AVR stopped (state 7)"; a missing file printed
three lines (simavr's two and ours), an unknown option two (getopt's and the usage).
"""

from __future__ import annotations

import subprocess

import pytest
from conftest import simulator_build


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    return simulator_build(tmp_path_factory)


def _run(sim, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(sim / "mearm_sim"), *args], input="", capture_output=True, text=True,
        timeout=60,  # a hang bound only
    )  # fmt: skip


@pytest.mark.parametrize(
    ("arg", "says"),
    [
        ("mearm_servo.hex", "cannot read"),
        ("missing.elf", "cannot read"),
        (".", "cannot read"),
    ],
)
def test_a_file_that_is_not_the_firmware_elf_is_refused_in_one_line(sim, arg, says):
    path = str(sim / arg)
    done = _run(sim, path)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and says in done.stderr and path in done.stderr
    assert ("not an ELF file" in done.stderr) == arg.endswith(".hex")
    assert done.stdout == ""


def test_an_unknown_option_is_one_line_and_help_goes_to_stdout(sim):
    elf = str(sim / "mearm_servo.elf")
    wrong = _run(sim, "-q", elf)
    assert wrong.returncode == 2 and wrong.stderr.count("\n") == 1 and "-q" in wrong.stderr
    for flag in ("-h", "--help"):
        helped = _run(sim, flag)
        assert helped.returncode == 0 and helped.stdout.startswith("usage: ")
        assert helped.stderr == ""
