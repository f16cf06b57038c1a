"""A config from a mapping: ``extends`` and ``arm.use`` → ``--set`` → validated :class:`Config`.

Files are read by :mod:`mearm.config.files` (YAML text → mapping, then here); what the
mapping builds on (another config, a reference arm) is merged in first
(:mod:`mearm.config.compose`).

An override is ``dotted.key=value``: the path walks mappings by key and lists by index
or, for lists of named items (joints, classes, tool actuators), by name —
``arm.joints.shoulder.limits.max=140``, ``task.classes.red.bin_cm=[-20,30,20]``. The value
is read as YAML (``1.5``, ``true``, ``[1, 2]``, ``{min: 0, max: 90}``). Overrides are
applied before validation, so a bad one gets the same one-line error as a bad file. A
relative file path an override gives is relative to the current folder (one a config
file gives: to that file's folder).
"""

from __future__ import annotations

import copy
import functools
import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TypeGuard

from pydantic import ValidationError
from pydantic_core import ErrorDetails

from mearm.config.base import (
    MAX_LENGTH_CM,
    NOT_A_NUMBER,
    describe_error,
    example_file,
    loc_text,
    short_repr,
)
from mearm.config.compose import (
    CALIBRATION,
    EXTENDS_KEY,
    FILE_KEYS,
    HOMOGRAPHY,
    IMAGE_SIZE,
    USE_KEY,
    KeyPath,
    Origins,
    claim,
    expand_config_traced,
    names_a_file,
    origin,
)
from mearm.config.root import CONFIG_GIVEN, Config
from mearm.data import doc_page, packaged_arm
from mearm.errors import ConfigError
from mearm.yamlio import MAX_YAML_DEPTH, load_yaml_text

#: Longest ``--set`` key [characters]; the longest real one has ~40.
MAX_KEY_CHARS = 200
_INDEX = re.compile(r"^-?[0-9]{1,9}$")
#: What errors of overrides are said of, by default: the argument of the Python call
#: (:func:`~mearm.config.files.load_config`'s ``overrides``); a command passes its flag,
#: ``--set``.
OVERRIDES = "overrides"


def override_example(text: str, overrides_as: str) -> str:
    """The override ``text`` as it is given where ``overrides_as`` names.

    ``--set 'twin.faults=[{at_s: 1}]'`` for a flag (a word that starts with ``-``),
    ``overrides=['twin.faults=[{at_s: 1}]']`` for an argument.
    """
    if overrides_as.startswith("-"):
        import shlex  # noqa: PLC0415  (an empty list's error only: the sort leaves it out)

        return f"{overrides_as} {shlex.quote(text)}"
    return f"{overrides_as}=[{text!r}]"


def _check_utf8(text: str, overrides_as: str) -> None:
    r"""Refuse an override typed in bytes that are not UTF-8, naming the first of them.

    Python holds such bytes of a command line as surrogates (0xE9 as U+DCE9), which no
    config can hold: ``--set $'task.name=\xe9'`` from a Latin-1 terminal. YAML called
    the byte a control character; pydantic, a key "not a unicode string".

    Raises:
        ConfigError: ``text`` holds a byte that is not UTF-8.
    """
    at = next((i for i, c in enumerate(text) if "\udc80" <= c <= "\udcff"), None)
    if at is None:
        return
    shown = text.encode("utf-8", "surrogateescape")
    raise ConfigError(
        overrides_as,
        [
            f"{short_repr(shown)[1:]}: not UTF-8 text (byte 0x{ord(text[at]) - 0xDC00:02X} "
            f"at character {at + 1}): keys and values are UTF-8; a terminal in another "
            "encoding (Latin-1) sends other bytes: use a UTF-8 one, or set a value that is "
            "ASCII"
        ],
    )


def parse_override(text: str, overrides_as: str = OVERRIDES) -> tuple[list[str], Any]:
    """Split ``dotted.key=value`` into the path and the YAML-parsed value.

    ``overrides_as`` is what the override's error is said of: where it was given
    (:data:`OVERRIDES`, a command's ``--set``).

    Raises:
        ConfigError: text that is not UTF-8, no ``=``, an empty key, or a value that is
            not YAML.
    """
    _check_utf8(text, overrides_as)
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key or any(not part for part in key.split(".")):
        raise ConfigError(
            overrides_as,
            [f"{short_repr(text)}: expected dotted.key=value, e.g. arm.joints.base.home=90"],
        )
    bracket = re.search(r"\[([^\]]*)\]", key)
    if bracket is not None:  # a list item as Python or jq writes it
        dotted = (key[: bracket.start()] + "." + bracket.group(1) + key[bracket.end() :]).strip(".")
        raise ConfigError(
            overrides_as,
            [
                f"{short_repr(key)}: a list item is a dotted part, by its index or its "
                f"name: {dotted}"
            ],
        )
    parts = key.split(".")
    if len(key) > MAX_KEY_CHARS or len(parts) > MAX_YAML_DEPTH:
        raise ConfigError(
            overrides_as,
            [
                f"{short_repr(key)}: key too long (at most {MAX_KEY_CHARS} characters and "
                f"{MAX_YAML_DEPTH} parts)"
            ],
        )
    if not raw.strip():
        return parts, ""
    try:
        value = load_yaml_text(
            raw, source=overrides_as, what=f"{overrides_as} value", allow_empty=True
        )
    except ConfigError as exc:
        problem = exc.problems[0] if exc.problems else "?"
        raise ConfigError(
            overrides_as, [f"{key}: value {short_repr(raw, 40)} is not valid YAML ({problem})"]
        ) from None
    return parts, value


def _child(
    node: Any, default: Any, part: str, where: str, then: str, text: str, overrides_as: str
) -> tuple[Any, Any]:
    """The child ``part`` of ``node`` and of its default (created from it when missing).

    ``then`` is the part that follows: a missing section with no default that is followed
    by index ``0`` is made a list of one new item (``hue_bands_deg.0.lo_deg=50`` on a
    class that has no bands), which borrows no values from anywhere.
    """
    if isinstance(node, dict):
        sub_default = default.get(part) if isinstance(default, dict) else None
        if node.get(part) is None:  # missing, or null ("twin.lamp: null"): made, as asked
            if sub_default is not None:
                node[part] = copy.deepcopy(sub_default)
            else:
                node[part] = [{}] if then == "0" else {}
        return node[part], sub_default
    if isinstance(node, list):
        i = _index(node, part, where, text, overrides_as)
        return node[i], _same_item(node[i], default)
    raise ConfigError(overrides_as, [f"{where}: is a value, not a section (cannot set {part!r})"])


def _same_item(item: Any, default: Any) -> Any:
    """The built-in item ``item`` stands for: the one of its name, else ``None``.

    Never the item at the same index: the user's first class is not the built-in red, and
    a class or band the built-in config does not have borrows no values.
    """
    name = item.get("name") if isinstance(item, dict) else None
    if name is None or not isinstance(default, list):
        return None
    return next((d for d in default if isinstance(d, dict) and d.get("name") == name), None)


def _index(items: list[Any], part: str, where: str, text: str, overrides_as: str) -> int:
    """The index of the item ``part`` (an index or a name) of the list at ``where``.

    Raises:
        ConfigError: no such item; for an empty list, how to give the list whole
            (``text``, the override, shows what it sets).
    """
    if not items:
        raise _empty_list(part, where, text, overrides_as)
    if _INDEX.match(part):
        i = int(part)
        if not 0 <= i < len(items):
            raise ConfigError(overrides_as, [f"{where}.{part}: no such item (0…{len(items) - 1})"])
        return i
    for i, item in enumerate(items):
        if isinstance(item, dict) and item.get("name") == part:
            return i
    names = [str(it.get("name")) for it in items if isinstance(it, dict) and "name" in it]
    allowed = ", ".join(names) if names else f"an index 0…{len(items) - 1}"
    raise ConfigError(
        overrides_as, [f"{where}.{part}: no item named {part!r} (choices: {allowed})"]
    )


def _empty_list(part: str, where: str, text: str, overrides_as: str) -> ConfigError:
    """The error of ``--set TEXT`` that names item ``part`` of the empty list at ``where``.

    An empty list has no item to change: the list is set whole, with the item ``text``
    sets as its one item (``twin.faults.0.at_s=1``: ``twin.faults=[{at_s: 1}]``).
    """
    key, _, raw = text.partition("=")
    rest = key.strip().split(".")[len(where.split(".")) + 1 :]
    item = raw.strip() or '""'
    if any(_INDEX.match(name) for name in rest):  # a list inside the item: not spelt out
        item = "{...}"
    else:
        for name in reversed(rest):
            item = f"{{{name}: {item}}}"
    what = f"no item {part}" if _INDEX.match(part) else f"no item named {part!r}"
    return ConfigError(
        overrides_as,
        [
            f"{where}.{part}: {what}: {where} is an empty list; set the whole list "
            f"instead, e.g. {override_example(f'{where}=[{item}]', overrides_as)}"
        ],
    )


def apply_overrides(
    data: dict[str, Any],
    overrides: Sequence[str],
    defaults: dict[str, Any] | None = None,
    *,
    overrides_as: str = OVERRIDES,
) -> dict[str, Any]:
    """A copy of ``data`` with every ``dotted.key=value`` of ``overrides`` set.

    A section the data leaves out is taken from ``defaults`` (the built-in config) before
    the override changes it, so ``--set arm.joints.base.home=90`` works on a file that
    does not spell out the arm; inside a list item, from the built-in item of its name
    (none for an item the built-in config does not name). A relative file path it sets
    (``servo.calibration_file``, the camera's calibration files, a replayed ``camera.path``)
    is made absolute from the current folder. One that sets ``calibration.homography`` (or
    an entry of it), with none that sets ``calibration.image_size_px``, leaves the
    homography of unknown size (:func:`~mearm.config.compose.without_stale_size`). Its
    errors are said of ``overrides_as`` (:func:`parse_override`).

    Raises:
        ConfigError: a malformed override, a list index or name that does not exist.
    """
    out = copy.deepcopy(data)
    for text in overrides:
        path, value = parse_override(text, overrides_as)
        composed = _composed(tuple(path), overrides_as)
        if composed is not None:  # read as the file is composed, before --set applies
            raise ConfigError(overrides_as, [f"{'.'.join(path)}: {composed}"])
        node: Any = out
        default: Any = defaults
        for depth, part in enumerate(path[:-1]):
            where = ".".join(path[:depth]) or "(top level)"
            node, default = _child(node, default, part, where, path[depth + 1], text, overrides_as)
        last, where = path[-1], ".".join(path[:-1]) or "(top level)"
        if isinstance(node, dict):
            node[last] = value
        elif isinstance(node, list):
            i = _index(node, last, where, text, overrides_as)
            if isinstance(node[i], dict) and not isinstance(value, dict):
                raise ConfigError(
                    overrides_as,
                    [
                        f"{where}.{last}: is a whole item, not a value: set one of its keys "
                        f"({where}.{last}.KEY=VALUE), or give it as a mapping {{...}}"
                    ],
                )
            node[i] = value
        else:
            raise ConfigError(overrides_as, [f"{where}: is a value, not a section"])
        _paths_from_here(out, path)
    paths = [parse_override(text, overrides_as)[0] for text in overrides]
    if any(p[:2] == [CALIBRATION, HOMOGRAPHY] for p in paths) and not any(
        p[:2] == [CALIBRATION, IMAGE_SIZE] for p in paths
    ):  # a homography set by hand is of unknown size, as one a file gives without it
        cal = out.get(CALIBRATION)
        if isinstance(cal, dict):
            cal.pop(IMAGE_SIZE, None)
    return out


def _composed(path: tuple[str, ...], overrides_as: str) -> str | None:
    """What an override of ``path`` is told, if it is a key read as a file is composed.

    Such a key (``extends``, ``arm.use``) is read before overrides apply; ``None`` for any
    other. In the words of ``overrides_as``: a command's flag (``--set``, then its config
    is ``--config``) or the Python call's argument.
    """
    flag = overrides_as.startswith("-")
    if path == (EXTENDS_KEY,):
        instead = "give that config as --config" if flag else "load that config instead"
        return (
            f"the config a file builds on is named in the file, not by {overrides_as}: "
            f"{instead}, or write extends: in your file"
        )
    if path == ("arm", USE_KEY):
        changes = f"{overrides_as} changes" if flag else "an override changes"
        return (
            "the reference arm a config builds on is named in its file (arm: {use: NAME}), "
            f"not by {overrides_as}; {changes} the keys of the arm it names"
        )
    return None


def file_keys_set(overrides: Sequence[str], overrides_as: str = OVERRIDES) -> set[str]:
    """The file-path keys (:data:`~mearm.config.compose.FILE_KEYS`) ``overrides`` set.

    Raises:
        ConfigError: a malformed override (said of ``overrides_as``).
    """
    paths = [parse_override(text, overrides_as)[0] for text in overrides]
    return {
        f"{section}.{key}"
        for section, key in FILE_KEYS
        if any(path in ([section, key], [section]) for path in paths)
    }


def _paths_from_here(data: dict[str, Any], path: list[str]) -> None:
    """Make a file path that ``--set`` just gave absolute from the current folder.

    A path typed on the command line means what the shell means by it (the file
    ``calibrate-servos --output F`` just wrote there), not a path beside the config file.
    """
    for section, key in FILE_KEYS:
        part = data.get(section)
        if path in ([section, key], [section]) and isinstance(part, dict):
            if names_a_file(section, key, part):
                part[key] = str(Path(part[key]).absolute())


def config_from_dict(
    data: Any,
    *,
    source: str | None = None,
    overrides: Sequence[str] = (),
    path: Path | None = None,
    overrides_as: str = OVERRIDES,
    given: tuple[str, bool] | None = None,
) -> Config:
    """Validate a mapping into a :class:`Config`.

    Its ``extends`` and ``arm.use`` are resolved first
    (:func:`~mearm.config.compose.expand_config`), then ``overrides`` applied.

    Args:
        data: The mapping, as read from a config file.
        source: Where it came from, for messages.
        overrides: ``dotted.key=value`` strings.
        path: The file it was read from: its ``extends`` are relative to its folder
            (``None``: to the current folder).
        overrides_as: What a bad override is said of: where ``overrides`` were given
            (the Python call's ``overrides``; a command's ``--set``).
        given: The config as the user named it (``--config``'s value) and whether it is
            one mearm ships, for the messages that say what to run on it.

    Raises:
        ConfigError: one line per bad field.
    """
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(source, [f"top level must be a mapping, got {type(data).__name__}"])
    data, origins = expand_config_traced(data, source=source, path=path)
    own = data
    if overrides:
        data = apply_overrides(data, overrides, _default_data(), overrides_as=overrides_as)
    try:
        return Config.model_validate(data, context={CONFIG_GIVEN: given})
    except ValidationError as exc:
        typed = _typed_values(overrides)
        errors = exc.errors()
        problems = [_in_user_words(e, data, typed) for e in errors]
        if overrides and _valid(own):  # the file is good: a --set value is what is wrong
            raise ConfigError(overrides_as, [*unit_hints(data), *problems]) from None
        for text in overrides:  # a key --set gave is said of the file, as the file is bad
            claim(origins, _key_path(parse_override(text, overrides_as)[0], data), source)
        written = [_written_in(e, data, origins) or source for e in errors]
        raise _named_error(source, unit_hints(data), problems, written) from None


def _written_in(err: ErrorDetails, data: Any, origins: Origins) -> str | None:
    """The file that wrote the key of ``err`` (a config the file extends), else ``None``.

    A model's check that names a key inside it (``@task.classes: …``) is that key's.
    """
    loc: list[Any] = list(err["loc"])
    msg = err["msg"].removeprefix("Value error, ")
    if msg.startswith("@"):
        loc += msg[1:].partition(": ")[0].split(".")
    return origin(origins, _key_path(loc, data))


def _key_path(loc: Sequence[Any], data: Any) -> KeyPath:
    """``loc`` (pydantic's, or a ``--set`` key's parts) as :data:`Origins` hold it.

    An item of a list of named items is its name; any other item its index.
    """
    out: list[Any] = []
    node = data
    for part in loc:
        if isinstance(node, list):
            item: Any = None
            if isinstance(part, str) and _INDEX.match(part):
                part = int(part)
            if isinstance(part, int) and -len(node) <= part < len(node):
                part %= len(node)
                item = node[part]
            else:
                item = next((it for it in node if _name_of(it) == part), None)
            name = _name_of(item)
            out.append(name if name is not None else part)
            node = item
        elif _is_tag(node, part):
            continue
        elif isinstance(node, dict) and part in node:
            out.append(part)
            node = node[part]
        else:
            out.append(part)
            node = None
    return tuple(out)


def _name_of(item: Any) -> str | None:
    """The name of a list item of a list of named items, else ``None``."""
    name = item.get("name") if isinstance(item, dict) else None
    return name if isinstance(name, str) else None


def _named_error(
    source: str | None, hints: list[str], problems: list[str], written: list[str | None]
) -> ConfigError:
    """The error of ``problems``, each said of the file its key was written in.

    ``written[i]`` is the file of ``problems[i]``. Problems all of one file name that
    file; problems of several files name ``source`` (the file given), and each of another
    file is led by that file's name.
    """
    if len(set(written)) == 1:
        return ConfigError(written[0], [*hints, *problems])
    led = [p if f == source else f"{f}: {p}" for p, f in zip(problems, written, strict=True)]
    return ConfigError(source, [*hints, *led])


def _valid(data: Any) -> bool:
    """Whether ``data`` validates (asked on the error path only)."""
    try:
        Config.model_validate(data)
    except ValidationError:
        return False
    return True


def _named_loc(loc: Sequence[int | str], data: Any) -> tuple[int | str, ...]:
    """``loc`` with each index into a list of named items replaced by the item's name.

    ``("arm", "joints", 1, "dh")`` → ``("arm", "joints", "shoulder", "dh")``: the path a
    user writes (and ``--set`` takes). The tag pydantic puts after an item of several
    kinds is left out: ``("twin", "faults", 0, "limp_servo", "foo")`` →
    ``("twin", "faults", 0, "foo")``.
    """
    out: list[int | str] = []
    node = data
    for part in loc:
        if isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
            item = node[part]
            name = item.get("name") if isinstance(item, dict) else None
            out.append(name if isinstance(name, str) and name.isidentifier() else part)
            node = item
        elif _is_tag(node, part):
            continue
        elif isinstance(node, dict) and part in node:
            out.append(part)
            node = node[part]
        else:
            out.append(part)
            node = None
    return tuple(out)


#: The key that tells the kinds of a list's items apart (``twin.faults``' ``kind``), whose
#: value pydantic writes into an error's path after the item.
TAG_KEY = "kind"


def _is_tag(node: Any, part: int | str) -> bool:
    """Whether ``part`` of an error's path is the tag of the item ``node``, not its key."""
    return isinstance(node, dict) and part not in node and node.get(TAG_KEY) == part


def _shown(loc: Sequence[int | str]) -> bool:
    """Whether the shipped file writes out the section at ``loc`` (not null, not empty)."""
    node: Any = _default_data()
    for part in loc:
        if isinstance(node, list):
            node = node[0] if node else None
        elif isinstance(node, dict) and part in node:
            node = node[part]
        else:
            return False
    if isinstance(node, list):
        node = node[0] if node else None
    return isinstance(node, dict)


def _arm_file(data: Any, section: Sequence[int | str]) -> str:
    """The reference arm file the config's arm was made from, as the user can open it.

    The arm of a reference arm's name, else the reference arm it matches best (a copy of
    ``mearm_v1.yaml`` under another name, or ``use: mearm_v1`` with a name of its own, is
    mostly that arm's values), else the built-in arm's. A file that does not write out
    ``section`` (pydantic's path to the unknown key's mapping) shows the built-in arm's.
    """
    from mearm.config.compose import reference_arm  # noqa: PLC0415  (an unknown key only)
    from mearm.config.defaults import DEFAULT_ARM  # noqa: PLC0415
    from mearm.data import arm_names  # noqa: PLC0415

    arm = data.get("arm") if isinstance(data, dict) else None
    name = arm.get("name") if isinstance(arm, dict) else None
    if not (isinstance(name, str) and packaged_arm(name) is not None):
        name = _closest_arm(arm, {n: reference_arm(n) for n in arm_names()})
    if name is None or not _writes_out(reference_arm(name), section[1:]):
        name = DEFAULT_ARM
    return example_file(name)


def _leaves(node: Any, path: tuple[Any, ...] = ()) -> dict[tuple[Any, ...], Any]:
    """Every value of ``node`` by its path, a named list item by its name."""
    if isinstance(node, dict):
        items = list(node.items())
    elif isinstance(node, list):
        items = [(_name_of(value) or i, value) for i, value in enumerate(node)]
    else:
        return {path: node}
    out: dict[tuple[Any, ...], Any] = {}
    for key, value in items:
        out.update(_leaves(value, (*path, key)))
    return out


def _closest_arm(arm: Any, references: dict[str, Any]) -> str | None:
    """The reference arm that shares the most of ``arm``'s values, if one does.

    One arm, with at least half of ``arm``'s values; ``None`` for a tie or an arm that is
    mostly its own (then no reference arm is more its pattern than another).
    """
    mine = _leaves(arm)
    shared = {
        name: sum(1 for path, value in _leaves(ref).items() if mine.get(path, ...) == value)
        for name, ref in references.items()
    }
    best = max(shared.values(), default=0)
    names = [name for name, count in shared.items() if count == best]
    return names[0] if len(names) == 1 and 2 * best >= len(mine) > 0 else None


def _writes_out(node: Any, section: Sequence[int | str]) -> bool:
    """Whether ``node`` (a reference arm's file) writes the mapping at ``section``.

    Across a list, any item that writes it will do.
    """
    if isinstance(node, list):
        return any(_writes_out(item, section[1:]) for item in node)
    if not section:
        return isinstance(node, dict)
    return isinstance(node, dict) and _writes_out(node.get(section[0]), section[1:])


def _typed_values(overrides: Sequence[str]) -> dict[tuple[str, ...], str]:
    """Each key ``overrides`` set, as its parts, to the value as typed (the last one's).

    A key set again, or inside a section set after it, shows what was typed last.
    """
    typed: dict[tuple[str, ...], str] = {}
    for text in overrides:
        key, _, raw = text.partition("=")
        path = tuple(part.strip() for part in key.strip().split("."))
        typed = {k: v for k, v in typed.items() if k[: len(path)] != path}
        typed[path] = raw.strip()
    return typed


def _in_user_words(
    err: ErrorDetails, data: Any, typed: dict[tuple[str, ...], str] | None = None
) -> str:
    """One line for one pydantic error, in the words of the user's file or ``--set``.

    Joints, classes and tool actuators by name, not index; an unknown key with the key
    it most likely meant and the file that shows every key of its section; a boolean
    given for a number as ``--set`` typed it (``'yes'``: YAML 1.1 reads it as true).
    """
    loc = _named_loc(err["loc"], data)
    if err["type"] == NOT_A_NUMBER and typed:
        for path in (loc, err["loc"]):
            raw = typed.get(tuple(str(part) for part in path))
            if raw is not None and raw not in ("true", "false"):  # those read as typed
                return f"{loc_text(loc)}: expected a number, got {short_repr(raw)}"
    if err["type"] in ("union_tag_not_found", "union_tag_invalid"):
        return _tag_error(err, loc)
    if err["type"] != "extra_forbidden":
        return describe_error({**err, "loc": loc})
    *section, key = loc
    import difflib  # noqa: PLC0415  (an unknown key only)

    from mearm.config.schema_doc import section_keys  # noqa: PLC0415  (an unknown key only)

    anchor, allowed = section_keys(err["loc"][:-1]) or ("", [])
    composed: dict[tuple[int | str, ...], list[str]] = {(): [EXTENDS_KEY], ("arm",): [USE_KEY]}
    allowed += composed.get(tuple(section), [])  # the keys read away as the file is composed
    close = difflib.get_close_matches(str(key), allowed, n=1, cutoff=0.6)
    meant = f"; did you mean {close[0]}?" if close else ""
    if not _shown(err["loc"][:-1]):  # null or empty in the shipped file: the docs show it
        where = (
            f"{doc_page('configuration.md')}#{anchor}" if anchor else doc_page("configuration.md")
        )
    elif loc and loc[0] == "arm":
        where = _arm_file(data, err["loc"][:-1])
    else:
        where = example_file()
    return f"{loc_text(loc)}: unknown key{meant} ({where} shows every key)"


def _tag_error(err: ErrorDetails, loc: Sequence[int | str]) -> str:
    """A list item whose ``kind`` (its union's tag) is missing or none of the kinds.

    ``twin.faults.0.kind: required but missing (one of: limp_servo, …)``.
    """
    from mearm.config.schema_doc import union_tags  # noqa: PLC0415  (a bad kind only)

    key = str((err.get("ctx") or {}).get("discriminator", TAG_KEY)).strip("'\"")
    kinds = ", ".join(union_tags(err["loc"], key))
    item = err.get("input")
    if err["type"] == "union_tag_not_found" or not isinstance(item, dict) or key not in item:
        return f"{loc_text((*loc, key))}: required but missing (one of: {kinds})"
    return f"{loc_text((*loc, key))}: expected one of: {kinds} (got {short_repr(item[key])})"


#: A link longer than this is no hobby arm's [cm]: written in mm, an 8 cm link reads 80.
MM_SUSPECT_CM = 60.0


def millimetre_hint(data: Any) -> str | None:
    """A hint when the arm's link lengths look like millimetres, else ``None``.

    Hobby arms' links are a few to 30 cm; a DH ``a_cm`` or ``d_cm`` over
    :data:`MM_SUSPECT_CM` (and within the bound a length may have) is most likely a
    length in mm. So is a prismatic joint's limit past it: the rail's variable is its
    row's d, in cm, and a lift of 4…16 cm written ``{min: 40, max: 160}`` is the same
    mistake.
    """
    arm = data.get("arm") if isinstance(data, dict) else None
    joints = arm.get("joints") if isinstance(arm, dict) else None
    if not isinstance(joints, list):
        return None
    long = []
    for k, joint in enumerate(joints):
        dh = joint.get("dh") if isinstance(joint, dict) else None
        for key in ("a_cm", "d_cm"):
            value = dh.get(key) if isinstance(dh, dict) else None
            # beyond MAX_LENGTH_CM (inf, 1e300) no unit explains it: the bound's error alone
            if isinstance(value, int | float) and MM_SUSPECT_CM < abs(value) <= MAX_LENGTH_CM:
                name = joint.get("name", k)
                long.append(f"{name}.dh.{key} = {value:g}")
        limits = joint.get("limits") if isinstance(joint, dict) else None
        low = limits.get("min") if isinstance(limits, dict) else None
        high = limits.get("max") if isinstance(limits, dict) else None
        if (
            isinstance(joint, dict)
            and joint.get("type") == "prismatic"
            and _number(low)
            and _number(high)
            and MM_SUSPECT_CM < max(abs(low), abs(high)) <= MAX_LENGTH_CM
        ):
            long.append(f"{joint.get('name', k)}.limits = [{low:g}, {high:g}]")
    if not long:
        return None
    return (
        f"arm.joints: {', '.join(long)}: lengths are in cm; these look like mm "
        f"(8 cm is 8.0, not 80)"
    )


#: How near a multiple of π/2 a DH angle [rad] must be to read as one (1.57 and 1.5708 do).
RADIAN_TOLERANCE = 0.002
#: A full turn [rad], the largest angle a radian DH angle or limit is read as.
_TURN = 2 * math.pi


def radian_hint(data: Any) -> str | None:
    """A hint when the arm's angles look like radians, else ``None``.

    Said only where no arm in degrees writes the value, so a hint is never a false alarm
    (every reference arm and shipped config gives none, ``tests/test_r5_t2_units.py``):

    - a DH ``alpha_deg`` or ``theta_deg`` within :data:`RADIAN_TOLERANCE` of ±π/2, ±π,
      ±3π/2 or ±2π (``1.5708``, ``3.1416``): the right angles a DH row is made of,
      written in radians; 1.57° or 3.14° is no angle an arm's frames are built at.
    - an actuated revolute joint whose limits both lie within ±2π (``{min: -2.6, max:
      -0.17}``): a whole range of travel under 13° about the zero is no servo joint's,
      while every range in radians is within a turn.
    """
    arm = data.get("arm") if isinstance(data, dict) else None
    joints = arm.get("joints") if isinstance(arm, dict) else None
    if not isinstance(joints, list):
        return None
    found = []
    for k, joint in enumerate(joints):
        if not isinstance(joint, dict):
            continue
        name = joint.get("name", k)
        dh = joint.get("dh")
        for key in ("alpha_deg", "theta_deg"):
            value = dh.get(key) if isinstance(dh, dict) else None
            if _number(value) and _right_angle_in_radians(value):
                found.append(f"{name}.dh.{key} = {value:g}")
        limits = joint.get("limits")
        low = limits.get("min") if isinstance(limits, dict) else None
        high = limits.get("max") if isinstance(limits, dict) else None
        if (
            joint.get("type", "revolute") == "revolute"
            and joint.get("coupling") is None  # a passive joint's limits are derived
            and _number(low)
            and _number(high)
            and low < high
            and max(abs(low), abs(high)) <= _TURN + RADIAN_TOLERANCE
        ):
            found.append(f"{name}.limits = [{low:g}, {high:g}]")
    if not found:
        return None
    return (
        f"arm.joints: {', '.join(found)}: angles are in degrees; these look like radians "
        "(90° is 90.0, not 1.5708)"
    )


def _number(value: Any) -> TypeGuard[float]:
    """Whether ``value`` is a finite number (not a boolean: YAML's ``yes`` is refused)."""
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _right_angle_in_radians(value: float) -> bool:
    """Whether ``value`` is ±π/2, ±π, ±3π/2 or ±2π, to :data:`RADIAN_TOLERANCE`."""
    quarters = round(abs(value) / (math.pi / 2))
    return 1 <= quarters <= 4 and abs(abs(value) - quarters * math.pi / 2) <= RADIAN_TOLERANCE


def unit_hints(data: Any) -> list[str]:
    """The arm's unit hints: lengths that look like mm, angles that look like radians."""
    return [h for h in (millimetre_hint(data), radian_hint(data)) if h is not None]


@functools.cache
def _default_data() -> dict[str, Any]:
    """The built-in config as data (read only: :func:`apply_overrides` copies what it takes)."""
    return Config().model_dump(mode="json")
