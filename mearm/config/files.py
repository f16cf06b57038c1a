"""Reading a config file: a path or a packaged name → YAML → :class:`Config`, files resolved.

The mapping is validated by :func:`mearm.config.loader.config_from_dict` (with what it
builds on, ``extends`` and ``arm.use``, merged in: :mod:`mearm.config.compose`); the files a
config names (the servo calibration, the camera's calibration, the frames a ``file`` or
``folder`` camera replays) are found relative to its folder (one a ``--set`` gives: to
the current folder), and the servo calibration file's fits replace the calibrations of
the actuators it names (:mod:`mearm.config.servo_file`).

A loaded config remembers where it came from (:func:`config_source`), so a check of the
whole config (:mod:`mearm.task.check`) names the file as a bad field's error does.
"""

from __future__ import annotations

import os
import weakref
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from mearm.config.base import short_repr
from mearm.config.compose import names_a_file
from mearm.config.loader import OVERRIDES, config_from_dict, file_keys_set, unit_hints
from mearm.config.root import Config
from mearm.data import config_names, packaged_config
from mearm.errors import ConfigError
from mearm.yamlio import load_yaml_file


def read_yaml(path: str | Path) -> Any:
    """Read one YAML config file through :func:`mearm.yamlio.load_yaml_file`.

    Raises:
        ConfigError: missing, not a regular file, too large, not UTF-8, empty, malformed
            or refused YAML (duplicate keys, tags, aliases, depth); the message says where.
    """
    return load_yaml_file(path, what="config")


def resolve_config_path(path: str | Path, path_as: str = "--config") -> Path:
    """The file a ``--config`` value names: a path, else the name of a packaged config.

    An existing path wins; a bare name (no folder: ``sim`` or ``sim.yaml``) that is no
    file here names one of the configs the package ships (:mod:`mearm.data`), as does a
    shipped config's name that is a folder here (a folder is never a config). Any other
    missing path is returned as it is, for the reader's "config file not found". An empty
    one is said of ``path_as``: where it was given (a command's ``--config``, the Python
    call's ``path``).

    Raises:
        ConfigError: an empty name (``Path`` would read it as the current folder), or a
            bare name that is neither a file nor a packaged config; the message lists
            the packaged names.
    """
    given = Path(path)
    text = str(path)
    if not text:
        raise ConfigError(
            path_as,
            [
                "the value is empty: give a config file's path or the name of a packaged "
                f"config (mearm --help lists them): {', '.join(config_names()) or 'none'}"
            ],
        )
    if "/" in text or "\\" in text:
        _refuse_a_shipped_path_elsewhere(given, text)
        return given
    try:
        here = given.exists() or given.is_symlink()
        folder = here and given.is_dir()
    except OSError:  # a name no file can have (too long): the reader says why
        return given
    packaged = packaged_config(text)
    if here and not (folder and packaged is not None):
        return given
    if packaged is not None:
        return packaged
    known = config_names()
    close = _close_names(given, known)
    hint = f" (did you mean {' or '.join(map(repr, close))}?)" if close else ""
    raise ConfigError(
        short_repr(text),  # quoted: a space or a control character in it shows
        [
            f"config file not found, and no packaged config is named {short_repr(text)}{hint}; "
            "give a file's path or the name of a packaged config (mearm --help lists them): "
            f"{', '.join(known) or 'none'}"
        ],
    )


def _refuse_a_shipped_path_elsewhere(given: Path, text: str) -> None:
    """Refuse ``configs/NAME.yaml`` given outside a checkout, naming the shipped ``NAME``.

    The docs write configs as the checkout's paths (``--config configs/sim.yaml``), which
    do not exist from another folder; the same config is shipped under its name.
    """
    try:
        if given.exists() or given.is_symlink() or given.parent.name != "configs":
            return
        shipped = packaged_config(given.name)
    except OSError:  # a name no file can have (too long): the reader says why
        return
    name = given.name.removesuffix(".yaml")
    if shipped is not None:
        raise ConfigError(
            text,  # a shipped config's name under configs/: nothing to quote
            [
                f"config file not found from {Path.cwd()}; the config of that name that "
                f"mearm ships is --config {name} (in Python, load_config({name!r}))"
            ],
        )


#: Most files of the current folder looked at for a "did you mean" (a huge folder is cut).
MAX_FOLDER_FILES = 1000


def _close_names(given: Path, known: Sequence[str]) -> list[str]:
    """What a bare ``--config`` name that is nothing most likely meant, best first.

    ``my_arm`` when ``my_arm.yaml`` is here (the name without its suffix), else the
    shipped names and this folder's YAML files that are close, case aside (``Sim``:
    ``sim``).
    """
    import difflib  # noqa: PLC0415  (a name that is no config only)
    import itertools  # noqa: PLC0415

    text = str(given)
    stem = given.stem if given.suffix in (".yaml", ".yml") else text
    here = [f"{stem}{suffix}" for suffix in (".yaml", ".yml") if Path(f"{stem}{suffix}").is_file()]
    if here:
        return here[:1]
    candidates = {name.lower(): name for name in known}
    try:
        files = list(itertools.islice(Path().iterdir(), MAX_FOLDER_FILES))
    except OSError:  # an unreadable current folder: the shipped names only
        files = []
    for path in files:
        if path.suffix in (".yaml", ".yml") and path.name != text:
            candidates.setdefault(path.stem.lower(), path.name)
    if stem.lower() in candidates:  # the name but for its case: that one only
        return [candidates[stem.lower()]]
    close = difflib.get_close_matches(stem.lower(), list(candidates), n=3, cutoff=0.75)
    return [candidates[c] for c in close]


#: Where each loaded config came from, by the config object's id, while it lives.
_SOURCES: dict[int, str] = {}


def config_source(config: Config) -> str | None:
    """The file ``config`` was read from, as its field errors name it, else ``None``.

    ``FILE``, ``FILE with --set``, or ``--set`` (no file) for a config that
    :func:`load_config` returned (``overrides`` for ``--set``, unless it was given
    ``overrides_as="--set"``); ``None`` for one built in code or a changed copy.
    """
    return _SOURCES.get(id(config))


def unit_warning(config: Config) -> str | None:
    """The arm's unit hints as one line naming the config, else ``None``.

    Lengths that look like mm or angles that look like radians
    (:func:`~mearm.config.loader.unit_hints`) make a valid arm, one of the wrong size or
    shape: ``mearm fk``, ``mearm ik`` and a sort's config check
    (:mod:`mearm.task.check`) say it as a warning (``PROG: warning: LINE``) and go on.
    """
    hints = unit_hints(config.model_dump(mode="json"))
    if not hints:
        return None
    where = config_source(config)
    return f"{where + ': ' if where else ''}{'; '.join(hints)}"


def _remember_source(config: Config, source: str) -> Config:
    """``config``, recorded as read from ``source`` until it is freed."""
    _SOURCES[id(config)] = source
    weakref.finalize(config, _SOURCES.pop, id(config), None)
    return config


def load_config(
    path: str | Path | None = None,
    overrides: Sequence[str] = (),
    *,
    path_as: str = "path",
    overrides_as: str = OVERRIDES,
) -> Config:
    """Read a YAML config file; ``None`` gives the built-in default (the simulated rig).

    Args:
        path: The file, or the name of a packaged config (``sim`` is the shipped
            ``configs/sim.yaml``: :func:`resolve_config_path`), or ``None``.
        overrides: ``dotted.key=value`` strings applied before validation (a relative
            file path among them is relative to the current folder).
        path_as: What an error of ``path`` itself (an empty one) is said of: where the
            caller took it from. The argument's name; a command passes its flag,
            ``--config``.
        overrides_as: What an error of an override is said of (``overrides: KEY: …``);
            a command passes its flag, ``--set`` (``--set: KEY: …``).

    Raises:
        ConfigError: the file is missing (a bare name: nor packaged), unreadable, not
            YAML, or has bad fields; ``path`` or ``overrides`` is of another type (one
            override is a list of one string).
    """
    if path is not None and not isinstance(path, str | os.PathLike):
        raise ConfigError(
            None,
            [f"a config is a file's path or a shipped config's name, got {short_repr(path)}"],
        )
    if isinstance(overrides, str | bytes) or not all(isinstance(o, str) for o in overrides):
        raise ConfigError(
            overrides_as,
            [
                "overrides must be a list of 'dotted.key=value' strings (one: "
                f"overrides=['controller.kp=0.2']), got {short_repr(overrides)}"
            ],
        )
    if path is None:
        if not overrides:
            return Config()
        config = config_from_dict(
            {}, source=overrides_as, overrides=overrides, overrides_as=overrides_as
        )
        set_keys = file_keys_set(overrides, overrides_as)
        config = _resolve_files(config, Path(), overrides_as, set_keys, overrides_as)
        return _remember_source(config, overrides_as)
    given = str(path)
    path = resolve_config_path(path, path_as)
    shipped = path != Path(given)  # a bare name that is no file here: the shipped config
    config = config_from_dict(
        read_yaml(path),
        source=str(path),
        overrides=overrides,
        path=path,
        overrides_as=overrides_as,
        given=(given, shipped),
    )
    set_keys = file_keys_set(overrides, overrides_as)
    config = _resolve_files(config, path.parent, str(path), set_keys, overrides_as)
    return _remember_source(config, f"{path} with {overrides_as}" if overrides else str(path))


def _resolve_files(
    config: Config, folder: Path, source: str, from_set: set[str], overrides_as: str
) -> Config:
    """``config`` with its files found and its servo calibration applied.

    Relative paths are relative to ``folder`` (those of the keys in ``from_set``, given by
    ``--set``, are absolute already: a missing file of theirs is said of ``overrides_as``);
    the servo calibration file (``servo.calibration_file``) replaces the calibrations of the
    actuators it names.

    Raises:
        ConfigError: a calibration file the config names does not exist.
        ServoCalibrationError: the servo calibration file is not one, or not this arm's.
    """
    camera = config.camera
    if names_a_file("camera", "path", camera.model_dump()):  # frames replayed from here
        path = str(folder / str(camera.path))
        config = config.model_copy(update={"camera": camera.model_copy(update={"path": path})})
    servo_file = config.servo.calibration_file
    if servo_file is not None:
        # imported only for a config that names such a file (every other load skips it)
        from mearm.config.servo_file import apply_servo_calibration_file  # noqa: PLC0415

        key = "servo.calibration_file"
        where = overrides_as if key in from_set else source
        resolved = _existing(folder, servo_file, key, where, overrides_as)
        servo = config.servo.model_copy(update={"calibration_file": str(resolved)})
        config = apply_servo_calibration_file(config.model_copy(update={"servo": servo}), resolved)
    cal = config.calibration
    if cal.model != "perspective":
        return config
    changes: dict[str, str] = {}
    for name in ("intrinsics_file", "extrinsics_file"):
        key = f"calibration.{name}"
        where = overrides_as if key in from_set else source
        changes[name] = str(_existing(folder, getattr(cal, name), key, where, overrides_as))
    return config.model_copy(update={"calibration": cal.model_copy(update=changes)})


def _existing(folder: Path, text: str, key: str, source: str, overrides_as: str) -> Path:
    """The file ``text`` names, relative to ``folder`` unless absolute.

    Raises:
        ConfigError: it is not a file; the message says where it looked and by which rule.
    """
    resolved = folder / text if not Path(text).is_absolute() else Path(text)
    if not resolved.is_file():
        looked = "" if str(resolved) == text else f" (looked for {resolved})"
        raise ConfigError(
            source,
            [
                f"{key}: {text!r} is not a file{looked}; a relative path in a config file is "
                f"relative to that file's folder, one given by {overrides_as} to the current "
                "folder"
            ],
        )
    return resolved


__all__ = ["config_source", "load_config", "read_yaml", "resolve_config_path"]
