"""The data the package ships: reference configs and arms, URDFs, firmware and the docs.

The project keeps them in its fixed top-level folders (``configs/``, ``robot_description/``,
``tools/arduino/``, ``docs/``); this folder links to them (``configs``,
``robot_description``, ``firmware``, ``docs`` are relative symbolic links), so an editable
install reads the checkout's files, and building the wheel copies the files the links point
to into ``mearm/data/`` (``[tool.setuptools.package-data]`` in pyproject.toml; the docs'
pages without their images). One lookup serves both: :data:`DATA_DIR`.
"""

from __future__ import annotations

from pathlib import Path

#: Where the shipped data lies (in the wheel: real folders; in the checkout: links).
DATA_DIR = Path(__file__).parent
#: The reference configs (``sim.yaml`` …) and their calibration files (``calibration/``).
CONFIGS_DIR = DATA_DIR / "configs"
#: The reference arms, one description per file (``mearm_paper.yaml`` …), that configs
#: name with ``arm: {use: mearm_paper}`` (:mod:`mearm.config.compose`).
ARMS_DIR = CONFIGS_DIR / "arms"
#: The reference arms' URDFs (``mearm urdf`` writes them).
URDF_DIR = DATA_DIR / "robot_description"
#: The Uno's firmware source and its Makefile (``tools/arduino/`` of the checkout).
FIRMWARE_DIR = DATA_DIR / "firmware"
#: The docs' pages (``maker-path.md`` …; in the wheel without their images).
DOCS_DIR = DATA_DIR / "docs"
#: What a packaged config's file name ends with.
CONFIG_SUFFIX = ".yaml"


def config_names() -> list[str]:
    """The names of the packaged configs (``sim``, ``lab`` …), sorted."""
    if not CONFIGS_DIR.is_dir():
        return []
    return sorted(p.stem for p in CONFIGS_DIR.glob(f"*{CONFIG_SUFFIX}") if p.is_file())


def packaged_config(name: str) -> Path | None:
    """The packaged config called ``name`` (``sim`` or ``sim.yaml``), or ``None``."""
    stem = name.removesuffix(CONFIG_SUFFIX)
    if not stem or "/" in stem or "\\" in stem or stem.startswith("."):
        return None
    path = CONFIGS_DIR / f"{stem}{CONFIG_SUFFIX}"
    return path if path.is_file() else None


def arm_names() -> list[str]:
    """The names of the reference arms (``mearm_paper``, ``mearm_v1`` …), sorted."""
    if not ARMS_DIR.is_dir():
        return []
    return sorted(p.stem for p in ARMS_DIR.glob(f"*{CONFIG_SUFFIX}") if p.is_file())


def packaged_arm(name: str) -> Path | None:
    """The file of the reference arm called ``name``, or ``None``."""
    if not name or "/" in name or "\\" in name or name.startswith("."):
        return None
    path = ARMS_DIR / f"{name}{CONFIG_SUFFIX}"
    return path if path.is_file() else None


#: What a firmware source folder holds: the Makefile, the sketch and the simavr harness.
FIRMWARE_FILES = ("Makefile", "mearm_servo/mearm_servo.ino", "sim/mearm_sim.c")


def firmware_source_dir() -> Path:
    """The firmware's source folder (:data:`FIRMWARE_DIR`, resolved), checked whole.

    Raises:
        MearmError: a file of :data:`FIRMWARE_FILES` is missing there.
    """
    from mearm.errors import MearmError

    folder = FIRMWARE_DIR.resolve()
    missing = [f for f in FIRMWARE_FILES if not (folder / f).is_file()]
    if missing:
        raise MearmError(
            f"the firmware source is not installed (looked in {folder}, missing "
            f"{', '.join(missing)}): reinstall mearm, or run from the source checkout"
        )
    return folder


def shown_path(path: Path) -> str:
    """A shipped file's path as a message shows it, so that the user can open it.

    The file the links lead to (in the checkout ``configs/sim.yaml`` …, in the wheel its
    copy), relative to the current folder when it is under it (as the README's commands
    are run in the checkout), else absolute.
    """
    path = path.resolve()
    try:
        return path.relative_to(Path.cwd()).as_posix()
    except (ValueError, OSError):  # elsewhere, or the current folder is gone
        return str(path)


def doc_page(name: str) -> str:
    """Where to read the docs' page ``name`` (``maker-path.md``), as a message shows it.

    In the checkout it is ``docs/NAME``, from the wheel the copy it ships
    (:data:`DOCS_DIR`), shown by :func:`shown_path`.
    """
    return shown_path(DOCS_DIR / name)


def source_checkout() -> Path | None:
    """The source checkout the package runs from (an editable install), else ``None``.

    In the checkout ``configs`` here is a link to the checkout's ``configs/``; in an
    installed wheel it is a folder of copies.
    """
    if CONFIGS_DIR.is_symlink():
        return CONFIGS_DIR.resolve().parent
    return None


__all__ = [
    "ARMS_DIR",
    "CONFIGS_DIR",
    "CONFIG_SUFFIX",
    "DATA_DIR",
    "DOCS_DIR",
    "FIRMWARE_DIR",
    "FIRMWARE_FILES",
    "URDF_DIR",
    "arm_names",
    "config_names",
    "doc_page",
    "firmware_source_dir",
    "packaged_arm",
    "packaged_config",
    "shown_path",
    "source_checkout",
]
