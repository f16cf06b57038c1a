"""The virtual Uno's build cache: a folder that cannot be written, a build that lost a file.

``mearm sort --config virtual_uno`` with ``XDG_CACHE_HOME`` on a file or a folder that
cannot be made ended in "unexpected error: NotADirectoryError" (a traceback in the crash
log) instead of one line; a cache folder that had lost ``mearm_sim`` was never built
again: every run said "the build left no mearm_servo.elf and mearm_sim". The build here
is a stand-in Makefile that writes the two files (``make`` is the only tool it runs), so
the tests take no avr-gcc time; they need the toolchain the real build checks for.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from mearm.data import FIRMWARE_FILES
from mearm.sim.virtual_uno.build import build_virtual_uno, missing_requirements
from mearm.sim.virtual_uno.errors import VirtualUnoError

pytestmark = pytest.mark.skipif(
    bool(missing_requirements()), reason="the virtual Uno's toolchain is not installed"
)

#: A build that writes what the real one leaves: the firmware's ELF and the harness.
STAND_IN_MAKEFILE = """\
.PHONY: all sim
all:
\techo elf > $(BUILD_DIR)/mearm_servo.elf
sim:
\techo sim > $(BUILD_DIR)/mearm_sim
"""


def stand_in_source(folder: Path) -> Path:
    """A firmware source folder whose Makefile builds in no time."""
    for name in FIRMWARE_FILES:
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(STAND_IN_MAKEFILE if name == "Makefile" else f"// {name}\n")
    return folder


def test_a_cache_under_a_file_is_one_named_error(tmp_path: Path):
    """The cache's place is a file: a VirtualUnoError naming the folder and what to set."""
    (tmp_path / "cache").write_text("not a folder\n")
    source = stand_in_source(tmp_path / "src")
    with pytest.raises(VirtualUnoError, match=r"cannot build into .*cache.*XDG_CACHE_HOME"):
        build_virtual_uno(cache_dir=tmp_path / "cache" / "virtual_uno", source=source)


def test_a_build_that_lost_a_file_is_built_again(tmp_path: Path):
    """The harness deleted from a whole build: the next call builds and replaces it."""
    source = stand_in_source(tmp_path / "src")
    cache = tmp_path / "cache"
    built = build_virtual_uno(cache_dir=cache, source=source)
    assert built.firmware.read_text() == "elf\n" and built.simulator.read_text() == "sim\n"
    built.simulator.unlink()
    again = build_virtual_uno(cache_dir=cache, source=source)
    assert again == built
    assert again.simulator.read_text() == "sim\n"
    assert [p.name for p in cache.iterdir()] == [built.firmware.parent.name]  # no leftovers


def test_a_build_cut_short_is_built_again(tmp_path: Path):
    """The ELF cut short (a full disk, a hand): the AVR stopped before its banner, which
    read as a real board's fault with a real board's advice, until 2026-12-06. The build
    records its files' digests; one that differs is built again and replaced."""
    source = stand_in_source(tmp_path / "src")
    cache = tmp_path / "cache"
    built = build_virtual_uno(cache_dir=cache, source=source)
    assert built.whole and built.digests.is_file()
    built.firmware.write_text("el")
    assert not built.whole
    again = build_virtual_uno(cache_dir=cache, source=source)
    assert again == built and again.whole
    assert again.firmware.read_text() == "elf\n"
    assert [p.name for p in cache.iterdir()] == [built.firmware.parent.name]  # no leftovers
