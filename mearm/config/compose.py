"""Configs that build on others: ``extends`` names a config, ``arm.use`` a reference arm.

A reference arm is one file, ``configs/arms/<name>.yaml`` (:data:`mearm.data.ARMS_DIR`):
its ``arm:`` description (joints, servo calibrations, tool, target box), nothing of the
rig. A config names it and gives only what differs on its arm; a config may also build on
another config and give only what differs from it::

    extends: sim.yaml             # relative to this file; else a packaged config's name
    simulator: mujoco
    arm:
      tool: {settle_s: 0.2}
      joints:
        shoulder: {servo: {max_accel_deg_s2: 4000}}   # the joint named shoulder

    arm:
      use: mearm_v1               # configs/arms/mearm_v1.yaml
      joints:
        base: {dh: {d_cm: 6.0}}   # measured on this kit

What a config gives merges over what it builds on, by one rule:

- a mapping over a mapping merges key by key, at every depth;
- a mapping over a list of named items (``arm.joints``, ``arm.tool.actuators``,
  ``task.classes``) merges each of its values over the item of that name;
- anything else replaces what it builds on: a list is replaced whole (to add, remove or
  reorder joints, write out the list), a value or ``null`` replaces the value.

A config that gives ``calibration.homography`` without ``calibration.image_size_px`` has
a homography of unknown frame size: the size of the one it replaces is not kept.

``arm.use`` starts the arm afresh: a config that names an arm takes that arm with its own
changes only, whatever the config it extends said about its arm. Relative file paths in
a config (``servo.calibration_file``, the camera's calibration files, the frames a
``file`` or ``folder`` camera replays) stay relative to the folder of the file that
wrote them.
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mearm.config.base import short_repr
from mearm.data import arm_names, config_names, packaged_arm, packaged_config
from mearm.errors import ConfigError
from mearm.yamlio import load_yaml_file

#: The key of a config that names the config it builds on.
EXTENDS_KEY = "extends"
#: The key of a config's ``arm`` that names a reference arm.
USE_KEY = "use"
#: Most configs in one chain of ``extends`` (the shipped ones use two).
MAX_EXTENDS = 8
#: The keys that hold file paths, relative to the folder of the config that names them
#: (``camera.path`` unless the camera is a ``device``: :func:`names_a_file`).
FILE_KEYS: tuple[tuple[str, str], ...] = (
    ("servo", "calibration_file"),
    ("calibration", "intrinsics_file"),
    ("calibration", "extrinsics_file"),
    ("camera", "path"),
)
#: The section, its homography and the frame size that homography was fitted at.
CALIBRATION, HOMOGRAPHY, IMAGE_SIZE = "calibration", "homography", "image_size_px"
#: A key's place in a config: its keys from the top, a list of named items' item by name.
KeyPath = tuple[Any, ...]
#: Where each key of a composed config was written (:func:`expand_config_traced`): its
#: path → the file (the ``source`` it was read as), for every key or whole value a file
#: set; what lies beneath a path recorded is that file's too.
Origins = dict[KeyPath, str | None]
#: Camera kinds whose ``path`` is what ``cv2.VideoCapture`` opens as given (a device, a
#: URL), not a file or folder beside the config.
_DEVICE_KINDS = ("device",)


def names_a_file(section: str, key: str, part: Mapping[str, Any]) -> bool:
    """Whether ``part`` (the mapping of ``section``) holds a relative file path at ``key``.

    One of :data:`FILE_KEYS`, a relative path, and for ``camera.path`` a camera that
    replays a file or folder (a device's path, or a URL, is opened as given).
    """
    text = part.get(key)
    if (section, key) not in FILE_KEYS or not isinstance(text, str) or not text.strip():
        return False
    if section == "camera" and (part.get("kind") in _DEVICE_KINDS or "://" in text):
        return False
    return not Path(text).is_absolute()


def merge(base: Any, over: Any, where: str = "", *, source: str | None = None) -> Any:
    """``over`` merged over ``base`` by the module's rule; neither is changed.

    Args:
        base: What is built on (a config's mapping or a part of it).
        over: The differences.
        where: The dotted path of both, for messages.
        source: The file ``over`` comes from, for messages.

    Raises:
        ConfigError: a mapping over a list of named items names an item the list lacks.
    """
    if isinstance(over, Mapping) and isinstance(base, Mapping):
        out = copy.deepcopy(dict(base))
        for key, value in over.items():
            path = f"{where}.{key}" if where else str(key)
            out[key] = (
                merge(base[key], value, path, source=source)
                if key in base
                else copy.deepcopy(value)
            )
        return out
    if isinstance(over, Mapping) and _named_items(base):
        names = [item["name"] for item in base]
        unknown = [str(key) for key in over if key not in names]
        if unknown:
            raise ConfigError(
                source,
                [
                    f"{where}.{unknown[0]}: no item named {short_repr(unknown[0])} to change "
                    f"(names: {', '.join(map(str, names))}); to add one, write out the list"
                ],
            )
        return [
            merge(item, over[item["name"]], f"{where}.{item['name']}", source=source)
            if item["name"] in over
            else copy.deepcopy(item)
            for item in base
        ]
    return copy.deepcopy(over)


def without_stale_size(base: Any, own: Any) -> Any:
    """``base`` without its homography's frame size if ``own`` gives a homography without one.

    ``calibration.image_size_px`` is the size the homography beside it was fitted at: a
    config that replaces the homography and says nothing of its size has a homography of
    unknown size, not one of the size of the homography it replaced.
    """
    if not (isinstance(base, Mapping) and isinstance(own, Mapping)):
        return base
    cal, over = base.get(CALIBRATION), own.get(CALIBRATION)
    if not (isinstance(cal, Mapping) and isinstance(over, Mapping)):
        return base
    if HOMOGRAPHY not in over or IMAGE_SIZE in over or IMAGE_SIZE not in cal:
        return base
    return {**base, CALIBRATION: {k: v for k, v in cal.items() if k != IMAGE_SIZE}}


def _named_items(value: Any) -> bool:
    """Whether ``value`` is a non-empty list of mappings that each have a ``name``."""
    return (
        isinstance(value, list)
        and bool(value)
        and all(isinstance(item, Mapping) and "name" in item for item in value)
    )


@functools.cache
def _arm_file(path: Path) -> Any:
    return load_yaml_file(path, what="arm")


def reference_arm(name: str, source: str | None = None) -> dict[str, Any]:
    """The ``arm:`` mapping of the reference arm called ``name`` (a copy, not validated).

    Raises:
        ConfigError: no reference arm has that name (the message lists the names), or
            its file is not a mapping with an ``arm`` mapping.
    """
    path = packaged_arm(name) if isinstance(name, str) else None
    if path is None:
        raise ConfigError(
            source,
            [
                f"arm.{USE_KEY}: no reference arm named {short_repr(name)} "
                f"(known: {', '.join(arm_names()) or 'none'})"
            ],
        )
    data = _arm_file(path)
    arm = data.get("arm") if isinstance(data, Mapping) else None
    if not isinstance(arm, Mapping) or set(data) != {"arm"}:
        raise ConfigError(str(path), ["a reference arm's file holds one mapping, arm:"])
    return copy.deepcopy(dict(arm))


def expand_arm(arm: Any, source: str | None = None) -> Any:
    """``arm`` with its ``use`` replaced by the reference arm, its other keys merged over.

    An arm without ``use`` is returned as it is.

    Raises:
        ConfigError: an unknown arm name, or a change that names no item of its list.
    """
    if not isinstance(arm, Mapping) or USE_KEY not in arm:
        return arm
    changes = {k: v for k, v in arm.items() if k != USE_KEY}
    return merge(reference_arm(arm[USE_KEY], source), changes, "arm", source=source)


def expand_config(data: Any, *, source: str | None = None, path: Path | None = None) -> Any:
    """A config's mapping with its ``extends`` and ``arm.use`` resolved (module docstring).

    Args:
        data: The mapping read from the file (anything else is returned unchanged).
        source: Where it came from, for messages.
        path: The file it was read from: its ``extends`` are relative to its folder and
            it may not extend itself. ``None``: relative to the current folder.

    Raises:
        ConfigError: ``extends`` names no file and no packaged config, the chain loops
            or is longer than :data:`MAX_EXTENDS`, a file it names does not load, or
            ``arm.use`` names no reference arm; the message says which.
    """
    return expand_config_traced(data, source=source, path=path)[0]


def expand_config_traced(
    data: Any, *, source: str | None = None, path: Path | None = None
) -> tuple[Any, Origins]:
    """:func:`expand_config`, and which file wrote each key of the result (:data:`Origins`).

    A key of the file itself is ``source``'s; a key a config it extends wrote (and the
    file did not change) is that config's file, so an error in it can name the file the
    user must edit. The arm a file names (``arm.use``) is that file's, as it chose it.
    """
    chain = (path.resolve(),) if path is not None else ()
    folder = path.parent if path is not None else Path()
    origins: Origins = {}
    return _expand(data, source, folder, chain, origins), origins


def _expand(
    data: Any, source: str | None, folder: Path, chain: tuple[Path, ...], origins: Origins
) -> Any:
    if not isinstance(data, Mapping):
        return data
    own = dict(data)
    base: dict[str, Any] = {}
    if EXTENDS_KEY in own:
        parent = _extended(own.pop(EXTENDS_KEY), folder, source, chain)
        parent_data = load_yaml_file(parent, what="config")
        if not isinstance(parent_data, Mapping):
            raise ConfigError(str(parent), ["top level must be a mapping"])
        chained = (*chain, parent.resolve())
        base = _expand(parent_data, str(parent), parent.parent, chained, origins)
        if parent.parent.resolve() != folder.resolve():
            base = _paths_from(base, parent.parent)
    if "arm" in own:
        own["arm"] = expand_arm(own["arm"], source)
        if isinstance(own["arm"], Mapping) and USE_KEY in data["arm"]:
            base.pop("arm", None)  # a named arm starts afresh
    base = without_stale_size(base, own)
    merged = merge(base, own, source=source)
    _trace(base, own, (), source, origins)
    return merged


def _trace(base: Any, over: Any, path: KeyPath, source: str | None, origins: Origins) -> None:
    """Record in ``origins`` what ``over`` (from ``source``) sets as it merges over ``base``.

    Walks as :func:`merge` does: a key merged into is walked on; a key ``over`` adds, or
    a value or list it replaces, is ``source``'s with all beneath it.
    """
    if isinstance(over, Mapping) and isinstance(base, Mapping):
        for key, value in over.items():
            if key in base:
                _trace(base[key], value, (*path, key), source, origins)
            else:
                claim(origins, (*path, key), source)
    elif isinstance(over, Mapping) and _named_items(base):
        for item in base:
            if item["name"] in over:
                _trace(item, over[item["name"]], (*path, item["name"]), source, origins)
    else:
        claim(origins, path, source)


def claim(origins: Origins, path: KeyPath, source: str | None) -> None:
    """Record ``path`` and all beneath it as written by ``source`` (what was there is gone)."""
    n = len(path)
    for gone in [p for p in origins if p[:n] == path]:
        del origins[gone]
    origins[path] = source


def origin(origins: Origins, path: KeyPath) -> str | None:
    """The one file that wrote ``path`` and what is beneath it, else ``None``.

    A key is the file's that wrote it, or wrote it whole further up (a list, a section
    the config it extends did not have); a section several files wrote into is no one
    file's (``None``).
    """
    n = len(path)
    beneath = {source for p, source in origins.items() if p[:n] == path}
    if beneath:
        return beneath.pop() if len(beneath) == 1 else None
    for depth in range(n - 1, 0, -1):
        if path[:depth] in origins:
            return origins[path[:depth]]
    return None


def _extended(name: Any, folder: Path, source: str | None, chain: tuple[Path, ...]) -> Path:
    """The file ``extends: name`` names (relative to ``folder``, else a packaged config)."""
    if not isinstance(name, str) or not name.strip():
        raise ConfigError(
            source,
            [f"{EXTENDS_KEY}: expected a config file's path or name, got {short_repr(name)}"],
        )
    given = folder / name
    if given.is_symlink() and not given.is_file():  # a link here that leads to no file
        try:
            given.stat()
        except OSError as exc:  # a loop, a dangling link: said as --config says it
            raise ConfigError(
                source,
                [
                    f"{EXTENDS_KEY}: cannot open {short_repr(name)} (looked for {given}): "
                    f"{exc.strerror or exc}"
                ],
            ) from None
    path = given if given.is_file() else packaged_config(name)
    if path is None:
        raise ConfigError(
            source,
            [
                f"{EXTENDS_KEY}: {short_repr(name)} is not a file (looked for {given}) and no "
                f"packaged config has that name (packaged: {', '.join(config_names())})"
            ],
        )
    seen = [p.name for p in chain]
    if path.resolve() in chain:
        loop = " -> ".join([*seen, path.name])
        raise ConfigError(source, [f"{EXTENDS_KEY}: the configs extend each other ({loop})"])
    if len(chain) >= MAX_EXTENDS:
        raise ConfigError(
            source, [f"{EXTENDS_KEY}: more than {MAX_EXTENDS} configs in one chain ({seen[0]} …)"]
        )
    return path


def _paths_from(data: dict[str, Any], folder: Path) -> dict[str, Any]:
    """``data`` with its relative :data:`FILE_KEYS` made absolute from ``folder``."""
    out = dict(data)
    for section, key in FILE_KEYS:
        part = out.get(section)
        if isinstance(part, Mapping) and names_a_file(section, key, part):
            out[section] = {**part, key: str(folder.absolute() / part[key])}
    return out


__all__ = [
    "EXTENDS_KEY",
    "FILE_KEYS",
    "MAX_EXTENDS",
    "USE_KEY",
    "KeyPath",
    "Origins",
    "claim",
    "expand_arm",
    "expand_config",
    "expand_config_traced",
    "merge",
    "names_a_file",
    "origin",
    "reference_arm",
]
