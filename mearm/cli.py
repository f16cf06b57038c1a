"""Shared plumbing for the command-line tools.

Every CLI exits 2 on bad input with a single line on stderr (never a traceback), and
130 on Ctrl-C.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn, Protocol

from mearm.config import Config, load_config
from mearm.exceptions import MearmError

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


class ArgumentParser(argparse.ArgumentParser):
    """An ``argparse`` parser whose errors are one line on stderr and exit 2.

    It also accepts option values that start with a minus sign, such as
    ``--target -10.99,49.70,12.76`` (plain argparse takes that for an option).
    """

    def error(self, message: str) -> NoReturn:  # noqa: D102
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message}\n")

    def parse_known_args(  # type: ignore[override]  # noqa: D102
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        argv = list(sys.argv[1:] if args is None else args)
        return super().parse_known_args(self._attach_negative_values(argv), namespace)

    def _attach_negative_values(self, argv: list[str]) -> list[str]:
        """``--opt -1.5,2`` → ``--opt=-1.5,2`` for options that take a value."""
        out: list[str] = []
        i = 0
        while i < len(argv):
            action = self._option_string_actions.get(argv[i])
            nxt = argv[i + 1] if i + 1 < len(argv) else ""
            if action is not None and action.nargs != 0 and re.match(r"^-[\d.]", nxt):
                out.append(f"{argv[i]}={nxt}")
                i += 2
            else:
                out.append(argv[i])
                i += 1
        return out


def float_list(n: int | None = None, name: str = "values") -> Callable[[str], list[float]]:
    """An argparse type for comma-separated numbers, e.g. ``120,93,-132``."""

    def parse(text: str) -> list[float]:
        try:
            values = [float(v) for v in text.split(",")]
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{name} must be comma-separated numbers, got {text!r}"
            ) from None
        if n is not None and len(values) != n:
            raise argparse.ArgumentTypeError(
                f"{name} needs {n} numbers, got {len(values)}: {text!r}"
            )
        if not all(v == v and abs(v) != float("inf") for v in values):
            raise argparse.ArgumentTypeError(f"{name} must be finite numbers, got {text!r}")
        return values

    return parse


class ArgumentContainer(Protocol):
    """What takes arguments: an ``argparse`` parser or an argument group of one."""

    def add_argument(self, *args: Any, **kwargs: Any) -> argparse.Action: ...  # noqa: D102


def add_config_argument(parser: ArgumentContainer) -> None:
    """Add ``--config PATH`` and ``--set dotted.key=value`` to a parser or group."""
    parser.add_argument(
        "--config",
        type=Path,
        default=None,
        help="YAML config (default: the built-in simulated rig, as configs/sim.yaml)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override one config value before validation, e.g. "
        "--set arm.joints.shoulder.limits.max=140 (repeatable)",
    )


def config_from_args(args: argparse.Namespace) -> Config:
    """Load the config named by ``--config`` with every ``--set`` applied."""
    return load_config(args.config, getattr(args, "set", None) or ())


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same directory.

    Raises:
        MearmError: the directory cannot be made or the file written.
    """
    tmp = path.with_name(f".{path.name}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise MearmError(f"cannot write {path}: {exc}") from None


def _program_name() -> str:
    """``python -m mearm.ik`` for a module run with -m, else the script's name."""
    if sys.argv and sys.argv[0].startswith("mearm "):
        return sys.argv[0]  # a subcommand of the mearm command
    spec = getattr(sys.modules.get("__main__"), "__spec__", None)
    if spec is not None and spec.name and spec.name != "mearm.__main__":
        return "python -m " + spec.name.removesuffix(".__main__")
    return Path(sys.argv[0]).name if sys.argv and sys.argv[0] else "mearm"


def run(main: Callable[[Sequence[str] | None], int], argv: Sequence[str] | None = None) -> NoReturn:
    """Run a CLI ``main``; turn :class:`MearmError` into exit 2 and Ctrl-C into 130."""
    prog = _program_name()
    try:
        code = main(argv)
    except MearmError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        code = EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        code = EXIT_INTERRUPTED
    sys.exit(code)
