"""The base of every error mearm raises on purpose, and the errors of reading input.

Every error the package raises on purpose derives from :class:`MearmError`, so a caller
(and every CLI) can catch one type. Subclasses name the cause and keep the offending
values as attributes; their messages say what was wrong and what is allowed.

Each family lives next to the code that raises it (``mearm/<package>/errors.py``, or
beside the one module that raises it); :mod:`mearm.exceptions` names the library's (the
commands' own errors, ``mearm.maker`` and ``mearm.tools``, stay with them). Here are
the ones every layer raises, from the YAML reader (:mod:`mearm.yamlio`) up: a bad file,
a bad configuration value.
"""

from __future__ import annotations

import reprlib
from collections.abc import Sequence


class MearmError(Exception):
    """Base class for all errors raised by mearm.

    Attributes:
        exit_status: What a command that stops on this error exits with: 2, bad input,
            unless the error is a failure of the run itself (a disk that filled: 1).
    """

    exit_status: int = 2

    def __reduce__(self) -> tuple[object, ...]:
        """Pickle as this error, message and attributes (a worker process's, sent back).

        ``Exception`` pickles as its class called on its message, which re-runs a
        subclass's ``__init__`` on it: the message said twice (an extra's missing module),
        or no error at all where ``__init__`` takes other arguments (``ConfigError``).
        """
        return (_rebuilt, (type(self), self.args, self.__dict__))


def _rebuilt(cls: type[MearmError], args: tuple[object, ...], state: dict) -> MearmError:
    """A pickled :class:`MearmError` as it was raised (:meth:`MearmError.__reduce__`)."""
    error = cls.__new__(cls)
    error.args = args
    error.__dict__.update(state)
    return error


class ConfigError(MearmError):
    """A configuration file is missing, malformed or has invalid values.

    Attributes:
        path: The file that was read, or ``None`` for an in-memory mapping.
        problems: One line per bad field: its dotted path, the value, what is allowed.
    """

    def __init__(self, path: str | None, problems: Sequence[str]):
        self.path = path
        self.problems = list(problems)
        where = f"{path}: " if path else ""
        if len(self.problems) == 1:
            super().__init__(f"{where}{self.problems[0]}")
        else:
            lines = "; ".join(self.problems)
            super().__init__(f"{where}{len(self.problems)} problems: {lines}")


class InputFileError(MearmError):
    """An input file cannot be read safely: missing, not a regular file, too large, not text.

    Attributes:
        path: The file.
        reason: What is wrong with it and what to do.
    """

    def __init__(self, path: object, reason: str):
        self.path = str(path)
        self.reason = reason
        super().__init__(f"{self.path}: {reason}")


_REPR = reprlib.Repr()
_REPR.maxstring = _REPR.maxother = 40


def wrong_argument(user: str, needs: str, value: object, fix: str | None = None) -> str:
    """The message for a wrong object given to a public entry point.

    What ``user`` (the entry point) ``needs`` and what it got instead: an object of one of
    the package's (or a library's) classes by its type's name, a plain value (``None``, a
    string, a number, a list) by a short repr; then, when known, what to pass instead
    (``fix``: e.g. ``config.controller`` for a whole config given where its section is
    wanted). A check by ``isinstance`` at construction turns the ``AttributeError`` a
    wrong object gave deep inside (which named neither the argument nor the remedy)
    into one named error, raised by the caller with this message.
    """
    kind = type(value)
    if value is None or kind.__module__ == "builtins":
        got = _REPR.repr(value)
    else:
        name = kind.__name__
        got = f"{'an' if name[:1].lower() in 'aeiou' else 'a'} {name}"
    return f"{user} needs {needs}, got {got}" + (f": pass {fix}" if fix else "")


def whole_config(value: object) -> bool:
    """Whether ``value`` is the whole configuration (``mearm.config.Config``), by its parts.

    The layers below the simulators never import ``Config`` (they are passed its
    sections); a wrong argument's message still says "pass config.controller" when the
    whole config was given.
    """
    return all(hasattr(value, part) for part in ("arm", "task", "controller", "vision"))
