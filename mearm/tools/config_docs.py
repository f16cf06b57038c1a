"""Write the configuration reference (docs/configuration.md) from the config models.

mearm config-docs                                  # writes docs/configuration.md
mearm config-docs --check docs/configuration.md    # exit 1 if it is stale
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from mearm.cli import ArgumentParser, check_output_file, run, write_text_atomic
from mearm.config.schema_doc import DEFAULT_OUTPUT, render


def main(argv: Sequence[str] | None = None) -> int:
    """Write the reference page, print it, or check that a written one is up to date."""
    parser = ArgumentParser(description=__doc__.splitlines()[0])
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "--output", type=Path, help=f"write it to this file (default: {DEFAULT_OUTPUT})"
    )
    group.add_argument(
        "--check", type=Path, metavar="FILE", help="exit 1 if FILE differs from the models"
    )
    group.add_argument("--stdout", action="store_true", help="print it instead")
    args = parser.parse_args(argv)
    if args.check is not None and not args.check.is_file():
        parser.error(f"--check {args.check}: no such file")
    if args.output is not None:
        check_output_file(args.output, "--output")
    text = render()
    if args.stdout:
        sys.stdout.write(text)
        return 0
    if args.check is not None:
        if args.check.read_text(encoding="utf-8") != text:
            print(f"{args.check} is stale: run mearm config-docs --output {args.check}",
                  file=sys.stderr)  # fmt: skip
            return 1
        return 0
    output = args.output or DEFAULT_OUTPUT
    write_text_atomic(output, text)
    print(f"wrote {output}")
    return 0


if __name__ == "__main__":
    run(main)
