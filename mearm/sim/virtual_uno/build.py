"""Building the virtual Uno: the firmware and the simavr harness, once per source hash.

``tools/arduino/mearm_servo`` is built with Debian's avr-gcc and the harness
``tools/arduino/sim/mearm_sim.c`` against libsimavr, into a cache folder
(``~/.cache/mearm/virtual_uno/<hash of the sources>``).
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import os
import re
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from mearm.config.sections import DEFINE_PATTERN
from mearm.data import FIRMWARE_FILES, firmware_source_dir
from mearm.hardware import toolchain
from mearm.hardware.toolchain import (
    FIRMWARE_BUILD,
    SIMULATOR,
    Requirement,
    cache_dir,
    describe_missing,
)
from mearm.sim.virtual_uno.errors import VirtualUnoError

log = logging.getLogger(__name__)

#: The sketch: ``<source>/mearm_servo/mearm_servo.ino``.
SKETCH = "mearm_servo"
#: Longest build [s].
BUILD_TIMEOUT_S = 600.0


def missing_requirements() -> list[Requirement]:
    """What the build of the firmware and its simulator needs and is not installed."""
    return toolchain.missing((*FIRMWARE_BUILD, *SIMULATOR))


def cache_root() -> Path:
    """Where builds are kept: ``$XDG_CACHE_HOME/mearm/virtual_uno`` or ``~/.cache/…``."""
    return cache_dir("virtual_uno")


#: The file a build folder records its firmware's and harness's digests in.
DIGESTS = "SHA256SUMS"


@dataclass(frozen=True)
class VirtualUnoBuild:
    """A built virtual Uno.

    Attributes:
        firmware: The firmware's ELF.
        simulator: The harness executable, ``mearm_sim``.
    """

    firmware: Path
    simulator: Path

    @classmethod
    def in_folder(cls, folder: Path) -> VirtualUnoBuild:
        """The build a cache folder holds when it is whole."""
        return cls(folder / f"{SKETCH}.elf", folder / "mearm_sim")

    @property
    def digests(self) -> Path:
        """Where the build records its two files' digests (:meth:`record`)."""
        return self.firmware.parent / DIGESTS

    @property
    def whole(self) -> bool:
        """Both files are there, as the build left them (their digests are the recorded).

        A file cut short or changed since (a full disk, a hand) is not: the AVR would
        stop before its banner, which reads as a real board's fault.
        """
        try:
            return self.digests.read_text(encoding="utf-8") == self._digest_text()
        except (OSError, UnicodeDecodeError):
            return False

    def record(self) -> None:
        """Record the two files' digests (once they are built).

        Raises:
            OSError: the record cannot be written.
        """
        self.digests.write_text(self._digest_text(), encoding="utf-8")

    def _digest_text(self) -> str:
        lines = [
            f"{hashlib.sha256(path.read_bytes()).hexdigest()}  {path.name}\n"
            for path in (self.firmware, self.simulator)
        ]
        return "".join(lines)


def build_virtual_uno(
    defines: Sequence[str] = (), *, cache_dir: Path | None = None, source: Path | None = None
) -> VirtualUnoBuild:
    """Build the firmware and the harness, or find them already built.

    Each combination of sources and ``defines`` is built once, into its own folder named
    by their hash under ``cache_dir``; a build goes to a temporary folder first and is
    renamed into place, so an interrupted or concurrent build leaves no half of one. A
    folder that lost a file since, or holds one changed or cut short (a cache cleaner, a
    full disk, a hand: their digests are recorded), is built again and replaced.

    Args:
        defines: Compile-time options of a firmware variant, ``NAME`` or ``NAME=VALUE``
            (``SERVO_PIN_1=6``: channel 1 on pin D6); validated by the config.
        cache_dir: Where builds are kept (default :func:`cache_root`).
        source: The firmware source (default :func:`firmware_source_dir`).

    Raises:
        VirtualUnoError: a tool or header is missing (one line naming the Debian
            packages to install), or the build failed (its last line of output).
    """
    bad = [d for d in defines if not re.fullmatch(DEFINE_PATTERN, d)]
    if bad:
        raise VirtualUnoError(
            f"firmware defines must be NAME or NAME=VALUE (capitals, digits, _), got {bad}"
        )
    source = source if source is not None else firmware_source_dir()
    root = cache_dir if cache_dir is not None else cache_root()
    folder = root / _build_hash(source, defines)
    built = VirtualUnoBuild.in_folder(folder)
    if built.whole:
        return built
    missing = missing_requirements()
    if missing:
        raise VirtualUnoError(
            f"cannot build the firmware and its simulator: {describe_missing(missing)}",
            toolchain.packages(missing),
        )
    _make_into(source, defines, folder)
    if not built.whole:
        raise VirtualUnoError(f"the build left no {built.firmware.name} and mearm_sim")
    return built


def _build_hash(source: Path, defines: Sequence[str]) -> str:
    """The build folder's name: a hash of the firmware's sources and the defines."""
    digest = hashlib.sha256()
    for name in FIRMWARE_FILES:
        digest.update((source / name).read_bytes())
    digest.update("\0".join(defines).encode())
    return digest.hexdigest()[:16]


def _make_into(source: Path, defines: Sequence[str], folder: Path) -> None:
    """Run the build in a temporary folder beside ``folder``, then rename it into place.

    Raises:
        VirtualUnoError: the cache folder cannot be made or written (a read-only home, a
            file where a folder goes), or the build failed or took too long.
    """
    try:
        folder.parent.mkdir(parents=True, exist_ok=True)
        work = Path(tempfile.mkdtemp(prefix="build-", dir=folder.parent))
    except OSError as exc:
        raise VirtualUnoError(
            f"cannot build into {folder.parent}: {exc.strerror or exc}; set XDG_CACHE_HOME "
            "to a folder you can write"
        ) from None
    command = ["make", "-C", str(source), f"BUILD_DIR={work}", "all", "sim"]
    if defines:
        command.append("EXTRA_DEFS=" + " ".join(f"-D{d}" for d in defines))
    log.info("building the virtual Uno: %s", " ".join(command))
    try:
        result = subprocess.run(command, capture_output=True, text=True, timeout=BUILD_TIMEOUT_S)
        if result.returncode != 0:
            lines = (result.stderr or result.stdout).strip().splitlines() or ["no output"]
            raise VirtualUnoError(
                f"building the firmware and its simulator failed ({' '.join(command)}, exit "
                f"{result.returncode}): {lines[-1]}"
            )
        fresh = VirtualUnoBuild.in_folder(work)
        try:
            fresh.record()
        except OSError as exc:
            raise VirtualUnoError(
                f"cannot build into {folder.parent}: {exc.strerror or exc}; set XDG_CACHE_HOME "
                "to a folder you can write"
            ) from None
        try:
            os.replace(work, folder)
        except OSError:  # the folder is there: another process's build (keep it), or a damaged one
            if not VirtualUnoBuild.in_folder(folder).whole:
                shutil.rmtree(folder, ignore_errors=True)
                with contextlib.suppress(OSError):  # another process replaced it first
                    os.replace(work, folder)
    except subprocess.TimeoutExpired:
        raise VirtualUnoError(f"the build took over {BUILD_TIMEOUT_S:.0f} s") from None
    finally:
        shutil.rmtree(work, ignore_errors=True)
