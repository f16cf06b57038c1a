"""Reading the project's YAML and other input files so that no input can hurt.

Every YAML file mearm reads (configs, scenes, ``--set`` values, the calibration tool's
config) goes through :func:`load_yaml_file` or :func:`load_yaml_text`. They refuse,
each with one line naming the file, the place and what to do:

- anything but a regular file (``/dev/zero``, a FIFO, a directory), before reading it;
- a file over :data:`MAX_YAML_BYTES`, without reading more than that;
- text that is not UTF-8, or holds control characters (YAML's printable set only);
- an empty document (no config silently becomes the default);
- a mapping with the same key twice;
- a tag other than the plain ones (``!!str``, ``!!int``, ``!!float``, ``!!bool``,
  ``!!null``, ``!!seq``, ``!!map``): no ``!!python/…``, ``!!binary``, ``!!timestamp`` or
  local tags; dates stay strings;
- nesting deeper than :data:`MAX_YAML_DEPTH`, more than :data:`MAX_YAML_ALIASES`
  aliases, a recursive alias, or more than :data:`MAX_YAML_NODES` values once every
  alias is expanded (the "billion laughs" bomb).

The limits are checked while the document is composed, before any Python object is
built: composing descends one level per nesting level and refuses the first level past
the cap, so a 10 000-deep nesting (the parser itself keeps no stack in Python) or an
alias bomb is refused in milliseconds, never a RecursionError or a MemoryError.

Parsing uses libyaml when PyYAML was built with it, as an accelerator only: the rules
are mearm's, not the parser's. libyaml reads up to 1 024 characters ahead of the event
being composed and has limits of its own (PyYAML 6.0.4's refuses nesting past 1 000
levels in its own words), so when libyaml fails, the document is read again with
PyYAML's pure-Python parser, whose scanner also counts the open collections and refuses
the first one past :data:`MAX_YAML_DEPTH`. Whatever the PyYAML version, a document is
refused by mearm's rule and message first, and one that only libyaml refuses is read.
"""

from __future__ import annotations

import os
import re
import stat
from pathlib import Path
from typing import Any

import yaml
from yaml.composer import Composer
from yaml.constructor import SafeConstructor
from yaml.events import (
    AliasEvent,
    MappingEndEvent,
    MappingStartEvent,
    ScalarEvent,
    SequenceEndEvent,
    SequenceStartEvent,
)
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode
from yaml.parser import Parser
from yaml.reader import Reader
from yaml.resolver import Resolver
from yaml.scanner import Scanner

from mearm.errors import ConfigError, InputFileError

try:  # libyaml: the C scanner and parser (the events are the same)
    from yaml._yaml import CParser as _CParser
except ImportError:  # pragma: no cover - PyYAML built without libyaml
    _CParser = None


#: Largest YAML file read [bytes]. The reference configs are ~10 kB; a scene of the
#: largest allowed size is ~30 kB.
MAX_YAML_BYTES = 1 << 20
#: Deepest nesting of mappings and lists. A config's deepest key path has 6 levels
#: (``arm.joints.0.servo.channel``, the homography's rows).
MAX_YAML_DEPTH = 32
#: Most aliases (``*name``) in one document. Configs use none; a few are handy.
MAX_YAML_ALIASES = 100
#: Most values in one document, counting every alias's expansion in full. A config has
#: ~300; the largest allowed scene ~2 000.
MAX_YAML_NODES = 100_000
#: A value shown in a message is cut to this many characters.
SHOWN_CHARS = 60

#: Characters YAML 1.1 allows in a stream (its c-printable set); anything else is refused
#: by mearm before a parser sees it.
_NOT_PRINTABLE = re.compile(
    "[^\x09\x0a\x0d\x20-\x7e\x85\xa0-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]"
)

_TAG = "tag:yaml.org,2002:"
#: Tags a document may carry, explicitly (``!!int 3``) or as resolved.
ALLOWED_TAGS = frozenset(_TAG + t for t in ("str", "int", "float", "bool", "null", "seq", "map"))
_MERGE = _TAG + "merge"


class _Resolver(Resolver):
    """The YAML 1.1 resolver without timestamps and ``=`` (they stay strings)."""


_Resolver.yaml_implicit_resolvers = {
    first: [(tag, rx) for tag, rx in resolvers if tag not in (_TAG + "timestamp", _TAG + "value")]
    for first, resolvers in Resolver.yaml_implicit_resolvers.items()
}


class _Refused(yaml.YAMLError):
    """A document that breaks one of the limits (carries the place it was found)."""

    def __init__(self, problem: str, mark: Any):
        super().__init__(problem)
        self.problem = problem
        self.problem_mark = mark


def _cut(text: str, limit: int = SHOWN_CHARS) -> str:
    """``text`` (its repr if it holds unprintable characters) cut to ``limit``."""
    text = text if text.isprintable() else repr(text)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _at(mark: Any) -> str:
    return f"line {mark.line + 1}, column {mark.column + 1}" if mark is not None else "?"


def _too_deep(mark: Any) -> _Refused:
    return _Refused(f"nested deeper than {MAX_YAML_DEPTH} levels", mark)


class _ReferenceParser(Reader, Scanner, Parser):
    """PyYAML's pure-Python parser, whose scanner refuses collections past the cap.

    Every open block collection holds one indentation level and every open flow
    collection one flow level, so their sum never exceeds the document's nesting depth:
    the scanner refuses only what the composer would, but before reading further ahead.
    """

    def __init__(self, stream: str):
        Reader.__init__(self, stream)
        Scanner.__init__(self)
        Parser.__init__(self)

    def _check_depth(self) -> None:
        if len(self.indents) + self.flow_level > MAX_YAML_DEPTH:
            raise _too_deep(self.get_mark())

    def add_indent(self, column: int) -> bool:
        added: bool = Scanner.add_indent(self, column)
        if added:
            self._check_depth()
        return added

    def fetch_flow_collection_start(self, TokenClass: Any) -> None:  # noqa: N803 - PyYAML's name
        Scanner.fetch_flow_collection_start(self, TokenClass)
        self._check_depth()


class _GuardedLoader(Composer, SafeConstructor, _Resolver):
    """A safe loader that composes under the module's limits (see the module docstring).

    A subclass adds the parser: libyaml's (:class:`_FastLoader`) or PyYAML's own
    (:class:`_ReferenceLoader`).
    """

    def __init__(self, text: str):
        self._init_parser(text)
        SafeConstructor.__init__(self)
        _Resolver.__init__(self)
        Composer.__init__(self)
        self._depth = 0
        self._aliases = 0
        self._nodes = 0  # composed so far, aliases counted expanded
        self._sizes: dict[int, int] = {}  # id(node) → its expanded size
        self._open: set[int] = set()  # collections being composed (a recursive alias)

    def _count(self, n: int, mark: Any) -> None:
        self._nodes += n
        if self._nodes > MAX_YAML_NODES:
            raise _Refused(
                f"more than {MAX_YAML_NODES} values (aliases counted expanded): "
                "an alias bomb, or far more data than a config holds",
                mark,
            )

    def compose_node(self, parent: Node | None, index: Any) -> Node:
        if self.check_event(AliasEvent):
            event = self.get_event()
            self._aliases += 1
            if self._aliases > MAX_YAML_ALIASES:
                raise _Refused(f"more than {MAX_YAML_ALIASES} aliases (*name)", event.start_mark)
            node = self.anchors.get(event.anchor)
            if node is None:
                raise _Refused(f"alias *{_cut(event.anchor)} names no anchor", event.start_mark)
            if id(node) in self._open:
                raise _Refused(f"alias *{_cut(event.anchor)} is recursive", event.start_mark)
            self._count(self._sizes[id(node)], event.start_mark)
            return node
        event = self.peek_event()
        tag = getattr(event, "tag", None)
        if tag is not None and tag != "!" and tag not in ALLOWED_TAGS:
            raise _Refused(
                f"tag {_cut(tag.replace(_TAG, '!!'))} is not allowed (plain values only: "
                "strings, numbers, booleans, null, lists and mappings)",
                event.start_mark,
            )
        if event.anchor is not None and event.anchor in self.anchors:
            raise _Refused(f"anchor &{_cut(event.anchor)} is defined twice", event.start_mark)
        self._count(1, event.start_mark)
        if isinstance(event, ScalarEvent):
            node = self.compose_scalar_node(event.anchor)
            self._sizes[id(node)] = 1
            return node
        self._depth += 1
        if self._depth > MAX_YAML_DEPTH:
            raise _Refused(f"nested deeper than {MAX_YAML_DEPTH} levels", event.start_mark)
        before = self._nodes
        if isinstance(event, SequenceStartEvent):
            node = self._compose_sequence(event)
        elif isinstance(event, MappingStartEvent):
            node = self._compose_mapping(event)
        else:  # pragma: no cover - the parser emits nothing else here
            raise _Refused(f"unexpected {type(event).__name__}", event.start_mark)
        self._depth -= 1
        self._sizes[id(node)] = self._nodes - before + 1
        return node

    def _start(self, kind: type[Node], event: Any) -> Any:
        self.get_event()
        tag = event.tag
        if tag is None or tag == "!":
            tag = self.resolve(kind, None, event.implicit)
        node = kind(tag, [], event.start_mark, None, flow_style=event.flow_style)
        if event.anchor is not None:
            self.anchors[event.anchor] = node
        self._open.add(id(node))
        return node

    def _end(self, node: Node) -> None:
        node.end_mark = self.get_event().end_mark
        self._open.discard(id(node))

    def _compose_sequence(self, event: Any) -> SequenceNode:
        node = self._start(SequenceNode, event)
        index = 0
        while not self.check_event(SequenceEndEvent):
            node.value.append(self.compose_node(node, index))
            index += 1
        self._end(node)
        return node

    def _compose_mapping(self, event: Any) -> MappingNode:
        node = self._start(MappingNode, event)
        seen: dict[Any, Any] = {}
        while not self.check_event(MappingEndEvent):
            key_event = self.peek_event()
            key = self.compose_node(node, None)
            if not isinstance(key, ScalarNode):
                raise _Refused("a key must be a plain value, not a list or mapping", key.start_mark)
            if key.tag != _MERGE:
                ident = (key.tag, self._key_value(key))
                if ident in seen:
                    raise _Refused(
                        f"duplicate key {_cut(repr(key.value))} (first at {_at(seen[ident])}): "
                        "each key may appear once",
                        key_event.start_mark,
                    )
                seen[ident] = key.start_mark
            node.value.append((key, self.compose_node(node, key)))
        self._end(node)
        return node

    def _key_value(self, key: ScalarNode) -> Any:
        if key.tag in (_TAG + "str", "!"):
            return key.value
        try:  # 1 and 0x1, true and yes are the same key
            return self.construct_object(key)
        except (ValueError, yaml.YAMLError):
            return key.value

    def _init_parser(self, text: str) -> None:
        raise NotImplementedError


class _ReferenceLoader(_GuardedLoader, _ReferenceParser):
    """The guarded loader on PyYAML's pure-Python parser: slower, and the reference."""

    def _init_parser(self, text: str) -> None:
        _ReferenceParser.__init__(self, text)


if _CParser is not None:

    class _FastLoader(_GuardedLoader, _CParser):
        """The guarded loader on libyaml's parser: the fast path."""

        def _init_parser(self, text: str) -> None:
            _CParser.__init__(self, text)

    _LOADERS: tuple[type[_GuardedLoader], ...] = (_FastLoader, _ReferenceLoader)
else:  # pragma: no cover - PyYAML built without libyaml
    _LOADERS = (_ReferenceLoader,)


def _describe(exc: yaml.YAMLError) -> str:
    """``at line L, column C: problem`` (or ``: problem`` when the place is unknown)."""
    mark = getattr(exc, "problem_mark", None)
    problem = getattr(exc, "problem", None)
    if isinstance(exc, yaml.reader.ReaderError):
        mark, problem = None, f"{exc.reason} (character #{exc.position + 1})"
    elif problem is None:
        text = str(exc).splitlines()
        problem = text[0] if text else type(exc).__name__
    elif problem == "but found another document":
        problem = "a second document (---): the file must hold one"
    where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
    return f"{where}: {_cut(problem, 160)}"


def load_yaml_text(
    text: str, *, source: str | None = None, what: str = "config", allow_empty: bool = False
) -> Any:
    """Parse one YAML document under the module's limits.

    Args:
        text: The document.
        source: Where it came from, for messages (a path, ``--set``).
        what: What it is, for messages (``config``, ``scene``).
        allow_empty: Return ``None`` for an empty (or ``null``) document instead of
            refusing it.

    Returns:
        Plain Python data: dicts, lists, str, int, float, bool, None.

    Raises:
        ConfigError: malformed YAML or a refused document; the message says where.
    """
    if text.startswith("\ufeff"):
        text = text[1:]
    bad = _NOT_PRINTABLE.search(text)
    if bad is not None:
        line = text.count("\n", 0, bad.start()) + 1
        column = bad.start() - text.rfind("\n", 0, bad.start())
        raise ConfigError(
            source,
            [
                f"malformed YAML at line {line}, column {column}: control characters are not "
                f"allowed (U+{ord(bad.group()):04X}); only printable text, tabs and newlines"
            ],
        )
    for n, loader_class in enumerate(_LOADERS, start=1):
        loader: _GuardedLoader | None = None
        try:
            loader = loader_class(text)  # PyYAML's reader checks the characters here
            node = loader.get_single_node()
            data = None if node is None else loader.construct_document(node)
            break
        except _Refused as exc:
            raise ConfigError(source, [f"refused YAML{_describe(exc)}"]) from None
        except yaml.YAMLError as exc:
            if n < len(_LOADERS):  # libyaml's word is not final: the reference reads it again
                continue
            raise ConfigError(source, [f"malformed YAML{_describe(exc)}"]) from None
        except ValueError as exc:  # an integer of more than 4300 digits (int's own limit)
            problem = "a number too long" if "digits" in str(exc) else _cut(str(exc), 160)
            raise ConfigError(source, [f"malformed YAML: {problem}"]) from None
        finally:
            if loader is not None:
                loader.dispose()
    if data is None and not allow_empty:
        raise ConfigError(
            source, [f"empty {what}: the file holds no YAML document (nothing but comments?)"]
        )
    return data


def _a(noun: str) -> str:
    return f"an {noun}" if noun[:1] in "aeiou" else f"a {noun}"


def read_regular_file(
    path: str | Path, *, max_bytes: int, what: str = "file", head: int | None = None
) -> bytes:
    """The bytes of a regular file of at most ``max_bytes`` (or its first ``head`` bytes).

    Special files (devices such as ``/dev/zero``, FIFOs, sockets) and directories are
    refused before a byte is read; at most ``max_bytes + 1`` bytes are ever read.

    Raises:
        InputFileError: missing, unreadable, not a regular file, or too large.
    """
    p = Path(path)
    try:
        # O_NONBLOCK: opening a FIFO must not wait for a writer; fstat of the open file
        # leaves no gap between the check and the read.
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0))
    except FileNotFoundError:
        raise InputFileError(p, f"{what} not found") from None
    except IsADirectoryError:
        raise InputFileError(p, f"is a directory, not {_a(what)}") from None
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the path
        reason = getattr(exc, "strerror", None) or str(exc)
        raise InputFileError(p, f"cannot open the {what}: {reason}") from None
    try:
        info = os.fstat(fd)
        if stat.S_ISDIR(info.st_mode):
            raise InputFileError(p, f"is a directory, not {_a(what)}")
        if not stat.S_ISREG(info.st_mode):
            raise InputFileError(
                p, f"not a regular file (a device, FIFO or socket): give {_a(what)} on disk"
            )
        if info.st_size > max_bytes:
            raise InputFileError(
                p, f"{what} too large: {info.st_size} bytes, at most {max_bytes} are read"
            )
        chunks: list[bytes] = []
        left = max_bytes + 1 if head is None else min(head, max_bytes + 1)
        while left > 0:
            chunk = os.read(fd, min(left, 1 << 20))
            if not chunk:
                break
            chunks.append(chunk)
            left -= len(chunk)
        data = b"".join(chunks)
    except OSError as exc:
        raise InputFileError(p, f"cannot read the {what}: {exc.strerror or exc}") from None
    finally:
        os.close(fd)
    if len(data) > max_bytes:  # it grew after the check
        raise InputFileError(p, f"{what} too large: more than {max_bytes} bytes")
    return data


def read_text_file(path: str | Path, *, max_bytes: int = MAX_YAML_BYTES, what: str = "file") -> str:
    """A regular UTF-8 text file of at most ``max_bytes`` (see :func:`read_regular_file`).

    Raises:
        InputFileError: as :func:`read_regular_file`, or the bytes are not UTF-8.
    """
    data = read_regular_file(path, max_bytes=max_bytes, what=what)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise InputFileError(
            path,
            f"not UTF-8 text (byte 0x{data[exc.start]:02x} on line {line}): save the {what} "
            "as UTF-8",
        ) from None


def load_yaml_file(
    path: str | Path,
    *,
    what: str = "config",
    max_bytes: int = MAX_YAML_BYTES,
    allow_empty: bool = False,
) -> Any:
    """Read and parse one YAML file under the module's limits.

    Args:
        path: The file.
        what: What it is, for messages (``config``, ``scene``).
        max_bytes: Largest file read [bytes].
        allow_empty: Return ``None`` for an empty file instead of refusing it.

    Raises:
        ConfigError: the file is missing, not a regular file, too large, not UTF-8, not
            YAML, or refused (see the module docstring); one line says which and where.
    """
    try:
        text = read_text_file(path, max_bytes=max_bytes, what=f"{what} file")
    except InputFileError as exc:
        raise ConfigError(exc.path, [exc.reason]) from None
    return load_yaml_text(text, source=str(path), what=what, allow_empty=allow_empty)


__all__ = [
    "ALLOWED_TAGS",
    "MAX_YAML_ALIASES",
    "MAX_YAML_BYTES",
    "MAX_YAML_DEPTH",
    "MAX_YAML_NODES",
    "load_yaml_file",
    "load_yaml_text",
    "read_regular_file",
    "read_text_file",
]
