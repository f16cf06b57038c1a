"""What building and uploading the Uno firmware needs, and where builds are kept.

Both ``mearm flash`` (:mod:`mearm.maker.flash`) and the virtual Uno
(:mod:`mearm.sim.virtual_uno`) build the project's firmware with Debian's AVR toolchain;
the virtual Uno also builds its simavr harness with the host's C compiler. Each names
what is missing in one line with the ``apt-get`` command that installs it.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

#: The Arduino core the firmware's Makefile builds against (its ``ARDUINO_DIR``).
ARDUINO_CORE_DIR = Path("/usr/share/arduino/hardware/arduino/avr")


@dataclass(frozen=True)
class Requirement:
    """A tool or file a build or an upload needs, and the Debian package providing it.

    Attributes:
        what: The program (looked up on ``PATH``), or what the file is.
        package: The Debian package.
        path: The file that shows it is installed (``None``: ``what`` is a program).
    """

    what: str
    package: str
    path: Path | None = None

    def present(self) -> bool:
        """Whether it is installed."""
        if self.path is not None:
            return self.path.is_file()
        return shutil.which(self.what) is not None


#: The firmware's build (``make -C tools/arduino``).
FIRMWARE_BUILD: tuple[Requirement, ...] = (
    Requirement("make", "make"),
    Requirement("avr-gcc", "gcc-avr"),
    Requirement("avr-objcopy", "binutils-avr"),
    Requirement("avr-libc", "avr-libc", Path("/usr/lib/avr/include/avr/io.h")),
    Requirement(
        "the Arduino core", "arduino-core-avr", ARDUINO_CORE_DIR / "cores/arduino/Arduino.h"
    ),
)
#: The upload to a real Uno.
UPLOAD: tuple[Requirement, ...] = (Requirement("avrdude", "avrdude"),)
#: The simavr harness of the virtual Uno (``make -C tools/arduino sim``).
SIMULATOR: tuple[Requirement, ...] = (
    Requirement("cc", "gcc"),
    Requirement("libsimavr", "libsimavr-dev", Path("/usr/include/simavr/sim_avr.h")),
    Requirement("libelf", "libelf-dev", Path("/usr/include/libelf.h")),
)


def missing(requirements: Iterable[Requirement]) -> list[Requirement]:
    """The requirements that are not installed, in order."""
    return [r for r in requirements if not r.present()]


def packages(requirements: Sequence[Requirement]) -> list[str]:
    """Their Debian packages, each once, in order."""
    return list(dict.fromkeys(r.package for r in requirements))


def describe_missing(requirements: Sequence[Requirement]) -> str:
    """One line naming what is missing and the ``apt-get`` command that installs it."""
    names = ", ".join(f"{r.what} ({r.package})" for r in requirements)
    return (
        f"not installed: {names}; install with: sudo apt-get install "
        f"{' '.join(packages(requirements))}"
    )


def cache_dir(name: str) -> Path:
    """``$XDG_CACHE_HOME/mearm/<name>``, else ``~/.cache/mearm/<name>``: where builds go."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "mearm" / name
