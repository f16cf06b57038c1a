"""The Uno firmware builds with Debian's toolchain, fits the Uno, and boots with its banner.

Needs gcc-avr, avr-libc and arduino-core-avr (and make); simavr for the boot test.
Skipped without them, but failed when MEARM_REQUIRE_TOOLS=1 (CI).
"""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest
from conftest import ROOT, require_tool

from mearm.hardware.mearm_protocol import decode_line, encode_line

ARDUINO = ROOT / "tools" / "arduino"
CORE_H = Path("/usr/share/arduino/hardware/arduino/avr/cores/arduino/Arduino.h")
#: ATmega328P with the Uno's bootloader (boards.txt: upload.maximum_size/_data_size).
FLASH_BYTES = 32256
RAM_BYTES = 2048


def _require_core() -> None:
    if CORE_H.is_file():
        return
    msg = f"arduino-core-avr is not installed ({CORE_H} missing)"
    if os.environ.get("MEARM_REQUIRE_TOOLS") == "1":
        pytest.fail(f"{msg}, and MEARM_REQUIRE_TOOLS=1 says it must be")
    pytest.skip(msg)


@pytest.fixture(scope="module")
def firmware(tmp_path_factory) -> Path:
    """Build the sketch from the checkout into a temporary directory; the ELF's path."""
    require_tool("make")
    require_tool("avr-gcc")
    _require_core()
    build = tmp_path_factory.mktemp("firmware")
    result = subprocess.run(
        ["make", "-C", str(ARDUINO), f"BUILD_DIR={build}"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert (build / "mearm_servo.hex").stat().st_size > 0
    return build / "mearm_servo.elf"


def _section_sizes(elf: Path) -> dict[str, int]:
    out = subprocess.run(["avr-size", "-A", str(elf)], capture_output=True, text=True, check=True)
    sizes = {}
    for line in out.stdout.splitlines():
        m = re.match(r"^(\.\w+)\s+(\d+)\s+\d+$", line.strip())
        if m:
            sizes[m.group(1)] = int(m.group(2))
    return sizes


def test_firmware_fits_the_uno(firmware):
    """Flash (.text + .data) and RAM (.data + .bss) within the Uno's limits, with room."""
    s = _section_sizes(firmware)
    flash, ram = s[".text"] + s.get(".data", 0), s.get(".data", 0) + s.get(".bss", 0)
    assert 0 < flash < FLASH_BYTES // 2
    assert 0 < ram < RAM_BYTES // 2  # the rest is stack and the serial buffers' headroom


def test_firmware_does_not_use_the_servo_library():
    """Debian does not package Servo: the sketch must generate pulses itself."""
    text = (ARDUINO / "mearm_servo" / "mearm_servo.ino").read_text()
    assert "Servo.h" not in text and "TIMER1_COMPA_vect" in text


def test_firmware_boots_with_banner_in_simavr(firmware):
    """Run the ELF in simavr (ATmega328P, 16 MHz): its UART prints the protocol banner."""
    simavr = require_tool("simavr")
    try:
        proc = subprocess.run(
            [simavr, "-m", "atmega328p", "-f", "16000000", str(firmware)],
            capture_output=True, timeout=1.5,
        )  # fmt: skip
        out = proc.stdout + proc.stderr
    except subprocess.TimeoutExpired as exc:  # simavr runs until killed
        out = (exc.stdout or b"") + (exc.stderr or b"")
    text = re.sub(rb"\x1b\[[0-9;]*m", b"", out)  # simavr colours UART output
    banner = encode_line("READY mearm_servo 1.0 5").rstrip(b"\n")
    assert banner in text, text[:500]
    assert decode_line(banner).kind == "READY"
