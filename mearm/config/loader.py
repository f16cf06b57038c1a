"""Reading a config: YAML text → mapping → ``--set`` overrides → validated :class:`Config`.

An override is ``dotted.key=value``: the path walks mappings by key and lists by index
or, for lists of named items (joints, classes, tool actuators), by name —
``arm.joints.shoulder.limits.max=140``, ``task.classes.red.bin_cm=[-20,30,20]``. The value
is read as YAML (``1.5``, ``true``, ``[1, 2]``, ``{min: 0, max: 90}``). Overrides are
applied before validation, so a bad one gets the same one-line error as a bad file.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from mearm.config.base import describe_error, short_repr
from mearm.config.root import Config
from mearm.data import config_names, packaged_config
from mearm.exceptions import ConfigError
from mearm.yamlio import MAX_YAML_DEPTH, load_yaml_file, load_yaml_text

#: Longest ``--set`` key [characters]; the longest real one has ~40.
MAX_KEY_CHARS = 200
_INDEX = re.compile(r"^-?[0-9]{1,9}$")


def parse_override(text: str) -> tuple[list[str], Any]:
    """Split ``dotted.key=value`` into the path and the YAML-parsed value.

    Raises:
        ConfigError: no ``=``, an empty key, or a value that is not YAML.
    """
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key or any(not part for part in key.split(".")):
        raise ConfigError(
            "--set",
            [f"{short_repr(text)}: expected dotted.key=value, e.g. arm.joints.base.home=90"],
        )
    parts = key.split(".")
    if len(key) > MAX_KEY_CHARS or len(parts) > MAX_YAML_DEPTH:
        raise ConfigError(
            "--set",
            [
                f"{short_repr(key)}: key too long (at most {MAX_KEY_CHARS} characters and "
                f"{MAX_YAML_DEPTH} parts)"
            ],
        )
    if not raw.strip():
        return parts, ""
    try:
        value = load_yaml_text(raw, source="--set", what="--set value", allow_empty=True)
    except ConfigError as exc:
        problem = exc.problems[0] if exc.problems else "?"
        raise ConfigError(
            "--set", [f"{key}: value {short_repr(raw, 40)} is not valid YAML ({problem})"]
        ) from None
    return parts, value


def _child(node: Any, default: Any, part: str, where: str) -> tuple[Any, Any]:
    """The child ``part`` of ``node`` and of its default (created from it when missing)."""
    if isinstance(node, dict):
        sub_default = default.get(part) if isinstance(default, dict) else None
        if part not in node:
            node[part] = copy.deepcopy(sub_default) if sub_default is not None else {}
        return node[part], sub_default
    if isinstance(node, list):
        i = _index(node, part, where)
        same = isinstance(default, list) and i < len(default)
        return node[i], default[i] if same else None
    raise ConfigError("--set", [f"{where}: is a value, not a section (cannot set {part!r})"])


def _index(items: list[Any], part: str, where: str) -> int:
    if _INDEX.match(part):
        i = int(part)
        if not 0 <= i < len(items):
            raise ConfigError("--set", [f"{where}.{part}: no such item (0…{len(items) - 1})"])
        return i
    for i, item in enumerate(items):
        if isinstance(item, dict) and item.get("name") == part:
            return i
    names = [str(it.get("name")) for it in items if isinstance(it, dict) and "name" in it]
    allowed = ", ".join(names) if names else f"an index 0…{len(items) - 1}"
    raise ConfigError("--set", [f"{where}.{part}: no item named {part!r} (choices: {allowed})"])


def apply_overrides(
    data: dict[str, Any], overrides: Sequence[str], defaults: dict[str, Any] | None = None
) -> dict[str, Any]:
    """A copy of ``data`` with every ``dotted.key=value`` of ``overrides`` set.

    A section the data leaves out is taken from ``defaults`` (the built-in config) before
    the override changes it, so ``--set arm.joints.base.home=90`` works on a file that
    does not spell out the arm.

    Raises:
        ConfigError: a malformed override, a list index or name that does not exist.
    """
    out = copy.deepcopy(data)
    for text in overrides:
        path, value = parse_override(text)
        node: Any = out
        default: Any = defaults
        for depth, part in enumerate(path[:-1]):
            node, default = _child(node, default, part, ".".join(path[:depth]) or "(top level)")
        last, where = path[-1], ".".join(path[:-1]) or "(top level)"
        if isinstance(node, dict):
            node[last] = value
        elif isinstance(node, list):
            node[_index(node, last, where)] = value
        else:
            raise ConfigError("--set", [f"{where}: is a value, not a section"])
    return out


def config_from_dict(
    data: Any, *, source: str | None = None, overrides: Sequence[str] = ()
) -> Config:
    """Validate a mapping (with ``overrides`` applied first) into a :class:`Config`.

    Raises:
        ConfigError: one line per bad field.
    """
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(source, [f"top level must be a mapping, got {type(data).__name__}"])
    if overrides:
        data = apply_overrides(data, overrides, _default_data())
    try:
        return Config.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(source, [describe_error(e) for e in exc.errors()]) from None


def _default_data() -> dict[str, Any]:
    return Config().model_dump(mode="json")


def read_yaml(path: str | Path) -> Any:
    """Read one YAML config file through :func:`mearm.yamlio.load_yaml_file`.

    Raises:
        ConfigError: missing, not a regular file, too large, not UTF-8, empty, malformed
            or refused YAML (duplicate keys, tags, aliases, depth); the message says where.
    """
    return load_yaml_file(path, what="config")


def resolve_config_path(path: str | Path) -> Path:
    """The file a ``--config`` value names: a path, else the name of a packaged config.

    An existing path wins; a bare name (no folder: ``sim`` or ``sim.yaml``) that is no
    file here names one of the configs the package ships (:mod:`mearm.data`). Any other
    missing path is returned as it is, for the reader's "config file not found".

    Raises:
        ConfigError: a bare name that is neither a file nor a packaged config; the
            message lists the packaged names.
    """
    given = Path(path)
    text = str(path)
    if given.exists() or given.is_symlink() or "/" in text or "\\" in text:
        return given
    packaged = packaged_config(text)
    if packaged is not None:
        return packaged
    names = ", ".join(config_names()) or "none"
    raise ConfigError(
        text,
        [
            f"config file not found, and no packaged config is named {text!r} "
            f"(packaged: {names}); give a file's path or one of these names"
        ],
    )


def load_config(path: str | Path | None = None, overrides: Sequence[str] = ()) -> Config:
    """Read a YAML config file; ``None`` gives the built-in default (the simulated rig).

    Args:
        path: The file, or the name of a packaged config (``sim`` is the shipped
            ``configs/sim.yaml``: :func:`resolve_config_path`), or ``None``.
        overrides: ``dotted.key=value`` strings applied before validation.

    Raises:
        ConfigError: the file is missing (a bare name: nor packaged), unreadable, not
            YAML, or has bad fields.
    """
    if path is None:
        if not overrides:
            return Config()
        return config_from_dict({}, source="--set", overrides=overrides)
    path = resolve_config_path(path)
    config = config_from_dict(read_yaml(path), source=str(path), overrides=overrides)
    return _resolve_files(config, path.parent, str(path))


def _resolve_files(config: Config, folder: Path, source: str) -> Config:
    """``config`` with its calibration files found and its servo calibration applied.

    Relative paths are relative to ``folder``; the servo calibration file
    (``servo.calibration_file``) replaces the calibrations of the actuators it names.

    Raises:
        ConfigError: a calibration file the config names does not exist.
        ServoCalibrationError: the servo calibration file is not one, or not this arm's.
    """
    servo_file = config.servo.calibration_file
    if servo_file is not None:
        from mearm.config.servo_file import apply_servo_calibration_file

        resolved = _existing(folder, servo_file, "servo.calibration_file", source)
        servo = config.servo.model_copy(update={"calibration_file": str(resolved)})
        config = apply_servo_calibration_file(config.model_copy(update={"servo": servo}), resolved)
    cal = config.calibration
    if cal.model != "perspective":
        return config
    changes: dict[str, str] = {}
    for name in ("intrinsics_file", "extrinsics_file"):
        changes[name] = str(_existing(folder, getattr(cal, name), f"calibration.{name}", source))
    return config.model_copy(update={"calibration": cal.model_copy(update=changes)})


def _existing(folder: Path, text: str, key: str, source: str) -> Path:
    """The file ``text`` names, relative to ``folder`` unless absolute.

    Raises:
        ConfigError: it is not a file.
    """
    resolved = folder / text if not Path(text).is_absolute() else Path(text)
    if not resolved.is_file():
        raise ConfigError(
            source,
            [
                f"{key}: {text!r} is not a file (looked for {resolved}); relative paths are "
                "relative to the config file's folder"
            ],
        )
    return resolved
