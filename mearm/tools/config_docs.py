"""Write the configuration reference (docs/configuration.md) from the config models.

mearm config-docs                                  # the source checkout's docs/configuration.md
mearm config-docs --output FILE                    # anywhere (an installed wheel: required)
mearm config-docs --check docs/configuration.md    # exit 1 if it is stale

A file that is there is replaced only when it already holds the page written now (nothing
changes), or with --force: a file of the user's, an edited reference and one written from
other models alike. What --force replaces is kept first as FILE.bak (``FILE.bak.1`` beside
an earlier one: :func:`mearm.cli.backup_existing`), named on stdout (``wrote FILE.bak (the
old FILE)``).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from mearm.cli import (
    ArgumentParser,
    backup_existing,
    check_output_file,
    run,
    write_text_atomic,
)
from mearm.config.schema_doc import DEFAULT_OUTPUT, GENERATED_START, render
from mearm.data import source_checkout
from mearm.errors import MearmError
from mearm.fileio import backup_path


def default_output() -> Path | None:
    """The checkout's reference page, wherever the command runs; ``None`` from a wheel."""
    checkout = source_checkout()
    return None if checkout is None else checkout / DEFAULT_OUTPUT


def is_generated(path: Path) -> bool:
    """Whether the file at ``path`` starts with the header :func:`render` writes."""
    try:
        with path.open("rb") as fh:
            head = fh.read(len(GENERATED_START.encode()))
    except OSError:
        return False
    return head.decode("utf-8", errors="replace") == GENERATED_START


def _not_a_file(path: Path) -> str:
    """Why ``path``, which is not a regular file, cannot be checked (for ``--check``)."""
    if path.is_dir():
        return "is a folder, not a file: give the page's file (e.g. docs/configuration.md)"
    if path.exists():
        return "is not a regular file (a device, pipe or socket): give the page's file"
    if path.is_symlink():
        return "is a link to no file"
    return "no such file"


def main(argv: Sequence[str] | None = None) -> int:
    """Write the reference page, print it, or check that a written one is up to date."""
    default = default_output()
    parser = ArgumentParser(description=__doc__.splitlines()[0])
    group = parser.add_mutually_exclusive_group()
    where = (
        f"the source checkout's, {default}, from any folder"
        if default is not None
        else "none: an installed mearm has no source checkout, so give --output"
    )
    group.add_argument("--output", type=Path, help=f"write it to this file (default: {where})")
    group.add_argument(
        "--check", type=Path, metavar="FILE", help="exit 1 if FILE differs from the models"
    )
    group.add_argument("--stdout", action="store_true", help="print it instead")
    parser.add_argument(
        "--force",
        action="store_true",
        help="replace the output file even if it differs from the page written now (it is "
        "kept as FILE.bak)",
    )
    args = parser.parse_args(argv)
    if args.check is not None and not args.check.is_file():
        parser.error(f"--check {args.check}: {_not_a_file(args.check)}")
    if args.stdout:
        sys.stdout.write(render())
        return 0
    if args.check is not None:
        try:
            text = args.check.read_text(encoding="utf-8")
        except OSError as exc:
            parser.error(f"--check {args.check}: cannot read it: {exc.strerror or exc}")
        except UnicodeDecodeError:
            parser.error(f"--check {args.check}: not a text file (UTF-8)")
        if text != render():
            print(f"{parser.prog}: {args.check} is stale: run mearm config-docs --output "
                  f"{args.check} --force", file=sys.stderr)  # fmt: skip
            return 1
        return 0
    output = args.output if args.output is not None else default
    if output is None:
        parser.error(
            "no source checkout to write docs/configuration.md into (mearm is installed "
            "from a wheel): give --output FILE, or --stdout"
        )
    check_output_file(output, "--output")
    page = render()
    if output.exists() and not args.force and not _holds(output, page):
        kept = f"--force replaces it, keeping it as {backup_path(output)}"
        if is_generated(output):
            raise MearmError(
                f"--output {output}: a configuration reference that differs from the one "
                f"written now (edited, or from other models): not replaced; {kept}"
            )
        raise MearmError(
            f"--output {output}: exists and is not a configuration reference written before "
            f"(it lacks the generated header): not replaced; give another file, or {kept}"
        )
    try:
        backup_existing(output, page)  # not when it holds the page already
    except OSError as exc:
        raise MearmError(
            f"cannot keep {output} as {backup_path(output)}: {exc.strerror or exc}"
        ) from None
    write_text_atomic(output, page)
    print(f"wrote {output}")
    return 0


def _holds(path: Path, page: str) -> bool:
    """Whether the file at ``path`` holds ``page`` exactly (replacing it loses nothing)."""
    try:
        return path.read_bytes() == page.encode("utf-8")
    except OSError:
        return False


if __name__ == "__main__":
    run(main)
