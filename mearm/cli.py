"""Shared plumbing for the command-line tools.

Every CLI exits 2 on bad input with a single line on stderr (never a traceback), and
130 on Ctrl-C.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NoReturn

from mearm.config import Config, load_config
from mearm.exceptions import MearmError

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


class ArgumentParser(argparse.ArgumentParser):
    """An ``argparse`` parser whose errors are one line on stderr and exit 2."""

    def error(self, message: str) -> NoReturn:  # noqa: D102
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message}\n")


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


def add_config_argument(parser: argparse.ArgumentParser) -> None:
    """Add ``--config PATH`` (default: the embedded simulated rig)."""
    parser.add_argument(
        "--config",
        type=Path,
        default=None,
        help="YAML config (default: the built-in simulated rig, as configs/sim.yaml)",
    )


def config_from_args(args: argparse.Namespace) -> Config:
    """Load the config named by ``--config``."""
    return load_config(args.config)


def run(main: Callable[[Sequence[str] | None], int], argv: Sequence[str] | None = None) -> NoReturn:
    """Run a CLI ``main``; turn :class:`MearmError` into exit 2 and Ctrl-C into 130."""
    prog = Path(sys.argv[0]).stem if sys.argv and sys.argv[0] else "mearm"
    try:
        code = main(argv)
    except MearmError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        code = EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        code = EXIT_INTERRUPTED
    sys.exit(code)
